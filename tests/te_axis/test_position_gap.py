"""Samples lost under uniform time stamps: a jump of x_T between two samples is refused (A15).

Before (session 20, tester A): a trace renumbered by sample index (time = index × period) that
lost 2 s of samples showed a 40 mm jump of x_T and θ_M between two samples; it was imported and
fitted silently and the 50 µm grid held a straight line over 39 mm, TE up to 6.4 µm off. Now a
step beyond the tooth-mesh limit (pitch/6, the spacing error limit) while moving is an error
naming the file, the samples, the time and the step.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from drivelash.errors import DataError
from drivelash.te.protocol.importer import import_campaign

from .synth import standard_runs, write_axis


def _axis(tmp_path, drop: bool):
    runs = [dataclasses.replace(r, lo=0.05, hi=0.45) for r in standard_runs(loads=(0.0, 1500.0, 3000.0))]
    axis = write_axis(tmp_path / "rec", runs)
    f = sorted((tmp_path / "rec").glob("run04_*.csv"))[0]
    df = pd.read_csv(f)
    if drop:  # 1 s of samples lost at 100 mm/s, the time stamps renumbered (uniform 1 ms)
        df = df.drop(index=range(1000, 2000)).reset_index(drop=True)
        df["time_ms"] = np.arange(len(df), dtype=float)
    df.to_csv(f, index=False, float_format="%.9f")
    return axis, f


def test_a_jump_of_the_position_is_refused_naming_the_samples(tmp_path):
    axis, f = _axis(tmp_path, drop=True)
    with pytest.raises(DataError) as err:
        import_campaign(axis, tmp_path / "camp")
    msg = str(err.value)
    # the step from the sample before the hole (0.999 s) to the one after it: 100 mm + one 0.1 mm step
    assert str(f) in msg and "x_T jumps by 100.1 mm between samples 999 and 1000 (t = 0.999 s" in msg, msg
    assert "samples lost?" in msg and "\n" not in msg


def test_the_complete_pass_imports(tmp_path):
    """Negative control: the same file without the hole imports."""
    axis, _ = _axis(tmp_path, drop=False)
    import_campaign(axis, tmp_path / "camp")
    assert (tmp_path / "camp" / "manifest.json").is_file()
