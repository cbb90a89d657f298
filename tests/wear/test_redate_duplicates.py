"""A changed ``time`` specification re-dates stored recordings; a copy of a recording is
estimated once and reported once (exploration: re-ingest said '0 new … 6 already in the store'
and the dates stayed wrong; a copy 'x - Kopie' was re-estimated on every run)."""

from __future__ import annotations

import json
import os
import shutil
from datetime import UTC, datetime
from pathlib import Path

import pytest

from drivelash.errors import ConfigError
from drivelash.wear import Store, ingest, load_fleet

FILENAME_TIME = """time = { from = "filename", pattern = '_(\\d{8}T\\d{6})', format = "%Y%m%dT%H%M%S" }"""


def _tiny(small_fleet: Path, dst: Path, time_line: str) -> Path:
    """One axis (M01/X), its first 3 recordings; mtimes set to known instants."""
    (dst / "rec").mkdir(parents=True)
    (dst / "drives").mkdir()
    shutil.copy(small_fleet / "drives" / "M01-X.toml", dst / "drives" / "M01-X.toml")
    truth = json.loads((small_fleet / "truth.json").read_text())["axes"]["M01/X"]["recordings"]
    good = [r["file"] for r in truth if r["excited"] and r["corrupt"] is None][:3]
    for k, rel in enumerate(good):
        p = small_fleet / rel
        q = dst / "rec" / p.name
        shutil.copy(p, q)
        t = datetime(2026, 6, 1 + k, 12, 0, tzinfo=UTC).timestamp()
        os.utime(q, (t, t))
    return _write(dst, time_line)


def ingested_with_a_copy(small_fleet: Path, tmp_path: Path) -> tuple[Path, Store, Path, Path]:
    """A tiny fleet ingested once, then one recording copied under a new name (not ingested):
    (fleet dir, store, original, copy)."""
    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(f), st, workers=1)
    orig = sorted((tmp_path / "f" / "rec").glob("*.parquet"))[0]
    copy = orig.with_name(orig.stem + " - Kopie.parquet")
    shutil.copy(orig, copy)
    return f, st, orig, copy


def _write(dst: Path, time_line: str) -> Path:
    f = dst / "fleet.toml"
    f.write_text(
        f'[fleet]\n{time_line}\n[[axis]]\nid = "M01/X"\ndrive = "drives/M01-X.toml"\n'
        'recordings = "rec/*.parquet"\nthreshold = 0.2\n'
    )
    return f


def _starts(st: Store) -> list[datetime]:
    return [r["start_time"] for r in st.estimates("M01/X")]


def test_changed_time_spec_re_dates_stored_recordings(small_fleet, tmp_path):
    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    st = Store(tmp_path / "w.sqlite")
    rep = ingest(load_fleet(f), st, workers=1)
    assert rep.planned == 3 and rep.redated == 0 and not rep.failures, rep.failures
    days = [t.day for t in _starts(st)]
    assert all(t.month == 1 for t in _starts(st)) and len(days) == 3  # January, from the file names
    # negative control: the same specification again re-dates nothing
    assert ingest(load_fleet(f), st, workers=1).redated == 0
    _write(tmp_path / "f", 'time = { from = "mtime" }')
    rep = ingest(load_fleet(f), st, workers=1)
    assert rep.planned == 0 and rep.skipped == 3 and rep.redated == 3
    assert _starts(st) == [datetime(2026, 6, d, 12, 0) for d in (1, 2, 3)]
    # a time column that does not exist: one line naming file, key and recording; nothing written
    _write(tmp_path / "f", 'time = { from = "column", column = "Zeit" }')
    with pytest.raises(ConfigError) as exc:
        ingest(load_fleet(f), st, workers=1)
    msg = str(exc.value)
    assert "\n" not in msg and msg.startswith(str(f.resolve()))
    assert "key 'time.column' = 'Zeit': cannot re-date" in msg and "no such column" in msg
    assert _starts(st) == [datetime(2026, 6, d, 12, 0) for d in (1, 2, 3)]


def test_a_copy_is_estimated_once_and_reported_once(small_fleet, tmp_path):
    f, st, orig, copy = ingested_with_a_copy(small_fleet, tmp_path)
    rep = ingest(load_fleet(f), st, workers=1)
    assert rep.planned == 0 and rep.stored == 0  # its content is stored: not estimated again
    assert rep.duplicates == [f"{copy}: same content as {orig} (stored once, estimated once)"]
    rep = ingest(load_fleet(f), st, workers=1)  # the run that re-estimated it every time
    assert rep.planned == 0 and rep.skipped == 4 and rep.duplicates == []
    paths = [r["path"] for r in st.estimates("M01/X")]
    assert len(paths) == 3 and str(orig) in paths and str(copy) not in paths
