"""Session 31, tester D (D6, D7, D11): single-turn motor encoders, a fit with no held-out load,
a `[geometry]` that its recordings or its own tooth geometry contradict.

The synthetic axis of :mod:`.synth` (known TE, exact kinematics, 1 m travel); no fit is run.
"""

from __future__ import annotations

import dataclasses

from drivelash.te.learn.fit import default_holdout, holdout_limitations
from drivelash.te.protocol.plausibility import check_runs

from .synth import BENCH, record, standard_runs

SHORT = {"lo": 0.05, "hi": 0.45}


def _records():
    return [record(dataclasses.replace(r, **SHORT), f"run{i:02d}.csv") for i, r in enumerate(standard_runs())]


def _check(recs, tooth_pitch=BENCH.tooth_pitch, **kw):
    kw.setdefault("max_load", 3000.0)
    return check_runs(recs, BENCH.r_eff, tooth_pitch, BENCH.travel, source="axis.toml", **kw)


def _found(rep, check):
    return [f for f in rep.findings if f.check == check]


# --- D7: no held-out load ------------------------------------------------------------------------------


def test_no_held_out_load_is_a_stated_limitation():
    """Before: the fit printed 'held out: none' and the training MAE only; model.json had no word."""
    loads = (0.0, 2500.0, 5000.0)
    holdout = default_holdout(loads, 3000.0)
    assert holdout == ()
    (line,) = holdout_limitations(loads, 3000.0, holdout)
    assert "accuracy between the training loads is not measured" in line
    assert "2 training loads: 0, 2500 N" in line


def test_a_held_out_load_has_no_limitation_line():
    """Negative control: 0 … 3000 N in 1000 N steps holds 1500 … out — the accuracy between the
    training loads is measured."""
    loads = (0.0, 1000.0, 2000.0, 3000.0)
    holdout = default_holdout(loads, 3000.0)
    assert holdout and holdout_limitations(loads, 3000.0, holdout) == []
