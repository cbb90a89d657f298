"""Compensator kernels (spec 02 §5) against closed forms of analytic TE functions."""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.errors import DataError, ParameterError
from drivelash.te.runtime.compensator import (
    S_B,
    S_FLANK,
    S_TE_HAT,
    Compensator,
    CompensatorParams,
    smooth_step,
    smooth_step_rate,
)
from drivelash.te.runtime.export import export_table, load_table
from drivelash.te.runtime.table import TETable, build_table

from .analytic import BilinearTE, SineTE

T_SC = 5e-3


def _table(model, dx=0.1e-3, tmax=10.0, n_t=11):
    return build_table(model, 0.0, 1.0, dx, tmax, n_t)


# -- smooth step (7) ---------------------------------------------------------


def test_smooth_step_closed_form_and_derivative():
    tau = np.linspace(-0.5, 1.5, 2001)
    s = np.array([smooth_step(t) for t in tau])
    ref = np.where(tau <= 0, 0.0, np.where(tau >= 1, 1.0, 3 * tau**2 - 2 * tau**3))
    np.testing.assert_allclose(s, ref, atol=1e-15)
    # derivative against a central difference (O(h²) = 1e-8 here)
    h = 1e-4
    ds = np.array([smooth_step_rate(t) for t in tau])
    fd = np.array([(smooth_step(t + h) - smooth_step(t - h)) / (2 * h) for t in tau])
    away = (np.abs(tau) > 2 * h) & (np.abs(tau - 1) > 2 * h)  # s'' jumps at τ = 0 and 1
    np.testing.assert_allclose(ds[away], fd[away], atol=1e-6)
    assert smooth_step_rate(0.5) == pytest.approx(1.5)


# -- table -------------------------------------------------------------------


def test_table_reproduces_bilinear_model_exactly():
    m = BilinearTE()
    tab = build_table(m, 0.0, 2.0, 0.05, 12.0, 7)
    rng = np.random.default_rng(1)
    x = rng.uniform(0, 2, 500)
    for d in (1, -1):
        t = d * rng.uniform(0, 12, 500)
        np.testing.assert_allclose(tab.predict(x, t, d), m.predict(x, t, d), rtol=0, atol=1e-15)


def test_table_interpolation_error_bound_for_sine():
    # linear interpolation error ≤ h²/8 · max|f''| = h²/8 · A (2π/λ)²
    m = SineTE()
    dx = 0.2e-3
    tab = _table(m, dx=dx)
    x = np.linspace(0.01, 0.99, 10001)
    err = np.abs(tab.predict(x, 3.0, 1) - m.predict(x, 3.0, 1)).max()
    bound = dx**2 / 8 * m.A * (2 * np.pi / m.lam) ** 2
    assert err <= bound * 1.01
    assert err > 0.3 * bound  # the bound is tight, so the check has teeth


def test_table_clamps_outside_grid_and_rejects_bad_input():
    tab = build_table(BilinearTE(), 0.0, 1.0, 0.1, 10.0, 3)
    assert tab.predict(-5.0, 3.0, 1) == pytest.approx(tab.predict(0.0, 3.0, 1))
    assert tab.predict(0.5, 99.0, 1) == pytest.approx(tab.predict(0.5, 10.0, 1))
    assert tab.predict(0.5, 99.0, -1) == pytest.approx(tab.predict(0.5, 0.0, -1))
    with pytest.raises(ParameterError):
        tab.predict(0.5, 1.0, 0)
    with pytest.raises(DataError):
        TETable(0.0, 1e-3, np.zeros(2), np.ones(2), np.zeros((2, 1, 3)))
    with pytest.raises(DataError):
        TETable(0.0, 1e-3, np.zeros(2), np.ones(2), np.full((2, 4, 3), np.nan))


