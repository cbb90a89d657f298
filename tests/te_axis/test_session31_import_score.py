"""Session 31, tester D: `te import` advice and checks, `te score` pairing, CNC table headers.

The synthetic axis of :mod:`.synth` (known TE, exact kinematics, 1 m travel) is spoilt the way
a real CNC trace is; no fit is needed.
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from drivelash.te.protocol.plausibility import check_runs

from .synth import BENCH, Run, record, standard_runs

SHORT = {"lo": 0.05, "hi": 0.45}


def _records(runs=None):
    runs = runs if runs is not None else [dataclasses.replace(r, **SHORT) for r in standard_runs()]
    return [record(r, f"run{i:02d}.csv") for i, r in enumerate(runs)]


def _check(recs, **kw):
    kw.setdefault("max_load", 3000.0)
    return check_runs(recs, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, source="axis.toml", **kw)


def _found(rep, check):
    return [f for f in rep.findings if f.check == check]


# --- D1: the zero advice names the motor column; a scale outside the axis's frame is refused ----------


def _shift(recs, dx):
    """Scale and motor moved together by dx [m] (TE unchanged)."""
    return [dataclasses.replace(r, x_T=r.x_T + dx, theta_m=r.theta_m + dx / BENCH.r_eff) for r in recs]


def _motor_zero(recs, theta0):
    return [dataclasses.replace(r, theta_m=r.theta_m + theta0) for r in recs]


def test_zero_advice_shifts_the_motor_column_and_following_it_imports():
    """Before: "set offset = 3.82086 (m) on the x_T column" — the scale (the tables' machine
    coordinates) moved by metres. The advice is now an offset on theta_m [rad]; applied, the
    campaign imports with x_T where the scale recorded it."""
    recs = _motor_zero(_records(), 1000.3)  # raw multi-turn counts: arbitrary motor zero
    rep = _check(recs)
    f = _found(rep, "zero")[0]
    assert f.level == "error" and "x_T column" not in f.message
    m = re.search(r"set offset = (-?\d+\.\d+) \(rad\) on the theta_m column", f.message)
    assert m, f.message
    off = float(m.group(1))
    assert off == pytest.approx(-1000.3, abs=0.05)
    fixed = _check([dataclasses.replace(r, theta_m=r.theta_m + off) for r in recs])
    assert fixed.errors == [] and not _found(fixed, "zero") and not _found(fixed, "frame")
    assert min(i["range_m"][0] for i in fixed.runs) == pytest.approx(0.05, abs=1e-3)


def test_zero_advice_adds_to_an_offset_already_on_theta_m():
    recs = _motor_zero(_records(), 1000.3)
    f = _found(_check(recs, column_offsets={"theta_m": 2.0}), "zero")[0]
    m = re.search(r"set offset = (-?\d+\.\d+) \(rad\) \(now 2\) on the theta_m column", f.message)
    assert m and float(m.group(1)) == pytest.approx(2.0 - 1000.3, abs=0.05), f.message


def test_x_t_moved_beyond_the_travel_by_an_offset_is_refused():
    """Following the old advice: x_T + 3.82 m on the 1 m axis (motor and scale agree again) was
    accepted with no finding; now a frame error naming the x_T offset."""
    recs = _shift(_records(), 3.82)
    rep = _check(recs, column_offsets={"x_T": 3.82})
    f = _found(rep, "frame")
    assert len(f) == 1 and f[0].level == "error", [x.line() for x in rep.findings]
    assert "3.87 … 4.27 m" in f[0].message and "offset = 3.82 (m) on the x_T column" in f[0].message
    assert "theta_m" in f[0].message


def test_x_t_just_beyond_the_travel_is_a_warning_and_inside_nothing():
    shift = 1.2  # 1.25 … 1.65 m on a 1 m axis: odd, not impossible (machine zero off the travel)
    recs = _shift(_records(), shift)
    rep = _check(recs)
    f = _found(rep, "frame")
    assert len(f) == 1 and f[0].level == "warning" and rep.errors == []
    # negative controls: the clean campaign, and negative machine coordinates within the travel
    assert not _found(_check(_records()), "frame")
    rep = _check(_shift(_records(), -0.9))
    assert not _found(rep, "frame") and rep.errors == []


def test_a_scale_out_of_its_frame_still_gets_the_x_t_advice():
    """The scale itself shifted (zero_mm) and out of the frame: the x_T offset is the fix."""
    runs = [dataclasses.replace(r, **SHORT, zero_mm=1234.5) for r in standard_runs()]
    f = _found(_check(_records(runs)), "zero")[0]
    assert "offset = -1.2344" in f.message and "on the x_T column" in f.message


# --- D4: a run that reverses inside ---------------------------------------------------------------------


def _out_and_back(F=1000.0):
    fwd = record(Run("load", 1, F, 0.1, **SHORT))
    back = record(Run("load", -1, F, 0.1, **SHORT))
    t = np.concatenate([fwd.t, back.t + fwd.t[-1] + 1e-3])
    cat = {k: np.concatenate([getattr(fwd, k), getattr(back, k)]) for k in ("x_T", "theta_m", "torque_m")}
    return dataclasses.replace(fwd, label="outback.csv", t=t, **cat)


def test_out_and_back_run_is_named_as_such_not_as_torque_sign():
    """Before: "mean motor torque -2.25e-06 N·m opposes the motion … set scale = -1 on the
    torque_m column" (+ mixed-zero); the advice broke every other run."""
    recs = _records()
    recs[4] = _out_and_back(recs[4].load)  # the +1 1000 N pass recorded out and back
    rep = _check(recs)
    f = [x for x in rep.findings if x.file == "outback.csv"]
    assert len(f) == 1 and f[0].check == "reversal" and f[0].level == "error", [x.line() for x in f]
    assert "reverses at 450.0 mm" in f[0].message and "split the file" in f[0].message
    assert not _found(rep, "torque")
    assert not _found(_check(_records()), "reversal")  # negative control: one-way passes


# --- D3: passes of one direction imported for te score --------------------------------------------------


def test_for_score_accepts_passes_of_one_direction():
    """Before: "no load run in direction -1" was an error with --for-score too."""
    runs = [Run("load", 1, F, v, **SHORT) for F, v in ((1000.0, 0.05), (2500.0, 0.1))]
    rep = _check(_records(runs), for_score=True)
    assert rep.errors == [], [f.line() for f in rep.errors]
    one = "no pass in direction -1: only the other direction is scored"
    assert any(one in f.message for f in rep.warnings)
    assert not any("direction -1" in f.message and "geometric" in f.message for f in rep.warnings)
    # negative control: a fit campaign still needs both directions
    assert any("no load run in direction -1" in f.message for f in _check(_records(runs)).errors)
