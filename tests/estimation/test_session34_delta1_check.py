"""Session 34: the δ1 check judges only once its joint law has settled, and a worse torque fit of
the joint law does not make a δ1 "consistent" whose lower contact the anchored law fits worse.

Reference: the simulator's truth (bench scenarios, seed 0, the scenario's own estimator drive
parameters) and a configured δ1 off by a few mrad — a δ1 measured once at commissioning, then an
encoder remounted. Found by a sweep over the 18 bench scenarios × 6 / 10 / 20 s × δ1 offsets
0, ±10, −3 mrad (docs/assumptions.md, "δ1 check: settled joint law"): before, 49 of 54 off-δ1 runs
of 6 s and 15 of 54 of 10 s were "converged" with δ̂ 3–10 mrad off (the 1.96 σ interval ≈ 1 mrad);
after, 1 of 162 (bench-1A 20 s, δ1 −10 mrad: switched to the joint law, +4.5 mrad — K_S stated 2×,
which that law holds at κ = 1; left, see the note). The price: with the true δ1 a 6 s bench
recording (three reversal periods) is no longer "converged" (0 of 18), 10 s 11 of 18, 20 s 18 of 18.
"""

from __future__ import annotations

import pytest

import drivelash as dl
from drivelash.sim.scenarios import get_scenario


def _run(name: str, duration: float, offset: float):
    sc = get_scenario(name)
    tr = sc.simulate(duration=duration, seed=0)
    est = dl.estimate_backlash(tr, sc.estimator_drivetrain, sc.estimator_backlash.delta1 + offset)
    return est, float(tr["delta_true"][-1])


def _confidently_wrong(est, truth: float) -> bool:
    lo, hi = est.summary["delta_interval_95"] or (None, None)
    return est.converged and not (lo is not None and lo <= truth <= hi) and abs(est.delta - truth) > 2e-3


@pytest.mark.parametrize("offset", [-10e-3, 10e-3, -3e-3])
@pytest.mark.parametrize("name", ["bench-0B", "bench-0C"])
def test_an_unsettled_delta1_check_withholds_convergence(name, offset):
    """6 s of bench-0B / 0C with δ1 off: the anchored δ̂ moves one-for-one with δ1 (−10.1 / +9.9 /
    −4.8 mrad off on 0B) and was "converged" ± 1.0 mrad; the joint law still moved 11–27 mrad over
    the last 4 s window. Now: "not settled", a warning naming both δ1 values, not converged."""
    est, truth = _run(name, 6.0, offset)
    x = est.result.extra
    assert abs(est.delta - truth) > 2e-3  # the control: the anchored δ̂ is wrong by the offset
    assert x["delta1_check_result"] == "not settled"
    assert x["delta1_check_movement"] > x["delta1_check_band"]
    assert x["delta1_check_apart"] > 1e-3  # ended beyond the 1 mrad floor from δ̂
    assert not est.converged
    w = [w for w in est.warnings if "the δ1 check did not settle" in w]
    assert len(w) == 1 and w[0].startswith("the estimate is uncertain by"), est.warnings
    configured = get_scenario(name).estimator_backlash.delta1 + offset
    assert f"configured δ1 = {1e3 * configured:.2f} mrad" in w[0]
    # the interval reaches where the unsettled joint law ended (a bounded alternative)
    assert x["delta1_check_gap"] == pytest.approx(abs(est.delta - x["delta1_check_delta"]), abs=0)
    assert 1.96 * est.summary["delta_std"] >= x["delta1_check_gap"]
    assert not _confidently_wrong(est, truth)


def test_a_settled_check_still_confirms_the_true_delta1():
    """Negative control: 20 s of bench-0B with its true δ1 — the joint law settled (moved 0.26 mrad
    over the window), "consistent", converged within 0.1 mrad, no δ1 warning."""
    est, truth = _run("bench-0B", 20.0, 0.0)
    x = est.result.extra
    assert x["delta1_check_result"] == "consistent"
    assert x["delta1_check_movement"] <= x["delta1_check_band"]
    assert est.converged and abs(est.delta - truth) < 0.2e-3
    assert not [w for w in est.warnings if "δ1" in w]


