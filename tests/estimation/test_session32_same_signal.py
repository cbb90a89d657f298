"""The load position mapped to the motor's own channel (Δθ ≡ 0) is named as such (session 31
tester C, C14 d: it read "the shaft torque reversed 5 times but the gap was never crossed: one
flank keeps the load (… gravity, or a preload)", a wrong physical story)."""

from __future__ import annotations

import numpy as np
import pytest

import drivelash as dl
from drivelash.io.trace import Trace
from drivelash.sim.scenarios import get_scenario


@pytest.fixture(scope="module")
def bench0b():
    sc = get_scenario("bench-0B")
    return sc, sc.simulate(duration=6.0, seed=1)


def _estimate(sc, cols):
    return dl.estimate_backlash(Trace(cols, {}), sc.estimator_drivetrain, delta1=sc.estimator_backlash.delta1)


def test_same_channel_twice_is_named(bench0b):
    sc, run = bench0b
    N = sc.estimator_drivetrain.N
    cols = {n: np.array(run[n]) for n in ("t", "theta_m", "omega_m", "torque_m")}
    cols["theta_l"], cols["omega_l"] = cols["theta_m"] / N, cols["omega_m"] / N
    est = _estimate(sc, cols)
    assert not est.converged and not est.summary["excitation_ok"]
    assert "the load position is the motor's own signal (one channel mapped twice?)" in est.summary["reason"]
    assert "gravity" not in est.summary["reason"]


def test_negative_control_a_real_load_encoder(bench0b):
    sc, run = bench0b
    est = _estimate(
        sc, {n: np.array(run[n]) for n in ("t", "theta_m", "omega_m", "theta_l", "omega_l", "torque_m")}
    )
    # 6 s of bench-0B (three 0.5 Hz reversal periods) no longer verify δ1: the δ1 check's joint law
    # ends ≈ 2 mrad from δ̂, so the interval widens and `converged` is withheld (session 34,
    # tests/estimation/test_session34_delta1_check.py) — the control's subject instead: accepted,
    # excited, accurate, and blocked by nothing but the δ1 check's interval
    assert est.excitation_ok and "own signal" not in est.summary["reason"]
    assert abs(est.delta - 0.186) < 0.5e-3
    blocking = [w for w in est.warnings if not w.startswith("note:")]
    assert len(blocking) == 1 and "the δ1 check did not settle" in blocking[0], blocking
