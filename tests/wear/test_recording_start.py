"""The start time of a recording from a file column: POSIX stamps and ISO 8601 stamps."""

from __future__ import annotations

from datetime import datetime

import numpy as np
import pytest

from drivelash.errors import DataError
from drivelash.wear.estimate import recording_start
from drivelash.wear.fleet import TimeSpec


def test_start_from_a_posix_column(tmp_path):
    """``from = "column"``: the first value is a POSIX time in the stated unit (closed form:
    1764248400 s = 2025-11-27 13:00:00 UTC)."""
    p = tmp_path / "r.csv"
    t0 = 1764248400.0
    p.write_text("stamp,theta_m\n" + "".join(f"{(t0 + k * 1e-3) * 1e3!r},{k}\n" for k in range(5)))
    spec = TimeSpec.model_validate({"from": "column", "column": "stamp", "unit": "ms"})
    assert recording_start(p, spec) == datetime(2025, 11, 27, 13, 0, 0)


def test_start_from_an_iso_stamp_column_is_the_first_stamp(tmp_path):
    """A column of ISO 8601 stamps is read as seconds from its first stamp, so its first value
    is 0; the start is the first stamp (in UTC), not 1970-01-01 (the value 0 as POSIX time)."""
    p = tmp_path / "r.csv"
    rows = "".join(f"2026-03-02T08:15:00.{k:03d}+01:00,{float(np.sin(k))!r}\n" for k in range(5))
    p.write_text("time,theta_m\n" + rows)
    spec = TimeSpec.model_validate({"from": "column", "column": "time"})
    assert recording_start(p, spec) == datetime(2026, 3, 2, 7, 15, 0)
    with pytest.raises(DataError, match="no such column for the start time"):
        recording_start(p, TimeSpec.model_validate({"from": "column", "column": "stamp"}))


def test_start_from_a_parquet_time_stamp_column(tmp_path):
    """A pandas datetime64 column in Parquet (tz-aware): the start is its first stamp in UTC."""
    import pandas as pd

    p = tmp_path / "r.parquet"
    stamps = pd.Timestamp("2026-03-02 08:15:00", tz="Europe/Berlin") + pd.to_timedelta(
        np.arange(5) * 1e-3, unit="s"
    )
    pd.DataFrame({"time": stamps, "theta_m": np.arange(5.0)}).to_parquet(p)
    spec = TimeSpec.model_validate({"from": "column", "column": "time"})
    assert recording_start(p, spec) == datetime(2026, 3, 2, 7, 15, 0)