@pytest.mark.parametrize("suffix", [".csv", ".json"])
def test_export_roundtrip(tmp_path, suffix):
    tab = build_table(SineTE(), 0.0, 0.2, 0.5e-3, 10.0, 5, meta={"model": "sine"})
    p = export_table(tab, tmp_path / f"table{suffix}", CompensatorParams())
    back = load_table(p)
    assert back.te.shape == tab.te.shape
    np.testing.assert_allclose(back.te, tab.te, atol=1e-12)  # 1e-6 µm printed resolution
    np.testing.assert_allclose(back.x_grid, tab.x_grid, atol=1e-12)
    for d in (1, -1):
        np.testing.assert_allclose(back.torque_grid(d), tab.torque_grid(d), atol=1e-9)
    assert back.meta == {"model": "sine"}


def test_export_rejects_unknown_format_and_malformed_files(tmp_path):
    tab = build_table(BilinearTE(), 0.0, 1.0, 0.1, 10.0, 3)
    with pytest.raises(DataError):
        export_table(tab, tmp_path / "t.xlsx")
    bad = tmp_path / "bad.json"
    bad.write_text('{"grid": {}}')
    with pytest.raises(DataError):
        load_table(bad)
    bad_csv = tmp_path / "bad.csv"
    bad_csv.write_text("a,b\n1,2\n")
    with pytest.raises(DataError):
        load_table(bad_csv)


# -- (6): correction velocity of the TE ---------------------------------------


def test_v_te_equals_secant_of_model_on_planned_trajectory():
    m = SineTE()
    tab = _table(m, dx=0.02e-3)
    comp = Compensator(tab, CompensatorParams(v_max=1.0), flank=1)
    v = 0.1  # m/s
    t = np.arange(200) * T_SC
    x_d = 0.2 + v * np.append(t, t[-1] + T_SC)
    tq = np.full(t.size, 4.0)
    vc, vte, vbl = comp.run(x_d, tq, np.full(t.size, 50.0), np.zeros(t.size))
    ref = (m.predict(x_d[1:], 4.0, 1) - m.predict(x_d[:-1], 4.0, 1)) / T_SC
    # table error ≤ 2·(dx²/8)·A(2π/λ)² / t_sc ≈ 1.1e-6 m/s
    np.testing.assert_allclose(vte, ref, atol=1.2e-6)
    np.testing.assert_array_equal(vbl, 0.0)
    np.testing.assert_array_equal(vc, vte)
    # the secant tends to the derivative v·dTE/dx at the midpoint (closed form)
    mid = 0.5 * (x_d[1:] + x_d[:-1])
    np.testing.assert_allclose(vte, v * m.dte_dx(mid), atol=0.02 * v * m.A * 2 * np.pi / m.lam)
    # v_c integrates to the model TE change (offset-free TE estimate)
    dte = m.predict(x_d[-1], 4.0, 1) - m.predict(x_d[0], 4.0, 1)
    assert comp.state[S_TE_HAT] == pytest.approx(dte, abs=2e-9)


def test_torque_never_reaches_the_output_directly():
    # standing still on one flank: any torque history gives v_c = 0
    m = SineTE(c=5e-6)  # strongly torque-dependent model
    tab = _table(m)
    comp = Compensator(tab, CompensatorParams(v_max=1.0), flank=1)
    rng = np.random.default_rng(3)
    n = 300
    vc, _, _ = comp.run(np.full(n + 1, 0.3), rng.uniform(0.5, 10.0, n), np.zeros(n), np.zeros(n))
    np.testing.assert_array_equal(vc, 0.0)
    # moving: v_c equals the model secant at the torque of the cycle, nothing else
    comp.reset(1)
    x_d = 0.3 + 0.05 * T_SC * np.arange(n + 1)
    tq = rng.uniform(0.5, 10.0, n)
    vc, _, _ = comp.run(x_d, tq, np.full(n, 10.0), np.zeros(n))
    ref = (tab.predict(x_d[1:], tq, 1) - tab.predict(x_d[:-1], tq, 1)) / T_SC
    np.testing.assert_allclose(vc, ref, rtol=0, atol=1e-12)


