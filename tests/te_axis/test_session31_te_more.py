"""Session 31, tester D (D6, D7, D11): single-turn motor encoders, a fit with no held-out load,
a `[geometry]` that its recordings or its own tooth geometry contradict.

The synthetic axis of :mod:`.synth` (known TE, exact kinematics, 1 m travel); no fit is run.
"""

from __future__ import annotations

import dataclasses
import math
import re

import pytest

from drivelash.physics.rack_pinion import RackPinionBench
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


# --- D6: a single-turn motor position -------------------------------------------------------------


def _single_turn(recs):
    """Each run's motor angle as a single-turn encoder gives it, unwrapped within the run: its
    first sample in [0, 2π)."""
    out = []
    for r in recs:
        th0 = float(r.theta_m[0])
        out.append(
            dataclasses.replace(r, theta_m=r.theta_m - th0 + math.fmod(th0, 2 * math.pi) % (2 * math.pi))
        )
    return out


def test_single_turn_motor_position_is_named_without_offset_advice():
    """Before: "TE is +… mm … set offset = … (rad) on the theta_m column" for the first run, and
    after following it the next run's different zero (the advice chased run by run)."""
    rep = _check(_single_turn(_records()))
    zero = _found(rep, "zero")
    assert len(zero) == 1 and zero[0].level == "error", [f.line() for f in zero]
    msg = zero[0].message
    assert "single-turn / reset per run" in msg and "record the multi-turn (absolute) position" in msg
    assert "set offset" not in msg
    assert rep.errors[0] is zero[0]  # the one line the user sees


def test_common_motor_zero_still_gets_the_offset_advice():
    """Negative control: multi-turn counts with one arbitrary zero (all runs alike) — the theta_m
    offset fixes it, so the advice stays; and the clean campaign has no zero finding."""
    recs = _records()
    assert not _found(_check(recs), "zero")
    shifted = [dataclasses.replace(r, theta_m=r.theta_m + 1000.3) for r in recs]
    zero = _found(_check(shifted), "zero")
    assert zero and all("on the theta_m column" in f.message for f in zero)
    assert not any("single-turn" in f.message for f in zero)


def test_runs_starting_at_one_place_are_not_called_single_turn():
    """Negative control: runs all starting at the same x_T cannot tell a single-turn encoder
    from a common zero: the offset advice (which then works) stays."""
    recs = [r for r in _records() if r.direction > 0]
    recs = [dataclasses.replace(r, theta_m=r.theta_m + 1000.3) for r in _single_turn(recs)]
    zero = _found(_check(recs), "zero")
    assert zero and not any("single-turn" in f.message for f in zero)


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


# --- D11: contact ratio override and tooth pitch against the recordings --------------------------------


def test_contact_ratio_far_from_the_geometry_is_warned():
    """Before: contact_ratio 9 accepted for a geometry whose ε_α + ε_β is 3.05."""
    geo = RackPinionBench(m_n=3e-3, n_t=24, i_PG=10.0, travel=1.2, contact_ratio=9.0)
    (w,) = _found(_check(_records(), geometry=geo), "geometry")
    assert w.level == "warning" and "contact_ratio = 9" in w.message and "ε = 3.05" in w.message


@pytest.mark.parametrize("eps", [None, 2.2, 3.4])
def test_contact_ratio_near_the_geometry_is_accepted(eps):
    """Negative control: no override, or one within 30 % of ε = 2.68 (a data sheet's value)."""
    geo = RackPinionBench(travel=1.0, contact_ratio=eps)
    assert not _found(_check(_records(), geometry=geo), "geometry")


def test_tooth_pitch_the_recordings_contradict_is_warned():
    """Before: m_n/n_t halved/doubled (same d_p, so the ratio check passes) accepted silently;
    the synthetic TE meshes at 13.33 mm, the stated pitch is half of it."""
    rep = _check(_records(), tooth_pitch=BENCH.tooth_pitch / 2)
    (w,) = _found(rep, "pitch")
    assert w.level == "warning"
    line = float(re.search(r"line is at (\d+\.\d+) mm", w.message).group(1))
    assert line == pytest.approx(BENCH.tooth_pitch * 1e3, rel=0.01)
    assert f"{BENCH.tooth_pitch * 500:.2f} mm" in w.message


def test_stated_tooth_pitch_matching_the_recordings_is_not_warned():
    """Negative control: the right pitch (and within the 10 % tolerance) gives no warning."""
    for p in (BENCH.tooth_pitch, 0.95 * BENCH.tooth_pitch):
        assert not _found(_check(_records(), tooth_pitch=p), "pitch")
