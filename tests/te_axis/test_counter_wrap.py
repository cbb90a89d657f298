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