# -- (7): backlash and flank detection -----------------------------------------


def _reversal_inputs(n=120, k_flip=40, x_flip=0.4):
    """Set position reverses at k_flip; motor torque follows with sign change there."""
    v = 0.02
    k = np.arange(n + 1)
    x_d = x_flip - v * T_SC * np.abs(k - k_flip)
    tq = np.where(k[:-1] < k_flip, 3.0, -3.0)
    omega = np.where(k[:-1] < k_flip, 30.0, -30.0)
    return x_d, tq, omega, np.zeros(n)


def test_backlash_step_sums_to_b_and_follows_smooth_step():
    m = SineTE()
    p = CompensatorParams(v_max=1.0, hysteresis=0.5, t_ss_sign=35e-3, release=0.0, bl_gain=1.0)
    comp = Compensator(_table(m, dx=0.05e-3), p, flank=1)
    x_d, tq, om, al = _reversal_inputs()
    vc, vte, vbl = comp.run(x_d, tq, om, al)
    k_flip = 40
    assert np.all(vbl[:k_flip] == 0) and comp.flank == -1
    b = m.predict(x_d[k_flip], -3.0, -1) - m.predict(x_d[k_flip], 3.0, 1)
    assert comp.state[S_B] == pytest.approx(b, abs=1e-9)  # table error at the flip position
    assert np.sum(vbl) * T_SC == pytest.approx(b, rel=1e-12)
    # profile: cycle j after the flip holds b·(s((j+1)t/t_ss) − s(j t/t_ss))/t_sc
    j = np.arange(vbl.size - k_flip)
    tau0, tau1 = j * T_SC / p.t_ss_sign, (j + 1) * T_SC / p.t_ss_sign
    s = lambda z: np.clip(3 * np.clip(z, 0, 1) ** 2 - 2 * np.clip(z, 0, 1) ** 3, 0, 1)  # noqa: E731
    np.testing.assert_allclose(vbl[k_flip:], comp.state[S_B] * (s(tau1) - s(tau0)) / T_SC, rtol=1e-12)
    assert np.count_nonzero(vbl) == 7  # t_ss_sign / t_sc cycles (change found from the torque sign)
    # peak of the continuous derivative is 1.5 b / t_ss
    assert np.max(np.abs(vbl)) <= 1.5 * abs(b) / p.t_ss_sign + 1e-12


def test_bl_gain_scales_the_step():
    m = SineTE()
    x_d, tq, om, al = _reversal_inputs()
    sums = []
    for g in (1.0, 0.95):
        comp = Compensator(_table(m), CompensatorParams(v_max=1.0, bl_gain=g), flank=1)
        _, _, vbl = comp.run(x_d, tq, om, al)
        sums.append(np.sum(vbl) * T_SC)
    assert sums[1] == pytest.approx(0.95 * sums[0], rel=1e-12)
    assert sums[0] == pytest.approx(m.backlash(0.4), rel=0.02)  # plus the small |T| term of the model


