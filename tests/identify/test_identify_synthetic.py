"""IDIM-LS against synthetic data with known parameters (closed-form trajectories)."""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.errors import ConfigError, DataError
from drivelash.estimation.identify import identify, identify_load, identify_rigid
from drivelash.io import Trace
from drivelash.io.config import IdentificationSection

DT = 1e-3


def _motion(t: np.ndarray, amp: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A multi-sine position with analytic velocity and acceleration (rich excitation)."""
    f = np.array([0.3, 0.71, 1.9, 3.3])
    a = amp * np.array([1.0, 0.4, 0.08, 0.02])
    w = 2 * np.pi * f
    q = (a[:, None] * np.sin(w[:, None] * t)).sum(0)
    dq = (a[:, None] * w[:, None] * np.cos(w[:, None] * t)).sum(0)
    ddq = (-a[:, None] * w[:, None] ** 2 * np.sin(w[:, None] * t)).sum(0)
    return q, dq, ddq


def test_rigid_axis_recovered_and_std_consistent(rng):
    """τ = M q̈ + F_v q̇ + F_c sgn q̇ + offset + white noise; estimates within 4 σ̂ of the truth
    (σ̂ from the LS covariance) and within 1 % — the std devs are honest, not decoration."""
    t = np.arange(20000) * DT
    q, dq, ddq = _motion(t)
    true = {"M": 2.5, "F_v": 0.8, "F_c": 0.6, "offset": -0.15}
    tau = true["M"] * ddq + true["F_v"] * dq + true["F_c"] * np.sign(dq) + true["offset"]
    tau = tau + 0.05 * rng.standard_normal(t.size)
    r = identify_rigid(Trace({"t": t, "theta_m": q, "torque_m": tau}))
    for name, value in true.items():
        assert abs(r[name] - value) < 4 * r.std_of(name) + 1e-3 * abs(value), name
        assert r[name] == pytest.approx(value, rel=0.01, abs=0.01)
    assert r.relative_error < 0.05


def test_quantised_position_still_identifies(rng):
    """A 2^16-count encoder: the zero-phase low-pass + decimation handle the quantisation."""
    t = np.arange(20000) * DT
    q, dq, ddq = _motion(t)
    qq = np.round(q / (2 * np.pi / 65536)) * (2 * np.pi / 65536)
    tau = 1.2 * ddq + 0.3 * dq + 0.4 * np.sign(dq)
    r = identify_rigid(Trace({"t": t, "theta_m": qq, "torque_m": tau}), cutoff_hz=20.0)
    assert r["M"] == pytest.approx(1.2, rel=0.02)
    assert r["F_v"] == pytest.approx(0.3, rel=0.02)
    assert r["F_c"] == pytest.approx(0.4, rel=0.02)


def test_load_side_two_mass():
    """Load side from the load encoder and the shaft torque estimated with eq (1)."""
    t = np.arange(20000) * DT
    ql, dql, ddql = _motion(t, amp=0.5)
    N = 3.0
    J_m, beta_m, T_Cm = 0.02, 0.01, 0.05
    J_l, beta_l, T_Cl = 0.4, 0.2, 0.3
    T_l = J_l * ddql + beta_l * dql + T_Cl * np.sign(dql)
    # a stiff shaft, θ_m/N − θ_l ≈ T_l / K_S, with the Coulomb step of the twist smoothed
    # (a real shaft cannot twist discontinuously)
    twist = (J_l * ddql + beta_l * dql + T_Cl * np.tanh(dql / 0.02)) / 2000.0
    qm = N * (ql + twist)
    dqm = np.gradient(qm, DT)
    ddqm = np.gradient(dqm, DT)
    u = J_m * ddqm + beta_m * dqm + T_Cm * np.sign(dqm) + T_l / N
    tr = Trace({"t": t, "theta_m": qm, "theta_l": ql, "torque_m": u})
    r = identify_load(tr, J_m=J_m, beta_m=beta_m, T_Cm=T_Cm, N=N)
    assert r.side == "load"
    assert r["J_l"] == pytest.approx(J_l, rel=0.02)
    assert r["beta_l"] == pytest.approx(beta_l, rel=0.03)
    assert r["T_Cl"] == pytest.approx(T_Cl, rel=0.03)
    assert r.drivetrain_values().keys() == {"J_l", "beta_l", "T_Cl"}
    # this load never rests: the rule of the test below leaves out only the rows where it
    # passes slowly through its reversals, and the estimates above are unchanged by it
    slow = np.abs(dql) <= 0.05 * np.percentile(np.abs(dql), 99)
    assert r.options["rows_at_rest"] / (r.n_rows + r.options["rows_at_rest"]) < slow.mean() + 0.05


def test_load_side_leaves_out_the_load_at_rest_in_the_gap():
    """With backlash the load rests while the motor crosses the gap (18 % of bench-0B): there
    the shaft torque and the friction are 0, not T_Cl sign ω̂_l. Those rows made noise-free
    bench-0B come out β_l +330 %, T_Cl −60 %.

    Reference: the plant's own parameters (the engine agrees with solve_ivp to 3e-6 rad), and a
    plain least squares on the simulator's true states (the deadzone torque (10) written out
    here) that leaves out |ω_l| ≤ 5 % of its 99th-percentile speed: the truth to 1e-3, so the
    rest samples — not the model — were the cause. Tolerances of the identification (3 %, 15 %
    for the small β_l, 3 %): what the 100 Hz position filter leaves of the contact impacts,
    measured −1.4 %, −8 %, +1.1 %.
    """
    import dataclasses

    from drivelash.params import SensorParams
    from drivelash.sim.scenarios import get_scenario

    sc = get_scenario("bench-0B")
    sc = dataclasses.replace(
        sc,
        sensors=SensorParams(counts_m=0, counts_l=0, sigma_omega_m=0.0, sigma_omega_l=0.0),
        plant_drivetrain=dataclasses.replace(sc.plant_drivetrain, T_Sm=0.0, T_Sl=0.0),
    )
    d, bl = sc.plant_drivetrain, sc.plant_backlash
    tr = sc.simulate(duration=10.0, seed=0, return_states=True)

    # independent reference on the true states
    wl = tr["omega_l_true"]
    dth = tr["theta_m_true"] / d.N - tr["theta_l_true"]
    dw = tr["omega_m_true"] / d.N - wl
    T_l = np.where(
        dth < -bl.delta1,
        d.K_S * (dth + bl.delta1) + d.D_S * dw,
        np.where(dth > bl.delta - bl.delta1, d.K_S * (dth + bl.delta1 - bl.delta) + d.D_S * dw, 0.0),
    )
    moving = np.abs(wl) > 0.05 * np.percentile(np.abs(wl), 99)
    assert 0.1 < 1.0 - moving.mean() < 0.3  # the load rests for a good part of the run
    A = np.column_stack([np.gradient(wl, tr.T_s), wl, np.sign(wl), np.ones_like(wl)])
    ref = np.linalg.lstsq(A[moving], T_l[moving], rcond=None)[0]
    assert ref[:3] == pytest.approx([d.J_l, d.beta_l, d.T_Cl], rel=1e-3)
    everything = np.linalg.lstsq(A, T_l, rcond=None)[0]  # the rest rows in: far off
    assert abs(everything[1] / d.beta_l - 1) > 1.0 and abs(everything[2] / d.T_Cl - 1) > 0.3

    r = identify_load(tr, J_m=d.J_m, beta_m=d.beta_m, T_Cm=d.T_Cm, N=d.N)
    assert r["J_l"] == pytest.approx(d.J_l, rel=0.03)
    assert r["beta_l"] == pytest.approx(d.beta_l, rel=0.15)
    assert r["T_Cl"] == pytest.approx(d.T_Cl, rel=0.03)
    assert 0.1 < r.options["rows_at_rest"] / (r.n_rows + r.options["rows_at_rest"]) < 0.35


def test_identify_dispatch_and_errors():
    t = np.arange(3000) * DT
    q, dq, ddq = _motion(t)
    tr = Trace({"t": t, "theta_m": q, "torque_m": 2 * ddq + np.sign(dq)})
    with pytest.raises(ConfigError, match="needs the motor parameters"):
        identify(tr, IdentificationSection(side="load"))
    with pytest.raises(DataError, match="theta_l"):
        identify_load(tr, J_m=1, beta_m=0, T_Cm=0, N=1)
    with pytest.raises(DataError, match="too short"):
        identify_rigid(tr.slice(0, 100))
    still = Trace({"t": t, "theta_m": np.zeros_like(t), "torque_m": np.ones_like(t)})
    with pytest.raises(DataError, match="does not excite"):
        identify_rigid(still)
