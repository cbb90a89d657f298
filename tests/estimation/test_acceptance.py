"""Acceptance figures of issue 3 on the simulator's scenarios and on drives outside them."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from drivelash.control.cascade import gains_from_bandwidth
from drivelash.control.references import constant_velocity_passes, position_sine
from drivelash.estimation.estimator import DeadzoneEstimator, EstimatorConfig, excitation_frequency
from drivelash.estimation.reproduce import reproduce_table, run_scenario
from drivelash.metrics import convergence_time, maee
from drivelash.params import BacklashParams, DrivetrainParams, SensorParams
from drivelash.sim.engine import simulate
from drivelash.sim.scenarios import list_scenarios

TS = 125e-6


def test_paper_sim_default_meets_paper_figures():
    (o,) = run_scenario("paper-sim", methods=("default",))
    m = o.metrics
    # spec 01 §4: within 2 mrad in < 2 s from 0 and after the +5 % step; |e_ss| < 2.5e-4 rad
    assert m["conv_2mrad_start_s"] is not None and m["conv_2mrad_start_s"] < 2.0
    assert m["conv_2mrad_step_s"] is not None and m["conv_2mrad_step_s"] < 2.0
    assert m["ss_error_rad"] < 2.5e-4
    assert m["excitation_ok"]


def _off_scenario(kind: str):
    """Drives that are not among the scenarios: gear ratio, inertias, stiffness, encoders, motion."""
    if kind == "gear5":
        drivetrain = DrivetrainParams(
            J_m=2e-4, J_l=5e-3, N=5.0, K_S=120.0, D_S=0.2, T_Cm=0.01, T_Cl=0.08, beta_m=5e-4,
            beta_l=0.01, T_Sm=0.015, T_Sl=0.12, omega_s=0.05,
        )  # fmt: skip
        bl = BacklashParams(0.02, 0.005)
        sens = SensorParams(counts_m=4096, counts_l=4096, sigma_omega_m=0.05, sigma_omega_l=0.01)
        ref = position_sine(40.0, TS, 0.3 * drivetrain.N, 1.0)
        g = gains_from_bandwidth(drivetrain, 100.0)
    else:  # trapezoidal passes with dwell, N = 3, 1024/8192 counts, offset δ1 = δ/3
        drivetrain = DrivetrainParams(
            J_m=8.31e-4, J_l=1.6e-3, N=3.0, K_S=20.0, D_S=0.05, T_Cm=0.02, T_Cl=0.03, beta_m=0.001,
            beta_l=0.002,
        )  # fmt: skip
        bl = BacklashParams(0.3, 0.1)
        sens = SensorParams(counts_m=8192, counts_l=1024, sigma_omega_m=0.03, sigma_omega_l=0.03)
        ref = constant_velocity_passes(40.0, TS, velocity=9.0, stroke=6.0, acceleration=90.0, dwell=0.2)
        g = gains_from_bandwidth(drivetrain, 100.0)
    trace = simulate(drivetrain, bl, g, ref, sensors=sens, seed=7).to_trace()
    return replace(drivetrain, T_Sm=0.0, T_Sl=0.0), bl, trace


@pytest.mark.parametrize("kind", ["gear5", "passes"])
def test_off_scenario_drive(kind):
    drivetrain, bl, trace = _off_scenario(kind)
    cfg = EstimatorConfig.tuned(drivetrain, TS, excitation_frequency(trace))
    res = DeadzoneEstimator(drivetrain, bl, TS, cfg).run(trace)
    t, d = res.t, res.delta_hat
    assert res.excitation_ok and res.converged, res.reason
    # the bench targets, transferred: ≤ 1 mrad over the last 20 s, into 10 mrad within 10 s
    assert maee(t, d, bl.delta, t[-1] - 20.0) <= 1e-3
    c = convergence_time(t, d, bl.delta, 10e-3)
    assert c is not None and c <= 10.0


def test_reproduce_quick(tmp_path):
    from drivelash.commands.estimate import run_reproduce

    r = run_reproduce(tmp_path, quick=True, workers=1, quiet=True)
    names = {p.name for p in r["files"]}
    assert {"reproduce.md", "reproduce.csv", "fig08_paper_sim.png", "fig13_bench_errors.png"} <= names
    assert {"fig15_torque_vs_dtheta.png", "fig10_ss_vs_phi_error.png"} <= names
    md = (tmp_path / "reproduce.md").read_text()
    assert "bench-5C" in md and "paper-sim" in md
    assert (tmp_path / "reproduce.csv").read_text().count("\n") == 7  # header + 3 scenarios × 2 methods
    assert np.isfinite(float((tmp_path / "fig10_slope.txt").read_text()))


def test_demo_step(tmp_path):
    from rich.console import Console

    from drivelash.estimation.demo import demo_estimate

    console = Console(record=True, width=200)
    demo_estimate(tmp_path, console)
    text = console.export_text()
    assert "true δ" in text and "default" in text
    assert (tmp_path / "estimate-bench-0A.json").exists()
    html = (tmp_path / "estimate-bench-0A.html").read_text(encoding="utf-8")
    assert html.count("data:image/png;base64,") >= 3  # self-contained figures
    assert "http://" not in html and "https://" not in html  # no network


#: The figures README.md quotes for `drivelash reproduce` (default law), asserted below at their
#: own value: each measured figure must round to the quoted one within ±2 % (the README gives
#: two or three significant digits), and the "≤" bounds hold on every bench test.
README_WORST_MAEE = 0.214e-3  # rad, "default law ≤ 0.214 mrad MAEE on every bench test"
README_WORST_CONV = 0.21  # s, "within 10 mrad after ≤ 0.21 s"
README_PAPER_SIM_SS = 0.055e-3  # rad, "paper-sim steady state 0.055 mrad"
README_REL = 0.02


@pytest.mark.slow
def test_full_bench_sweep_meets_targets_and_readme_figures():
    """`drivelash reproduce` (the command README.md names) in one sweep: the issue-3 goals
    (MAEE ≤ 1 mrad, 10 mrad band within 10 s) and the README's own figures for the default law.
    """
    names = [s.name for s in list_scenarios()]
    rows = reproduce_table(names, methods=("default",), workers=2)
    bench = [r for r in rows if r["scenario"].startswith("bench-")]
    assert len(bench) == 18  # tests 0…5 × deadzones A, B, C
    for r in bench:
        assert r["maee_rad"] <= 1e-3, r["scenario"]
        assert r["conv_10mrad_s"] is not None and r["conv_10mrad_s"] <= 10.0, r["scenario"]
        assert r["excitation_ok"], r["scenario"]
        assert r["converged"], r["scenario"]  # the estimate's own verdict (session 32, F1: 15 of 18 before)
    # README: "default law ≤ 0.214 mrad MAEE on every bench test and within 10 mrad after ≤ 0.21 s"
    worst_maee = max(r["maee_rad"] for r in bench)
    worst_conv = max(r["conv_10mrad_s"] for r in bench)
    assert all(r["maee_rad"] <= README_WORST_MAEE for r in bench), worst_maee  # measured 0.2138 mrad
    assert worst_maee == pytest.approx(README_WORST_MAEE, rel=README_REL)
    assert all(r["conv_10mrad_s"] <= README_WORST_CONV for r in bench), worst_conv  # measured 0.209 s
    assert worst_conv == pytest.approx(README_WORST_CONV, rel=README_REL)
    # README: "paper-sim steady state 0.055 mrad" (peak over the last 0.5 s before the step and at the end)
    (ps,) = [r for r in rows if r["scenario"] == "paper-sim"]
    assert ps["ss_peak_rad"] == pytest.approx(README_PAPER_SIM_SS, rel=README_REL)  # measured 0.0547 mrad


@pytest.mark.parametrize("offset", [0.02, -0.03])
def test_encoder_offset_or_wrong_delta1_is_detected(offset):
    """An offset between the encoders (equivalently a wrong δ1 in the configuration) shifts
    both contact points; the anchored law would be off by about the offset, the joint δ/δ1
    law takes over when the data disagree with δ1 and explain the torque better."""
    from drivelash.estimation.reproduce import estimator_for
    from drivelash.sim.scenarios import get_scenario

    sc = get_scenario("bench-0B")
    trace = sc.simulate()
    shifted = trace.with_columns({"theta_l": trace["theta_l"] + offset})
    res = estimator_for(sc, "default").run(shifted)
    assert res.extra.get("offset_switched") is True
    assert abs(res.delta - sc.plant_backlash.delta) < 1e-3
    # the configured δ1 = 93 mrad, the data's lower contact is at 93 mrad + offset
    assert res.extra["delta1_estimate"] == pytest.approx(sc.plant_backlash.delta1 + offset, abs=1e-3)
    assert "jointly" in res.reason
    plain = estimator_for(sc, "default").run(trace)
    assert not plain.extra.get("offset_switched")


def test_coarser_sample_time():
    """The same bench recording decimated to 1 kHz (ω_n T_s = 0.2): the rule slows the observer."""
    from drivelash.estimation.reproduce import estimator_for
    from drivelash.io.trace import Trace
    from drivelash.sim.scenarios import get_scenario

    sc = get_scenario("bench-5C")
    full = sc.simulate()
    trace = Trace({k: v[::8] for k, v in full.columns.items()})
    T_s = trace.T_s
    assert T_s == pytest.approx(1e-3)
    cfg = EstimatorConfig.tuned(sc.estimator_drivetrain, T_s, excitation_frequency(trace))
    res = DeadzoneEstimator(sc.estimator_drivetrain, sc.estimator_backlash, T_s, cfg).run(trace)
    assert res.excitation_ok and res.converged
    assert maee(res.t, res.delta_hat, sc.plant_backlash.delta, 40.0) <= 1e-3
    del estimator_for