def test_flank_from_mesh_torque_not_from_set_point_direction():
    m = SineTE()
    # load pulls the table along: set point reverses, mesh torque stays positive
    comp = Compensator(_table(m), CompensatorParams(v_max=1.0, release=0.0), flank=1)
    x_d, _, om, al = _reversal_inputs()
    n = om.size
    vc, _, vbl = comp.run(x_d, np.full(n, 2.0), om, al)
    assert comp.flank == 1 and np.all(vbl == 0)
    # negative motor torque that is only deceleration torque: no flank change
    p = CompensatorParams(v_max=1.0, J_flank=1e-3, hysteresis=0.2, release=0.0)
    comp = Compensator(_table(m), p, flank=1)
    alpha = np.full(n, -2000.0)  # J α = −2 N·m
    comp.run(x_d, np.full(n, -1.5), np.full(n, 30.0), alpha)
    assert comp.flank == 1
    # same torque without the acceleration: the flank does change
    comp = Compensator(_table(m), p, flank=1)
    comp.run(x_d, np.full(n, -1.5), np.full(n, 30.0), np.zeros(n))
    assert comp.flank == -1
    # friction estimate is subtracted: 0.3 N·m Coulomb at positive speed masks −0.25 N·m
    p = CompensatorParams(v_max=1.0, T_C=0.3, omega_reg=0.1, hysteresis=0.5, release=0.0)
    comp = Compensator(_table(m), p, flank=1)
    comp.run(x_d, np.full(n, -0.25), np.full(n, -30.0), np.zeros(n))  # mesh = −0.25 + 0.3 > −0.5
    assert comp.flank == 1
    comp.run(x_d, np.full(n, -0.25), np.full(n, 30.0), np.zeros(n))  # mesh = −0.55
    assert comp.flank == -1


def test_release_with_planned_reversal_starts_the_step_early():
    m = SineTE()
    p = CompensatorParams(v_max=1.0, hysteresis=0.5, release=0.2)
    x_d, _, _, al = _reversal_inputs()  # plan reverses at cycle 40
    n = al.size
    # mesh torque ≈ 0 (gap being traversed): the flank changes exactly when the plan reverses
    comp = Compensator(_table(m), p, flank=1)
    _, _, vbl = comp.run(x_d, np.full(n, 0.05), np.zeros(n), al)
    assert comp.flank == -1 and np.flatnonzero(vbl)[0] == 40
    # same torque but the plan keeps its direction: no change (standstill, creeping)
    comp = Compensator(_table(m), p, flank=1)
    comp.run(0.4 + 1e-4 * np.arange(n + 1), np.full(n, 0.05), np.zeros(n), al)
    assert comp.flank == 1
    comp.run(np.full(n + 1, 0.4), np.full(n, 0.05), np.zeros(n), al)
    assert comp.flank == 1
    # the plan reverses but the flank still carries torque: no change
    comp = Compensator(_table(m), p, flank=1)
    comp.run(x_d, np.full(n, 0.3), np.zeros(n), al)
    assert comp.flank == 1
    # a load that fades only in the last cycle before the reversal: no release (the
    # torque sign reports the change later, with the slow step)
    tq = np.where(np.arange(n) < 39, 3.0, 0.05)
    comp = Compensator(_table(m), p, flank=1)
    comp.run(x_d[:42], tq[:41], np.zeros(41), al[:41])
    assert comp.flank == 1


def test_lockout_ignores_impact_spikes_after_a_flank_change():
    m = SineTE()
    p = CompensatorParams(v_max=1.0, hysteresis=0.1, t_lock=0.05)
    n = 40
    tq = np.array([2.0] * 5 + [-2.0] + [3.0, -3.0] * 4 + [-2.0] * (n - 14))  # spikes for 40 ms
    comp = Compensator(_table(m), p, flank=1)
    _, _, vbl = comp.run(np.full(n + 1, 0.25), tq, np.zeros(n), np.zeros(n))
    assert comp.flank == -1
    assert np.sum(vbl) * T_SC == pytest.approx(comp.state[S_B], rel=1e-12)  # one single step
    comp = Compensator(_table(m), CompensatorParams(v_max=1.0, hysteresis=0.1, t_lock=0.0), flank=1)
    _, _, vbl0 = comp.run(np.full(8, 0.25), tq[:7], np.zeros(7), np.zeros(7))
    assert comp.flank == 1  # without the lockout the spike toggles the flank back


