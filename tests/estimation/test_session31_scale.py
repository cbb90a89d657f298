"""Session 31, tester C (diag31), C8: the online ``estimate`` must not depend on the units.

Reference: bench-0B, 10 s, seed 1 (true δ = 186 mrad, δ1 = 93 mrad) rewritten *exactly* in scaled
units — positions and velocities × s; J_m, J_l, K_S, D_S, β × 1/s; δ1 × s; torque unchanged. The
equations of motion, the noise and the encoder steps scale exactly, so δ̂/s must match the unscaled
δ̂ (a linear axis in m with a 186 µm gap at s = 1e-3, a precision gearbox at s = 1e-2 … 1e-3).
Before the fix the rule's angle constants were absolute (α ≤ 10⁵ 1/rad, 1 mrad of deflection, the
observers' 1 rad, the 2 mrad band): δ̂/s = 185.606 [185.21, 186.00] mrad at s = 1e-2 and 182.217
[181.31, 183.12] at s = 1e-3, "converged", the truth outside (8 σ).
"""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

import drivelash as dl
from drivelash.estimation.estimator import DeadzoneEstimator, estimate_blocks, trace_blocks
from drivelash.estimation.motion import scan_trace
from drivelash.io.trace import Trace
from drivelash.params import EstimatorConfig
from drivelash.sim.scenarios import get_scenario

DELTA = 0.186
POSITIONS = ("theta_m", "omega_m", "theta_l", "omega_l")


@pytest.fixture(scope="module")
def bench0b() -> tuple[Trace, dl.DrivetrainParams, float]:
    sc = get_scenario("bench-0B")
    tr = sc.simulate(duration=10.0, seed=1)
    assert sc.plant_backlash.delta == DELTA
    cols = {c: tr[c] for c in ("t", *POSITIONS, "torque_m")}
    return Trace(cols, {}), sc.estimator_drivetrain, sc.estimator_backlash.delta1


def _scaled(bench0b, s: float) -> tuple[Trace, dl.DrivetrainParams, float]:
    """The same recording and drive in units s (positions × s, inertias, stiffness, damping,
    viscous friction / s, torque unchanged)."""
    tr, p, d1 = bench0b
    cols = {c: tr[c] * s if c in POSITIONS else tr[c] for c in tr.names}
    per_s = ("J_m", "J_l", "K_S", "D_S", "beta_m", "beta_l")
    q = replace(p, **{f: getattr(p, f) / s for f in per_s})
    return Trace(cols, {}), q, d1 * s


@pytest.fixture(scope="module")
def unscaled(bench0b):
    return dl.estimate_backlash(*_scaled(bench0b, 1.0))


def test_unscaled_recording_keeps_its_gains_and_result(bench0b, unscaled):
    """Negative control: a Δθ range of 0.206 rad (≥ 10 mrad) leaves the angle scale at 1 and the
    gains and δ̂ of before (α = 2·10⁴, T_thr = 0.01647 N·m, θ_def = 1 mrad; 185.916 mrad)."""
    tr, p, _ = bench0b
    mo = scan_trace(tr, p.N)
    assert mo.dtheta_range == pytest.approx(0.206, abs=0.005)
    cfg = EstimatorConfig.tuned(p, mo.T_s, motion=mo)
    assert cfg.angle_scale == 1.0
    assert cfg.alpha == 2e4 and cfg.theta_def == pytest.approx(1e-3) and cfg.T_thr == pytest.approx(0.01647)
    assert unscaled.converged and not unscaled.warnings
    assert 1e3 * unscaled.delta == pytest.approx(185.916, abs=5e-4)
    assert unscaled.summary["gains"]["angle_scale"] == 1.0


