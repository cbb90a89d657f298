"""An inverted linear scale is named as such, not as an encoder sign (finding A14).

Before (session 20, tester A): x_T counting the other way was refused with "set scale = -1 on
the theta_m column"; following it led to "fix 'direction' of this run" for every run and a
mirrored campaign. The listed direction decides which of the two counts the other way: the
motor agrees with it here, so the scale is the odd one.
"""

from __future__ import annotations

import dataclasses

from drivelash.te.protocol.plausibility import check_runs

from .synth import BENCH, record, standard_runs


def _rep(spoil):
    runs = [dataclasses.replace(r, lo=0.05, hi=0.45) for r in standard_runs()]
    recs = [record(r, f"run{i:02d}.csv") for i, r in enumerate(runs)]
    recs[2] = spoil(recs[2])
    return check_runs(recs, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0)


def test_an_inverted_scale_is_named_on_the_x_T_column():
    rep = _rep(lambda r: dataclasses.replace(r, x_T=-r.x_T))
    (f,) = [f for f in rep.findings if f.check == "ratio"]
    assert f.file == "run02.csv" and "the linear scale counts against the motor" in f.message, f.message
    assert "set scale = -1 on the x_T column" in f.message and "theta_m" not in f.message


def test_an_inverted_encoder_is_still_named_on_theta_m():
    """Negative control: the motor angle negated (the scale agrees with the listed direction)."""
    rep = _rep(lambda r: dataclasses.replace(r, theta_m=-r.theta_m))
    (f,) = [f for f in rep.findings if f.check == "ratio"]
    assert "(encoder sign)" in f.message and "set scale = -1 on the theta_m column" in f.message, f.message