def test_hysteresis_rejects_torque_noise():
    m = SineTE()
    comp = Compensator(_table(m), CompensatorParams(v_max=1.0, hysteresis=0.5), flank=1)
    rng = np.random.default_rng(7)
    n = 400
    tq = 0.1 + 0.15 * rng.standard_normal(n)  # |noise| < 0.5 almost surely (3.3 σ)
    comp.run(np.full(n + 1, 0.2), tq, np.zeros(n), np.zeros(n))
    assert comp.flank == 1


def test_flank_change_during_running_step_keeps_the_net_jump():
    m = SineTE()
    comp = Compensator(_table(m), CompensatorParams(v_max=1.0, hysteresis=0.1, t_lock=0.0), flank=1)
    n = 40
    x = np.full(n + 1, 0.25)
    tq = np.array([2.0] * 5 + [-2.0] * 3 + [2.0] * (n - 8))
    _, _, vbl = comp.run(x, tq, np.zeros(n), np.zeros(n))
    # back on flank +1 at the same position: the net TE change is zero
    assert comp.flank == 1
    assert np.sum(vbl) * T_SC == pytest.approx(0.0, abs=1e-15)
    assert np.any(vbl != 0)


def test_v_c_limited_to_drive_limit():
    m = SineTE(b0=2e-3, b1=0.0)  # absurd 2 mm backlash
    p = CompensatorParams(v_max=0.01, hysteresis=0.1)
    comp = Compensator(_table(m), p, flank=1)
    x_d, tq, om, al = _reversal_inputs()
    vc, _, vbl = comp.run(x_d, tq, om, al)
    assert np.max(np.abs(vc)) == pytest.approx(0.01)
    assert np.max(np.abs(vbl)) > 0.01  # the unlimited component would exceed it


# -- state handling -------------------------------------------------------------


def test_chunked_run_equals_single_run_equals_steps():
    m = SineTE()
    tab = _table(m)
    p = CompensatorParams(v_max=1.0, J_flank=1e-4, T_C=0.1, beta=1e-3, hysteresis=0.3, J_model=2e-3)
    rng = np.random.default_rng(11)
    n = 250
    t = np.arange(n + 1) * T_SC
    x_d = 0.5 + 0.05 * np.sin(2 * np.pi * 1.5 * t)
    tq = 3.0 * np.cos(2 * np.pi * 1.5 * t[:-1]) + 0.2 * rng.standard_normal(n)
    om = 100 * np.cos(2 * np.pi * 1.5 * t[:-1])
    al = -100 * 2 * np.pi * 1.5 * np.sin(2 * np.pi * 1.5 * t[:-1])
    one = Compensator(tab, p, flank=1)
    v1, _, _ = one.run(x_d, tq, om, al)
    chunked = Compensator(tab, p, flank=1)
    parts = []
    for a, b in [(0, 17), (17, 100), (100, 101), (101, n)]:
        parts.append(chunked.run(x_d[a : b + 1], tq[a:b], om[a:b], al[a:b])[0])
    stepper = Compensator(tab, p, flank=1)
    v3 = np.array([stepper.step(x_d[k], x_d[k + 1], tq[k], om[k], al[k])[0] for k in range(n)])
    np.testing.assert_array_equal(np.concatenate(parts), v1)
    np.testing.assert_array_equal(v3, v1)
    np.testing.assert_array_equal(chunked.state, one.state)
    assert one.state[S_FLANK] in (1.0, -1.0)
    assert np.count_nonzero(np.diff(np.sign(tq)))  # the run did cross flanks


def test_params_validation_names_field():
    with pytest.raises(ParameterError) as ei:
        CompensatorParams(t_sc=0.0)
    assert ei.value.field == "t_sc"
    with pytest.raises(ParameterError) as ei:
        CompensatorParams(hysteresis=-1.0)
    assert ei.value.field == "hysteresis"


def test_run_rejects_missing_lookahead():
    comp = Compensator(_table(SineTE()), CompensatorParams())
    with pytest.raises(DataError):
        comp.run(np.zeros(5), np.zeros(5), np.zeros(5), np.zeros(5))
