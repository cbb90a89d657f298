"""``[sampling] resample = true`` is for jitter, not for holes (finding A11, session 20 tester A).

Before: a pass with a 2 s hole (a lost trace buffer) was bridged by linear interpolation —
2000 invented samples over 40 mm, TE up to 6.4 µm off — with only "non-uniform sampling;
resampled linearly". Now a stretch of more than MAX_BRIDGED_PERIODS sample periods bridged
while the table moved is refused in one line naming file, time, length and travel; jitter
is still resampled (negative control).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from drivelash.errors import DataError
from drivelash.te.protocol.importer import MAX_BRIDGED_PERIODS, import_campaign

from .synth import standard_runs, write_axis

RESAMPLE = "\n[sampling]\nresample = true\n"


def _axis(tmp_path, spoil):
    runs = [dataclasses.replace(r, lo=0.05, hi=0.45) for r in standard_runs(loads=(0.0, 1500.0, 3000.0))]
    axis = write_axis(tmp_path / "rec", runs, extra_toml=RESAMPLE)
    f = sorted((tmp_path / "rec").glob("run04_*.csv"))[0]
    df = spoil(pd.read_csv(f))
    df.to_csv(f, index=False, float_format="%.9f")
    return axis, f


def test_a_hole_bridged_by_resampling_is_refused_naming_time_and_length(tmp_path):
    # run04 moves at 100 mm/s sampled at 1 kHz: rows 1000-1999 (1 s, 100 mm) removed
    axis, f = _axis(tmp_path, lambda df: df.drop(index=range(1000, 2000)).reset_index(drop=True))
    with pytest.raises(DataError) as err:
        import_campaign(axis, tmp_path / "camp")
    msg = str(err.value)
    assert "\n" not in msg and str(f) in msg and "column 't'" in msg, msg
    # 1000 intervals of 1 ms missing -> the hole spans 1.001 s between the samples around it
    assert "bridged a gap of 1.001 s (1001 sample periods, 100 mm of travel) at t = 0.999 s" in msg, msg
    assert not (tmp_path / "camp").exists()


def test_jitter_is_still_resampled(tmp_path):
    """Negative control: every time stamp ±0.2 ms off (intervals 0.6-1.4 ms) imports with the
    resampling warning; no stretch of more than MAX_BRIDGED_PERIODS periods is exactly linear."""
    rng = np.random.default_rng(1)

    def jitter(df):
        df["time_ms"] = df["time_ms"] + rng.uniform(-0.2, 0.2, len(df))
        return df

    axis, f = _axis(tmp_path, jitter)
    warnings: list[str] = []
    import_campaign(axis, tmp_path / "camp", warn=warnings.append)
    assert any(str(f) in w and "resampled linearly" in w for w in warnings), warnings
    assert MAX_BRIDGED_PERIODS == 10


def test_jitter_without_resample_names_the_axis_file_key_not_an_option(tmp_path):
    """Tester H, TH9: the refusal advised "--resample", an option te import does not have."""
    rng = np.random.default_rng(1)

    def jitter(df):
        df["time_ms"] = df["time_ms"] + rng.uniform(-0.2, 0.2, len(df))
        return df

    axis, f = _axis(tmp_path, jitter)
    axis.write_text(axis.read_text().replace(RESAMPLE, "\n"))
    with pytest.raises(DataError) as err:
        import_campaign(axis, tmp_path / "camp")
    msg = str(err.value)
    assert str(f) in msg and "non-uniform sampling" in msg, msg
    assert "--resample" not in msg and "[sampling] resample = true in the axis file" in msg, msg
    assert not (tmp_path / "camp").exists()
