"""Time in s under a ``unit = "ms"`` mapping is refused when nothing else cross-checks it (A10).

Before (session 20, tester A): without a velocity column a pass recorded in s but declared in
ms was imported as "10 m/s sampled at 1 MHz" (the listed velocity only warned, and a run
without one passed silently). Now a pass faster than MAX_PASS_SPEED or sampled faster than
MAX_SAMPLE_RATE is an error naming the file and the time column's unit.
"""

from __future__ import annotations

import dataclasses

import pandas as pd
import pytest

from drivelash.errors import DataError
from drivelash.te.protocol.importer import import_campaign

from .synth import standard_runs, write_axis


def _axis(tmp_path, factor: float):
    runs = [dataclasses.replace(r, lo=0.05, hi=0.45) for r in standard_runs(loads=(0.0, 1500.0, 3000.0))]
    axis = write_axis(tmp_path / "rec", runs)
    f = sorted((tmp_path / "rec").glob("run04_*.csv"))[0]
    df = pd.read_csv(f)
    df["time_ms"] = df["time_ms"] * factor  # 1e-3: the file in s, the mapping still "ms"
    df.to_csv(f, index=False, float_format="%.9f")
    return axis, f


def test_time_in_seconds_declared_as_ms_is_refused(tmp_path):
    axis, f = _axis(tmp_path, 1e-3)
    with pytest.raises(DataError) as err:
        import_campaign(axis, tmp_path / "camp")
    msg = str(err.value)
    # run04 moves at 100 mm/s at 1 kHz: read with ms it is 100 m/s at 1 MHz
    assert str(f) in msg and "moves at 100 m/s sampled at 1e+06 Hz" in msg, msg
    assert "unit of the time column" in msg and "\n" not in msg


def test_the_same_file_in_ms_imports(tmp_path):
    """Negative control: the unchanged file (factor 1) imports without error."""
    axis, _ = _axis(tmp_path, 1.0)
    import_campaign(axis, tmp_path / "camp")
    assert (tmp_path / "camp" / "manifest.json").is_file()
