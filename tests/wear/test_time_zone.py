"""``time.zone`` (session 30 tester B, B-09): a controller writing local wall-clock stamps
without an offset (``2026-01-06T08:00`` in CET) was stored as 08:00 UTC, 1 h off, next to files
of the same axis whose stamps carry ``+01:00`` — without a word. ``zone = "Europe/Berlin"`` now
reads such stamps in local time (file name, ISO column, metadata); a stamp with an offset keeps
it; the default stays UTC, and its specification hash is the one stored before the key existed
(no re-dating of existing stores). References: the offsets by hand (CET = UTC+1 in January,
CEST = UTC+2 in July)."""

from __future__ import annotations

import hashlib
import json
import re
from datetime import datetime
from pathlib import Path

import pytest
from pydantic import ValidationError

from drivelash.wear.estimate import recording_start
from drivelash.wear.fleet import TimeSpec, time_spec_hash


def _csv(tmp_path: Path, stamp: str) -> Path:
    """Five rows 1 s apart whose first stamp is ``stamp`` (its seconds field is 10)."""
    p = tmp_path / "rec.csv"
    rows = "".join(f"{stamp.replace(':10', f':{10 + i}')},{0.1 * i}\n" for i in range(5))
    p.write_text("t,theta_m\n" + rows)
    return p


@pytest.mark.parametrize(
    ("stamp", "zone", "utc"),
    [
        ("2026-01-06T08:00:10", "UTC", datetime(2026, 1, 6, 8, 0, 10)),  # the default: as before
        ("2026-01-06T08:00:10", "Europe/Berlin", datetime(2026, 1, 6, 7, 0, 10)),  # CET
        ("2026-07-06T08:00:10", "Europe/Berlin", datetime(2026, 7, 6, 6, 0, 10)),  # CEST
        ("2026-01-06T08:00:10+00:00", "Europe/Berlin", datetime(2026, 1, 6, 8, 0, 10)),  # keeps its offset
    ],
)
def test_column_stamps_without_an_offset_are_read_in_the_zone(tmp_path, stamp, zone, utc):
    spec = TimeSpec.model_validate({"from": "column", "column": "t", "zone": zone})
    assert recording_start(_csv(tmp_path, stamp), spec) == utc


def test_file_name_and_metadata_stamps_too(tmp_path):
    p = tmp_path / "X_20260106T080000.parquet"
    fn = {"from": "filename", "pattern": r"(\d{8}T\d{6})", "format": "%Y%m%dT%H%M%S"}
    assert recording_start(p, TimeSpec.model_validate(fn)) == datetime(2026, 1, 6, 8)
    berlin = TimeSpec.model_validate(fn | {"zone": "Europe/Berlin"})
    assert recording_start(p, berlin) == datetime(2026, 1, 6, 7)
    md = TimeSpec.model_validate({"from": "metadata", "zone": "Europe/Berlin"})
    assert recording_start(p, md, {"start_time": "2026-01-06T08:00:00"}) == datetime(2026, 1, 6, 7)


def test_default_zone_keeps_the_stored_hash_and_a_bad_zone_is_refused():
    fn = {"from": "filename", "pattern": r"(\d{8}T\d{6})", "format": "%Y%m%dT%H%M%S"}
    old = {"from": "filename", "pattern": fn["pattern"], "format": fn["format"], "column": None,
           "unit": "s", "key": "start_time"}  # fmt: skip
    before = hashlib.sha256(json.dumps(old, sort_keys=True).encode()).hexdigest()
    assert time_spec_hash(TimeSpec.model_validate(fn)) == before
    assert time_spec_hash(TimeSpec.model_validate(fn | {"zone": "UTC"})) == before
    assert time_spec_hash(TimeSpec.model_validate(fn | {"zone": "Europe/Berlin"})) != before
    with pytest.raises(ValidationError, match=re.escape("zone 'CET+1' is not a time zone name")):
        TimeSpec.model_validate(fn | {"zone": "CET+1"})