@pytest.mark.parametrize("s", [1e-2, 1e-3])
def test_scaled_recording_gives_the_same_gap(bench0b, unscaled, s):
    """δ̂/s at s = 1e-2 and 1e-3 within the unscaled result's 95 % interval, its own interval
    holds the truth, converged (was 185.606 / 182.217 mrad, truth outside)."""
    est = dl.estimate_backlash(*_scaled(bench0b, s))
    lo, hi = (v / s for v in est.summary["delta_interval_95"])
    lo1, hi1 = unscaled.summary["delta_interval_95"]
    assert lo1 <= est.delta / s <= hi1, (est.delta / s, lo1, hi1)
    assert lo <= DELTA <= hi, (lo, hi)
    assert est.converged, est.warnings
    g = est.summary["gains"]
    # the angle constants follow the recording: σ = Δθ range / 10 mrad, α·s and θ_def/s alike
    assert g["angle_scale"] == pytest.approx(20.56 * s, rel=0.01)
    assert g["T_thr"] == pytest.approx(0.0265, abs=1e-4)  # a torque: does not depend on s
    assert est.summary["torque_reversals"] == unscaled.summary["torque_reversals"]  # was 39221


def test_gains_follow_the_scale_exactly_below_the_reference_range(bench0b):
    """Below a Δθ range of 10 mrad every angle gain scales with the recording: s = 1e-2 and 1e-3
    give the same α·s, θ_def/s, k2/s, k1/√s, the same torque threshold and δ1 floor/s."""
    cfgs = {}
    for s in (1e-2, 1e-3):
        tr, p, _ = _scaled(bench0b, s)
        mo = scan_trace(tr, p.N)
        cfgs[s] = (EstimatorConfig.tuned(p, mo.T_s, motion=mo), s)
    (a, sa), (b, sb) = cfgs.values()
    for f, k in (("alpha", 1), ("theta_def", -1), ("k2", -1), ("k2_m", -1), ("offset_switch", -1)):
        assert getattr(a, f) * sa**k == pytest.approx(getattr(b, f) * sb**k, rel=1e-9), f
    assert a.k1 / math.sqrt(sa) == pytest.approx(b.k1 / math.sqrt(sb), rel=1e-9)
    assert a.T_thr == pytest.approx(b.T_thr, rel=1e-9)


def test_gains_tuned_without_the_recording_are_flagged(bench0b):
    """The honest part: gains tuned without the recording (a DeadzoneEstimator given a config,
    angle scale 1) on the s = 1e-3 recording keep the absolute constants (α capped at 10⁵, the
    2 mrad band around a 0.186 mrad gap): δ̂ biased, so not converged and a warning names the cause."""
    tr, p, d1 = _scaled(bench0b, 1e-3)
    cfg = EstimatorConfig.tuned(p, tr.T_s, 0.5)
    assert cfg.angle_scale == 1.0
    res = DeadzoneEstimator(p, d1, tr.T_s, config=cfg).run(tr)
    assert not res.converged
    w = [w for w in res.warnings if w.startswith("the recording's Δθ range")]
    assert len(w) == 1 and "check the position units" in w[0], res.warnings


def test_range_below_the_smallest_scale_is_not_converged(bench0b):
    """A Δθ range below 10 mrad × 10⁻⁴ (here bench-0B at s = 1e-7, 21 nrad): the angle scale sits
    at its floor, the constants no longer follow — a blocking warning, never "converged"."""
    tr, p, d1 = _scaled(bench0b, 1e-7)
    res = estimate_blocks(p, d1, trace_blocks(tr))
    assert res.config.angle_scale == 1e-4
    assert not res.converged
    assert any(w.startswith("the recording's Δθ range") for w in res.warnings), res.warnings


def test_scaled_recording_paper_law(bench0b):
    """The paper's law alike: s = 1e-3 gave δ̂/s = 194.296 [181.05, 207.54] mrad, "converged" (in m:
    ±13 µm around 194 µm for a 186 µm gap passed the absolute claim of 2 mrad, i.e. 2 mm); now
    187.336 [185.17, 189.50], inside the unscaled 187.181 [185.61, 188.76]."""
    ref = dl.estimate_backlash(*_scaled(bench0b, 1.0), method="paper")
    est = dl.estimate_backlash(*_scaled(bench0b, 1e-3), method="paper")
    lo1, hi1 = ref.summary["delta_interval_95"]
    lo, hi = (v / 1e-3 for v in est.summary["delta_interval_95"])
    assert lo1 <= est.delta / 1e-3 <= hi1, (est.delta / 1e-3, lo1, hi1)
    assert lo <= DELTA <= hi and hi - lo < 5e-3, (lo, hi)
