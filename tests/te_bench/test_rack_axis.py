"""Closed-loop rack-and-pinion axis (spec 02 §2) and the path-error prediction (3)."""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.control.path_error import predict_path_error
from drivelash.errors import ParameterError
from drivelash.physics.rack_pinion import RackPinionBench, TransmissionErrorModel
from drivelash.sim.rack_axis import (
    RackAxisSimulator,
    bench_gains,
    constant_velocity_pass,
    sine_trajectory,
)

BENCH = RackPinionBench()


@pytest.fixture(scope="module")
def te_model():
    return TransmissionErrorModel.generate(BENCH, seed=1)


@pytest.fixture(scope="module")
def sim(te_model):
    return RackAxisSimulator(BENCH, te_model)


def _cruise(tr, v, settle=0.3):
    """Mask of the constant-velocity part (after the ramp and a settling time)."""
    t_a = max(np.pi * v / (2 * 0.5), 0.05)
    return (tr["t"] > 0.1 + t_a + settle) & (tr["t"] < tr["t"][-1] - 0.1 - t_a - 0.01)


def test_bench_gains_are_the_papers():
    g = bench_gains()
    assert (g.K_v, g.K_p, g.T_n, g.T_s, g.k_ff) == (231.0, 12.4, 3.05e-3, 125e-6, 1.0)


def test_ramp_without_te_has_zero_steady_state_following_error():
    sim0 = RackAxisSimulator(BENCH, TransmissionErrorModel.ideal(BENCH))
    t, xd, vd = constant_velocity_pass(0.2, 0.6, 0.05)
    tr = sim0.run(xd, vd, 1000.0)
    e = tr["x_d"] - tr["x_T"]
    sel = _cruise(tr, 0.05, settle=1.0)
    assert np.abs(e).max() > 1e-7  # the ramps do produce a transient error ...
    assert np.abs(e[sel]).max() < 1e-10  # ... that vanishes at constant velocity (feed-forward)
    # without feed-forward the same loop lags by v / K_v
    from dataclasses import replace

    no_ff = replace(bench_gains(), k_ff=0.0)
    tr2 = RackAxisSimulator(BENCH, TransmissionErrorModel.ideal(BENCH), gains=no_ff).run(xd, vd, 1000.0)
    e2 = tr2["x_d"] - tr2["x_T"]
    assert np.mean(e2[sel]) == pytest.approx(0.05 / 231.0, rel=1e-3)


def test_steady_state_torque_is_friction_plus_load(sim):
    """At constant velocity the PI integrator supplies motor friction + r (table friction + load)."""
    v, F = 0.05, 3000.0
    t, xd, vd = constant_velocity_pass(0.2, 0.7, v)
    tr = sim.run(xd, vd, F)
    sel = _cruise(tr, v)
    r = BENCH.r_eff
    expected = BENCH.T_Cm + BENCH.beta_m * v / r + r * (BENCH.F_CT + BENCH.beta_T * v + F)
    assert np.mean(tr["torque_m"][sel]) == pytest.approx(expected, rel=2e-3)
    assert np.all(tr["direction"][sel] == 1)


@pytest.mark.parametrize("direction", [1, -1])
def test_quasi_static_te_equals_the_te_model(sim, te_model, direction):
    """At 10 mm/s the measured TE = x_T − x_M is the model TE at the transmitted force."""
    v, F = 0.01, 2000.0
    a, b = (0.3, 0.6) if direction > 0 else (0.6, 0.3)
    t, xd, vd = constant_velocity_pass(a, b, v)
    tr = sim.run(xd, vd, F)
    sel = _cruise(tr, v)
    te_meas = BENCH.te_from_measurement(tr["x_T"], tr["theta_m"])
    F_tr = F + BENCH.F_CT + BENCH.beta_T * v
    te_true = te_model.te(tr["x_T"], F_tr, direction)
    # remainder: the mesh damper d acting on the deflection rate F c'(x) v (≈ 7 nm here:
    # 2150 N · 9.4e-8 m/N/m · 0.01 m/s · 9.1e5 N·s/m · 4e-9 m/N); inertia terms are ≪ 1 nm
    err = np.max(np.abs(te_meas - te_true)[sel])
    print(f"max |TE_sim - TE_model| = {err * 1e9:.2f} nm")
    assert err < 0.01e-6


def test_chunked_run_is_identical_to_one_run(sim):
    t, xd, vd = sine_trajectory(1.0, 0.02, 2.0, periods=1.0, dwell=0.02)
    n = xd.size
    F = np.full(n, 800.0)
    vc = 1e-4 * np.sin(np.arange(n) / 300.0)
    state0 = sim.initial_state(xd[0], 1)
    _, whole = sim.step_chunk(state0, xd, vd, F, vc)
    state = state0
    parts = []
    for i in range(0, n, 40):  # 5 ms compensation cycles
        state, out = sim.step_chunk(state, xd[i : i + 40], vd[i : i + 40], F[i : i + 40], vc[i : i + 40])
        parts.append(out)
    for key in whole:
        assert np.array_equal(whole[key], np.concatenate([p[key] for p in parts])), key
    tr = sim.run(xd, vd, F, vc, state=state0)
    assert np.array_equal(tr["x_T"], whole["x_T"])


