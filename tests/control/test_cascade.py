"""Cascade controller: cross-implementation with python-control, gains, anti-windup."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import control as ct
from drivelash.control.cascade import CascadeController, gains_from_bandwidth
from drivelash.control.references import position_sine
from drivelash.params import BacklashParams, CascadeGains, DrivetrainParams, SensorParams
from drivelash.physics.drivetrain import linear_state_space
from drivelash.sim.engine import simulate
from drivelash.sim.scenarios import RIG_DRIVETRAIN, RIG_GAINS

STATES = ["omega_m", "theta_m", "omega_l", "theta_l"]


def _python_control_loop(
    plant: DrivetrainParams | None, g: CascadeGains, motor_only: float = 0.0
) -> ct.InputOutputSystem:
    """Discrete closed loop built independently: c2d(zoh) plant + discrete PI/P controller.

    ``motor_only`` = J_m > 0 replaces the plant by the motor alone (coupling in its gap).
    """
    if motor_only:
        beta_m = RIG_DRIVETRAIN.beta_m
        A = np.array([[-beta_m / motor_only, 0.0], [1.0, 0.0]])
        B = np.array([[1.0 / motor_only], [0.0]])
        names = STATES[:2]
    else:
        A, B = linear_state_space(plant)
        names = STATES
    n = len(names)
    P = ct.ss(A, B, np.eye(n), np.zeros((n, 1)), inputs=["u"], outputs=names, name="plant")
    Pd = ct.c2d(P, g.T_s, method="zoh")
    # e_ω = K_v (θ_r − θ_m) + k_ff ω_r − ω_m ; u = K_p e_ω + x_i ; x_i⁺ = x_i + (K_p/T_n) T_s e_ω
    row = np.array([[g.K_v, g.k_ff, -g.K_v, -1.0]])
    Cd = ct.ss(
        [[1.0]],
        g.K_p / g.T_n * g.T_s * row,
        [[1.0]],
        g.K_p * row,
        dt=g.T_s,
        inputs=["theta_r", "omega_r", "theta_m", "omega_m"],
        outputs=["u"],
        name="ctrl",
    )
    return ct.interconnect([Pd, Cd], inplist=["theta_r", "omega_r"], outlist=[*names, "u"])


def test_closed_loop_matches_python_control() -> None:
    """δ = 0, no Coulomb/static friction: engine (RK4, ZOH) = python-control discrete loop over 1 s."""
    plant = replace(RIG_DRIVETRAIN, T_Cm=0.0, T_Cl=0.0, T_Sm=0.0, T_Sl=0.0)
    g = RIG_GAINS
    ref = position_sine(1.0, g.T_s, amplitude=1.0, frequency=0.5)
    res = simulate(plant, BacklashParams(0.0, 0.0), g, ref, sensors=SensorParams(), feedback="true")
    sys = _python_control_loop(plant, g)
    resp = ct.forced_response(sys, T=ref.t, U=np.vstack([ref.theta_ref, ref.omega_ref]), X0=np.zeros(5))
    y = np.asarray(resp.outputs)
    for i, name in enumerate([f"{s}_true" for s in STATES] + ["u"]):
        eng = res.column(name)
        scale = np.max(np.abs(y[i]))
        assert scale > 0
        rel = np.max(np.abs(eng - y[i])) / scale
        assert rel < 1e-6, f"{name}: relative deviation {rel:.2e}"
    assert np.max(np.abs(res.column("u"))) < g.torque_limit  # the linear comparison is valid


@pytest.mark.parametrize("engaged", [True, False])
def test_rig_gains_stable_loaded_and_unloaded(engaged: bool) -> None:
    """The chosen gains give a stable discrete loop with the load engaged and in the gap."""
    g = RIG_GAINS
    plant = replace(RIG_DRIVETRAIN, T_Cm=0.0, T_Cl=0.0, T_Sm=0.0, T_Sl=0.0)
    # in the gap the motor sees only J_m (the load is decoupled)
    loop = _python_control_loop(plant, g) if engaged else _python_control_loop(None, g, RIG_DRIVETRAIN.J_m)
    poles = ct.poles(loop)
    assert np.max(np.abs(poles)) < 0.9999
    # velocity loop alone: crossover near the design value, phase margin > 45°
    if engaged:
        A, B = linear_state_space(plant)
        Pw = ct.c2d(ct.ss(A, B, [[1.0, 0, 0, 0]], [[0.0]]), g.T_s, method="zoh")
    else:
        J = RIG_DRIVETRAIN.J_m
        Pw = ct.c2d(ct.ss([[-plant.beta_m / J]], [[1.0 / J]], [[1.0]], [[0.0]]), g.T_s, method="zoh")
    # PI in z: u = K_p e + x_i, x_i⁺ = x_i + (K_p/T_n) T_s e  →  K_p (1 + (T_s/T_n) / (z − 1))
    C = ct.tf([g.K_p, g.K_p * (g.T_s / g.T_n - 1.0)], [1.0, -1.0], g.T_s)
    # margins from a dense frequency response (the polynomial method of ct.margin is
    # ill-conditioned for the lightly damped shaft mode)
    w = np.logspace(0, np.log10(np.pi / g.T_s) - 0.01, 20_000)
    L = np.asarray(ct.frequency_response(C * Pw, w).complex).ravel()
    cross = np.where(np.diff(np.sign(np.abs(L) - 1.0)) != 0)[0]
    assert cross.size == 1  # a single gain crossover
    pm = 180.0 - abs(np.degrees(np.angle(L[cross[0]])))
    assert pm > 45.0
    # crossover: ω_cv = 100 rad/s engaged (J_m + J_l), 200 rad/s in the gap (J_m)
    assert w[cross[0]] == pytest.approx(100.0 if engaged else 200.0, rel=0.15)
    # and the magnitude stays below 1 above the crossover, across the shaft resonance
    assert np.max(np.abs(L[cross[0] + 5 :])) < 1.0


def test_gains_from_bandwidth() -> None:
    d = RIG_DRIVETRAIN
    g = gains_from_bandwidth(d, 100.0)
    assert g.K_p == pytest.approx(100.0 * (d.J_m + d.J_l))
    assert g.T_n == pytest.approx(0.04)
    assert g.K_v == pytest.approx(25.0)


def test_controller_class_and_anti_windup() -> None:
    """Hand-computed steps; under a persistent limit the integrator relaxes to the limit, never beyond."""
    g = CascadeGains(K_v=25.0, K_p=0.2, T_n=0.04, torque_limit=0.1, k_ff=1.0, T_s=1e-3)
    c = CascadeController(g)
    # unlimited step: e_ω = 25·(0.01) + 0.5 − 0.4 = 0.35, u = 0.2·0.35 = 0.07
    u = c.compute_output(0.01, 0.5, 0.0, 0.4)
    assert u == pytest.approx(0.07)
    c.update(g.T_s, u)
    assert c.x_i == pytest.approx(0.2 / 0.04 * 1e-3 * 0.35)  # plain PI increment
    # large error: limited output, integrator tends to +limit
    for _ in range(2000):
        u = c.compute_output(1.0, 0.0, 0.0, 0.0)
        assert u == pytest.approx(0.1)
        c.update(g.T_s, u)
        assert c.x_i <= 0.1 + 1e-15
    assert c.x_i == pytest.approx(0.1, rel=1e-6)  # relaxed with time constant T_n = 40 ms over 2 s
    # error reverses: the torque reverses at once (no wound-up integral to unwind)
    u = c.compute_output(0.0, 0.0, 0.01, 0.0)  # e_ω = −0.25 → u = 0.1 − 0.05
    assert u == pytest.approx(0.05)


@pytest.mark.parametrize("torque_limit", [60.0, 8.0])
def test_rack_axis_runs_the_one_cascade_controller(torque_limit: float) -> None:
    """The rack bench's kernel torque equals CascadeController fed with its measurements,
    sample by sample (bit for bit), unlimited (60 N·m) and repeatedly limited (8 N·m):
    both simulators share one controller and one anti-windup law."""
    from drivelash.physics.rack_pinion import RackPinionBench, TransmissionErrorModel
    from drivelash.sim.rack_axis import RackAxisSimulator, bench_gains, sine_trajectory

    bench = RackPinionBench()
    g = bench_gains(torque_limit=torque_limit)
    sim = RackAxisSimulator(bench, TransmissionErrorModel.generate(bench, seed=3), gains=g)
    _, xd, vd = sine_trajectory(1.0, 0.05, 1.0, periods=1.0, dwell=0.02)
    n = 6000
    xd, vd = xd[:n], vd[:n]
    vc = 2e-4 * np.sin(np.arange(n) / 200.0)
    _, out = sim.step_chunk(sim.initial_state(xd[0], 1), xd, vd, 2000.0, vc)
    ctrl = CascadeController(g, r=bench.r_eff)
    for k in range(n):
        u = ctrl.compute_output(xd[k], vd[k], out["x_T"][k], out["omega_m"][k], vc[k])
        assert u == out["torque_m"][k], k
        ctrl.update(g.T_s, u)
    limited = np.mean(np.abs(out["torque_m"]) >= torque_limit)
    if torque_limit < 10:
        assert limited > 0.05  # the limit does act in this run
    else:
        assert limited == 0.0
