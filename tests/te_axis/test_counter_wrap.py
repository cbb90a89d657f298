"""A multi-turn counter that wraps at several revolutions is named with the ``wrap`` to declare (A2).

Before (session 20, tester A): a 22-bit counter of a 2^20 encoder (wraps every 4 revolutions)
kept its jumps, and the import blamed the gear data ("check i_PG, m_n, n_t …"). Now the loader
names the column, the line of the first jump, its size and ``wrap = 2^k``.
"""

from __future__ import annotations

import dataclasses

import pandas as pd
import pytest

from drivelash.errors import DataError
from drivelash.te.protocol.importer import import_campaign

from .synth import CPR, standard_runs, write_axis

W = 4 * CPR  # a counter of 4 revolutions (2^27 counts)


def test_a_four_turn_counter_is_named_with_its_wrap(tmp_path):
    runs = [dataclasses.replace(r, lo=0.05, hi=0.45) for r in standard_runs(loads=(0.0, 1500.0, 3000.0))]
    axis = write_axis(tmp_path / "rec", runs)
    f = sorted((tmp_path / "rec").glob("run04_*.csv"))[0]
    df = pd.read_csv(f)
    assert df["enc_motor"].max() - df["enc_motor"].min() > 2 * W  # the pass spans > 8 revolutions
    df["enc_motor"] = df["enc_motor"].astype("int64") % W
    first = int((df["enc_motor"].diff().abs() > W / 2).idxmax())  # 0-based data row of the first jump
    df.to_csv(f, index=False, float_format="%.9f")
    with pytest.raises(DataError) as err:
        import_campaign(axis, tmp_path / "camp")
    msg = str(err.value)
    assert "\n" not in msg and str(f) in msg and "column 'enc_motor'" in msg, msg
    assert f"line {first + 2}:" in msg, (first, msg)  # + the header line, 1-based
    assert f"declare wrap = {W}" in msg and "(4 revolutions)" in msg, msg
    assert "i_PG" not in msg


def _wrapping_axis(tmp_path):
    """Every pass's motor counter is a 32-bit register that wraps inside the travel (tester H, TH5);
    the axis file declares ``wrap = 2^32``."""
    import numpy as np

    from .synth import BENCH

    runs = [dataclasses.replace(r, lo=0.05, hi=0.45) for r in standard_runs(loads=(0.0, 1500.0, 3000.0))]
    axis = write_axis(tmp_path / "rec", runs)
    off = 2**31 - round(0.25 / (2 * np.pi * BENCH.r_eff) * CPR)  # the register wraps at x_T ≈ 250 mm
    for f in sorted((tmp_path / "rec").glob("run*.csv")):
        df = pd.read_csv(f)
        df["enc_motor"] = (df["enc_motor"].astype("int64") + off + 2**31) % 2**32 - 2**31
        df.to_csv(f, index=False, float_format="%.9f")
    text = axis.read_text().replace(f"counts_per_rev = {CPR}", f"counts_per_rev = {CPR}\nwrap = 4294967296")
    axis.write_text(text)
    return axis


def test_a_wrapping_register_gives_one_zero_for_every_file(tmp_path):
    """Before: each file unwrapped from its own first sample, so the +1 passes (starting before the
    wrap) and the −1 passes (after it) came out 2^32 counts apart and no single offset fixed both
    ("set offset = −3145.86", then "+3288.13"). Now one offset is advised and, set, imports."""
    import re
    import warnings as _w

    axis = _wrapping_axis(tmp_path)
    notes: list[str] = []
    with pytest.raises(DataError) as err:
        import_campaign(axis, tmp_path / "c1", warn=notes.append)
    first = list(notes)
    m = re.search(r"set offset = (-?\d+\.\d+) \(rad\) on the theta_m column", str(err.value))
    assert m, str(err.value)
    text = axis.read_text().replace("wrap = 4294967296", f"wrap = 4294967296\noffset = {m.group(1)}")
    axis.write_text(text)
    with _w.catch_warnings():
        notes.clear()
        import_campaign(axis, tmp_path / "c2", warn=notes.append)  # imports: one zero fits all files
    assert (tmp_path / "c2" / "manifest.json").exists()
    assert not [n for n in notes if "TE is" in n or "mixed" in n], notes
    assert any("shifted by whole periods of wrap = 4.29497e+09" in n for n in first), first