def test_correction_velocity_is_a_velocity_feed_forward_only(sim):
    """v_c is subtracted from the velocity command: identical to a reduced feed-forward."""
    t, xd, vd = constant_velocity_pass(0.3, 0.5, 0.05)
    vc = np.where(vd > 0.01, 2e-4 * np.sin(2 * np.pi * 3.0 * t), 0.0)  # keeps the travel direction
    a = sim.run(xd, vd, 500.0, vc)
    b = sim.run(xd, vd - vc, 500.0)
    # equal up to the rounding of v_d − v_c (summation order differs)
    assert np.max(np.abs(a["x_T"] - b["x_T"])) < 1e-12
    assert np.max(np.abs(a["torque_m"] - b["torque_m"])) < 1e-6
    assert not np.array_equal(a["x_T"], sim.run(xd, vd, 500.0)["x_T"])


def test_true_te_rate_as_correction_removes_most_path_error(sim, te_model):
    """Sanity of the sign convention: v_c = dTE/dt along the planned path cuts the path error."""
    v = 0.1
    t, xd, vd = constant_velocity_pass(0.3, 1.0, v)
    F_tr = BENCH.F_CT + BENCH.beta_T * v
    te_plan = te_model.te(xd, F_tr, 1)
    vc = np.gradient(te_plan, t)
    base = sim.run(xd, vd, 0.0)
    comp = sim.run(xd, vd, 0.0, vc)
    sel = _cruise(base, v)
    e0 = np.mean(np.abs((base["x_d"] - base["x_T"])[sel]))
    e1 = np.mean(np.abs((comp["x_d"] - comp["x_T"])[sel]))
    assert e1 < 0.1 * e0


@pytest.mark.parametrize("v", [0.01, 0.02, 0.05, 0.1])
def test_eq3_predicts_the_simulated_path_error(sim, te_model, v, record_property):
    """Acceptance: eq (3) on the TE measured along the run predicts e_x with MAE < 0.1 µm
    (10 mm/s, no load; also the three campaign speeds). The MAE must also be small
    relative to the path error itself, else predicting zero would pass."""
    t, xd, vd = constant_velocity_pass(0.05, BENCH.travel - 0.05, v)
    tr = sim.run(xd, vd, 0.0)
    e = tr["x_d"] - tr["x_T"]
    sel = _cruise(tr, v)
    te_meas = BENCH.te_from_measurement(tr["x_T"], tr["theta_m"])
    e_hat = predict_path_error(te_meas, tr["t"], BENCH.J_s, sim.gains)
    mae = np.mean(np.abs(e - e_hat)[sel])
    record_property("mae_um", float(mae * 1e6))
    mean_e = np.mean(np.abs(e[sel]))
    print(f"v = {v * 1e3:g} mm/s: MAE = {mae * 1e6:.5f} µm, mean |e_x| = {mean_e * 1e6:.3f} µm")
    assert mae < 0.1e-6
    assert mae < 0.02 * np.mean(np.abs(e[sel]))
    # the TE *model* along the simulated table positions predicts it as well
    te_mod = te_model.te(tr["x_T"], BENCH.F_CT + BENCH.beta_T * v, 1)
    e_mod = predict_path_error(te_mod, tr["t"], BENCH.J_s, sim.gains)
    assert np.mean(np.abs(e - e_mod)[sel]) < 0.1e-6


@pytest.mark.parametrize("seed", [1, 3, 5])
def test_no_hunting_after_no_load_reversals(seed):
    """The backlash must not start a limit cycle at a slow no-load reversal (the table
    sticks, the motor crosses the gap): after each reversal the error settles again."""
    model = TransmissionErrorModel.generate(BENCH, seed)
    s = RackAxisSimulator(BENCH, model)
    t, xd, vd = sine_trajectory(1.1, 0.1, 0.25, periods=1.0)
    tr = s.run(xd, vd, 0.0)
    e = tr["x_d"] - tr["x_T"]
    for t_rev in (2.1,):
        late = (tr["t"] > t_rev + 0.4) & (tr["t"] < t_rev + 1.5)
        assert np.max(np.abs(e[late])) < 3e-6
    peak = (tr["t"] > 2.1) & (tr["t"] < 2.2)
    assert np.max(np.abs(e[peak])) > 5e-6  # the reversal error itself is there