def test_a_worse_joint_torque_fit_does_not_make_a_wrong_delta1_consistent():
    """bench-1B (K_S stated 2×) for 10 s, δ1 +10 mrad: the joint law settled (2.4 mrad over the
    window, band 3.9) and puts δ1 9.7 mrad lower; its torque residual is 1.29× the anchored law's
    (it holds κ at 1 where the anchored law learns it), which said "consistent" — δ̂ +9.9 mrad,
    "converged". The anchored law fits its lower contact 4× worse than the joint law (asymmetry
    4.0; the true δ1's 0.7): no longer "consistent", not converged."""
    est, truth = _run("bench-1B", 10.0, 10e-3)
    x = est.result.extra
    assert x["delta1_check_movement"] <= x["delta1_check_band"]
    assert x["delta1_check_ratio"] > 1.0 / 0.8 and x["delta1_check_asymmetry"] > 1.5
    assert x["delta1_check_result"] != "consistent"
    assert not _confidently_wrong(est, truth)
    assert not est.converged


def test_a_worse_joint_torque_fit_with_the_lower_contact_fitted_alike_stays_consistent():
    """Negative control of the rule above: bench-1A (K_S stated 2×) for 20 s with its true δ1 — the
    settled joint law puts δ1 2.1 mrad off (beyond the 1 mrad floor) and fits the torque 4× worse,
    the anchored law's lower contact no worse (asymmetry 1.03): "consistent", converged, 0.1 mrad."""
    est, truth = _run("bench-1A", 20.0, 0.0)
    x = est.result.extra
    assert abs(x["delta1_check"] - est.summary["delta1"]) > 1e-3
    assert x["delta1_check_ratio"] > 1.0 / 0.8 and x["delta1_check_asymmetry"] <= 1.5
    assert x["delta1_check_result"] == "consistent"
    assert est.converged and abs(est.delta - truth) < 0.5e-3


def test_offset_check_false_states_delta1_known():
    """The way out the warning names: with ``offset_check = false`` the user states δ1 known; the
    6 s run with the true δ1 is then converged (0.06 mrad off) — the claim rests on the user's δ1."""
    sc = get_scenario("bench-0B")
    tr = sc.simulate(duration=6.0, seed=0)
    est = dl.estimate_backlash(tr, sc.estimator_drivetrain, sc.estimator_backlash.delta1)
    assert est.result.extra["delta1_check_result"] == "not settled" and not est.converged
    from drivelash.io.config import loads_config

    p = sc.estimator_drivetrain
    rows = "\n".join(
        f"{k} = {getattr(p, k)!r}"
        for k in ("J_m", "J_l", "N", "K_S", "D_S", "T_Cm", "T_Cl", "beta_m", "beta_l")
    )
    cfg = loads_config(
        f"[drivetrain]\n{rows}\n[backlash]\ndelta1 = {sc.estimator_backlash.delta1!r}\n"
        "[estimator]\noffset_check = false\n"
    )
    known = dl.estimate_backlash(tr, cfg)
    assert known.converged and abs(known.delta - float(tr["delta_true"][-1])) < 0.2e-3
    assert known.summary.get("delta1_check_result") in (None, "not run")


def test_a_consistent_delta1_by_a_clearly_worse_joint_fit_stands_while_that_law_wanders():
    """The slow suite's random drive seed 3 / case 8 (40 s, true δ1): the joint law never settles
    (moved 92 mrad over the last window, ended 65 mrad from δ̂) but fits the torque 27× worse with
    the anchored law's lower contact fitted no worse (asymmetry 0.68) — evidence for the configured
    δ1. The first version of the gate called it "not settled" and withheld a δ̂ 0.1 mrad from the
    truth; the ratio rule's "consistent" now stands."""
    from .test_generalisation import _estimate

    ((_, bl, res),) = list(_estimate(3, 8))
    x = res.extra
    assert x["delta1_check_movement"] > x["delta1_check_band"] and x["delta1_check_apart"] > 1e-3
    assert x["delta1_check_ratio"] > 1.0 / 0.8 and x["delta1_check_asymmetry"] <= 1.5
    assert x["delta1_check_result"] == "consistent"
    assert res.converged and abs(res.delta - bl.delta) < 0.5e-3
