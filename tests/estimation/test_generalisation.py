"""Random drive trains outside the scenarios: the default tuning rule, unchanged (slow).

Each case draws gear ratio, inertias, shaft resonance, damping, friction, deadzone, offset,
encoder resolution, velocity noise and motion profile, simulates 40 s with the simulator's
engine, and runs the default law with ``EstimatorConfig.tuned`` and the detected reversal
frequency (default law). The numbers quoted in docs/assumptions.md come from this sweep (seeds 0–3).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from drivelash.control.cascade import gains_from_bandwidth
from drivelash.control.references import constant_velocity_passes, position_sine, velocity_sine
from drivelash.estimation.estimator import DeadzoneEstimator, EstimatorConfig, excitation_frequency
from drivelash.metrics import convergence_time, maee
from drivelash.params import BacklashParams, DrivetrainParams, SensorParams
from drivelash.sim.engine import simulate

TS = 125e-6
DURATION = 40.0


def random_drive(rng: np.random.Generator, seed: int):
    """One random drive, its true deadzone and a simulated trace."""
    N = float(rng.choice([1, 2, 5, 10]))
    J_l = 10 ** rng.uniform(-4, -2)
    J_m = 10 ** rng.uniform(-4, -3)
    wn = 10 ** rng.uniform(np.log10(60), np.log10(600))  # load-side shaft resonance [rad/s]
    K_S = J_l * wn**2
    D_S = 2 * 0.02 * np.sqrt(K_S * J_l) * rng.uniform(0.5, 3)
    T_Cl = K_S * 10 ** rng.uniform(-4, -2.5)
    drivetrain = DrivetrainParams(
        J_m=J_m, J_l=J_l, N=N, K_S=K_S, D_S=D_S, T_Cm=0.02 * J_m / 8e-4, T_Cl=T_Cl,
        beta_m=0.001, beta_l=T_Cl * 0.05, T_Sl=T_Cl * 1.5, T_Sm=0.0, omega_s=0.05,
    )  # fmt: skip
    delta = 10 ** rng.uniform(-2, np.log10(0.5))
    bl = BacklashParams(delta, delta * rng.uniform(0.1, 0.9))
    counts = int(rng.choice([0, 1024, 2048, 8192, 65536]))
    sig = float(rng.choice([0.0, 0.01, 0.03]))
    sens = SensorParams(counts_m=counts, counts_l=counts, sigma_omega_m=sig, sigma_omega_l=sig)
    kind = rng.choice(["sine", "passes", "vsine"])
    f = float(rng.uniform(0.3, 2.0))
    amp = max(3 * delta, rng.uniform(0.3, 2.0))  # load-side travel [rad]
    if kind == "sine":
        ref = position_sine(DURATION, TS, amp * N, f)
    elif kind == "vsine":
        ref = velocity_sine(DURATION, TS, amp * N * 2 * np.pi * f, f)
    else:
        ref = constant_velocity_passes(
            DURATION,
            TS,
            velocity=amp * N * 3 * f,
            stroke=amp * N,
            acceleration=amp * N * 30 * f * f,
            dwell=0.1,
        )
    g = replace(
        gains_from_bandwidth(drivetrain, float(min(0.5 * wn, 300.0))), torque_limit=max(0.5 * K_S, 1.0)
    )
    trace = simulate(drivetrain, bl, g, ref, sensors=sens, seed=seed).to_trace()
    return replace(drivetrain, T_Sm=0.0, T_Sl=0.0), bl, trace


#: The bench targets of issue 3, transferred to drives outside the scenarios (as in
#: tests/estimation/test_acceptance.py::test_off_scenario_drive).
MAEE_GOAL = 1e-3  # rad, over the last 20 s
CONV_GOAL = 10.0  # s, into the 10 mrad band
#: Cases that miss the MAEE goal, with the measured value. Seed 0 / case 0 (1.33 mrad, a steady
#: −0.90 mrad bias) left in session 10: the least-squares gain is capped at the shaft
#: resonance (``test_gain_capped_at_the_shaft_resonance_on_the_soft_drive`` below).
KNOWN_MISS: dict[tuple[int, int], float] = {}
#: ... and their mean error over the scored window [rad]: a steady bias, not a slow settling.
KNOWN_BIAS: dict[tuple[int, int], float] = {}
#: Cases whose ``converged`` verdict is a known miss (checked by the strict xfail below).
KNOWN_NOT_CONVERGED = {(1, 0), (1, 2)}


def _estimate(seed: int, case: int | None = None):
    """(case, bl, result) for every case of ``seed`` (or only ``case``)."""
    rng = np.random.default_rng(seed)
    for k in range(12 if case is None else case + 1):
        drivetrain, bl, trace = random_drive(rng, k)
        if case is not None and k != case:
            continue
        cfg = EstimatorConfig.tuned(drivetrain, TS, excitation_frequency(trace))
        yield k, bl, DeadzoneEstimator(drivetrain, bl, TS, cfg).run(trace)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_random_drives(seed):
    """Every case converges and meets the transferred bench goals (MAEE ≤ 1 mrad, 10 mrad band
    within 10 s); the known misses are asserted at the goal by the strict xfail below."""
    for case, bl, res in _estimate(seed):
        t, d = res.t, res.delta_hat
        where = f"seed {seed} case {case}"
        assert res.excitation_ok, where
        assert res.converged or (seed, case) in KNOWN_NOT_CONVERGED, where
        m = maee(t, d, bl.delta, t[-1] - 20.0)
        if (seed, case) in KNOWN_MISS:  # the miss is the one reported, not a drifting one
            assert m == pytest.approx(KNOWN_MISS[(seed, case)], rel=0.02), where
            late = t >= t[-1] - 20.0
            assert np.mean(d[late] - bl.delta) == pytest.approx(KNOWN_BIAS[(seed, case)], abs=0.05e-3), where
        else:
            assert m <= MAEE_GOAL, where
        c = convergence_time(t, d, bl.delta, 10e-3)
        assert c is not None and c <= CONV_GOAL, where


def test_gain_capped_at_the_shaft_resonance_on_the_soft_drive():
    """Seed 0 / case 0 (ω_n = 62 rad/s, f_r = 1.52 Hz, δ = 107 mrad) meets 1 mrad because the
    least-squares gain P_max = min(16 ω_r, ω_n) is no faster than the shaft resonance (measured
    session 10: MAEE 0.399 mrad). Negative control: the uncapped 16 ω_r = 153 /s lets δ̂ and κ
    follow the contact ringing — the steady −0.90 mrad bias, κ 0.977, MAEE 1.318 mrad of
    sessions 1–9 (docs/assumptions.md, "P0 = P_max")."""
    rng = np.random.default_rng(0)
    drivetrain, bl, trace = random_drive(rng, 0)
    f_r = excitation_frequency(trace)
    cfg = EstimatorConfig.tuned(drivetrain, TS, f_r)
    w_n = np.sqrt(drivetrain.K_S / drivetrain.J_l)
    assert cfg.P_max == pytest.approx(w_n, rel=1e-12)
    assert w_n < 16 * 2 * np.pi * f_r  # the cap binds on this drive
    res = DeadzoneEstimator(drivetrain, bl, TS, cfg).run(trace)
    assert maee(res.t, res.delta_hat, bl.delta, res.t[-1] - 20.0) == pytest.approx(0.399e-3, rel=0.05)
    unc = DeadzoneEstimator(drivetrain, bl, TS, replace(cfg, P_max=16 * 2 * np.pi * f_r)).run(trace)
    assert maee(unc.t, unc.delta_hat, bl.delta, unc.t[-1] - 20.0) == pytest.approx(1.318e-3, rel=0.02)
    late = unc.t >= unc.t[-1] - 20.0
    assert np.mean(unc.delta_hat[late] - bl.delta) == pytest.approx(-0.90e-3, abs=0.05e-3)
    assert unc.extra["stiffness_scale"] == pytest.approx(0.977, abs=0.002)


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason="known miss: seed 1 / case 2 (δ = 18.7 mrad) reports converged = False although δ̂ "
    "meets the goals (measured MAEE 0.35 mrad, 10 mrad band after 0.023 s); the verdict of the "
    "estimator since 0ac1d30 (h4-online) withholds 'converged' here; goal: converged = True",
)
def test_known_miss_converged_verdict_seed1_case2():
    ((_, _, res),) = _estimate(1, 2)
    assert res.excitation_ok and res.converged


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason="known miss: seed 1 / case 0 (δ = 254.8 mrad) reports converged = False although δ̂ "
    "meets the goals (measured final error −0.38 mrad, MAEE 0.38 mrad, 10 mrad band after 0.26 s); "
    "its stated σ is 1.07 mrad, so the 95 % half-width (2.1 mrad) exceeds the 2 mrad needed to "
    "claim convergence since e8fd826/0ffdca8 (h4-online, docs/assumptions.md); goal: converged = True",
)
def test_known_miss_converged_verdict_seed1_case0():
    ((_, _, res),) = _estimate(1, 0)
    assert res.excitation_ok and res.converged