def test_sine_trajectory_reverses_and_shows_backlash(sim, te_model):
    t, xd, vd = sine_trajectory(1.1, 0.1, 0.25, periods=1.0)
    tr = sim.run(xd, vd, 0.0)
    d = tr["direction"]
    assert set(np.unique(d)) == {-1.0, 1.0}
    te_meas = BENCH.te_from_measurement(tr["x_T"], tr["theta_m"])
    i_pos = np.argmin(np.abs(tr["t"] - 1.1))  # moving +, mid-stroke
    i_neg = np.argmin(np.abs(tr["t"] - 3.1))  # moving −, back at the same position
    assert tr["x_T"][i_pos] == pytest.approx(tr["x_T"][i_neg], abs=1e-3)
    gap = te_meas[i_neg] - te_meas[i_pos]
    # no load: the flanks carry the table friction at |v| (acceleration is zero mid-stroke)
    x = tr["x_T"][i_pos]
    F_fr = BENCH.F_CT + BENCH.beta_T * abs(tr["v_T"][i_pos])
    expected = float(te_model.te(x, F_fr, -1) - te_model.te(x, F_fr, 1))
    assert gap == pytest.approx(expected, abs=0.5e-6)
    assert expected - float(te_model.backlash(x)) > 1e-6  # the friction deflection is visible


def test_input_validation(sim):
    with pytest.raises(ParameterError):
        sim.initial_state(0.1, 0)
    with pytest.raises(ParameterError):
        sim.step_chunk(sim.initial_state(0.1, 1), np.zeros(4), np.zeros(3))
    with pytest.raises(ParameterError):
        constant_velocity_pass(0.0, 0.001, 0.1)


def test_sensor_noise_is_seeded_chunk_invariant_and_off_by_default(te_model):
    from drivelash.sim.rack_axis import AxisSimConfig, counter_gauss

    cfg = AxisSimConfig(sigma_x=5e-9, sigma_theta=1e-6, sigma_omega=1e-3, sigma_torque=0.02)
    t, xd, vd = constant_velocity_pass(0.3, 0.4, 0.05)
    a = RackAxisSimulator(BENCH, te_model, seed=7, config=cfg)
    tr = a.run(xd, vd, 0.0)
    # chunked == whole (the noise of sample k does not depend on the chunking)
    state = a.initial_state(xd[0], 1)
    xs = []
    for i in range(0, xd.size, 40):
        state, out = a.step_chunk(state, xd[i : i + 40], vd[i : i + 40], 0.0)
        xs.append(out["x_T"])
    assert np.array_equal(np.concatenate(xs), tr["x_T"])
    # a different seed gives different noise; the default config is noise-free
    b = RackAxisSimulator(BENCH, te_model, seed=8, config=cfg).run(xd, vd, 0.0)
    assert not np.array_equal(tr["x_T"], b["x_T"])
    clean = RackAxisSimulator(BENCH, te_model, seed=7).run(xd, vd, 0.0)
    assert np.array_equal(RackAxisSimulator(BENCH, te_model, seed=8).run(xd, vd, 0.0)["x_T"], clean["x_T"])
    # torque noise is on the recording only, at the configured level; the loop is unaffected
    cfg_tq = AxisSimConfig(sigma_torque=0.02)
    tq = RackAxisSimulator(BENCH, te_model, seed=7, config=cfg_tq).run(xd, vd, 0.0)
    assert np.array_equal(tq["x_T"], clean["x_T"])
    assert np.std(tq["torque_m"] - clean["torque_m"]) == pytest.approx(0.02, rel=0.05)
    # the recorded scale signal carries the noise
    assert np.std(tr["x_T"] - clean["x_T"]) > 5e-9
    # the generator is standard normal
    z = np.array([counter_gauss(3, k, 0) for k in range(20000)])
    assert abs(z.mean()) < 0.03 and abs(z.std() - 1) < 0.03
    with pytest.raises(ParameterError):
        AxisSimConfig(sigma_x=-1.0)


def test_read_only_inputs_compile_no_other_kernel(sim):
    """A read-only trajectory (an Arrow-backed column, a broadcast scalar load, a single-sample
    chunk) runs the same compiled ``axis_chunk`` as writable arrays: numba types a read-only array
    apart, and each extra signature compiled the kernel again (≈ 10 s; three were compiled by
    ``make test`` before session 26). Negative control: the read-only arrays reach ``step_chunk``."""
    from drivelash.sim import rack_axis

    t, xd, vd = sine_trajectory(1.0, 0.02, 2.0, periods=1.0, dwell=0.02)
    state0 = sim.initial_state(xd[0], 1)
    _, ref = sim.step_chunk(state0, xd, vd, np.full(xd.size, 800.0), None)
    before = set(rack_axis.axis_chunk.signatures)
    xr, vr = xd.copy(), vd.copy()
    xr.flags.writeable = vr.flags.writeable = False
    F = np.broadcast_to(np.asarray(800.0), xd.shape)
    assert not (xr.flags.writeable or vr.flags.writeable or F.flags.writeable)
    _, out = sim.step_chunk(state0, xr, vr, F, np.zeros(xd.size)[:1].repeat(xd.size))
    _, one = sim.step_chunk(state0, xr[:1], vr[:1], 800.0, 0.0)
    assert set(rack_axis.axis_chunk.signatures) == before and len(before) == 1
    assert np.array_equal(out["x_T"], ref["x_T"]) and one["x_T"][0] == ref["x_T"][0]
