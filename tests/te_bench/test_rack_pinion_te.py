"""Bench geometry, kinematics (1) and the true-TE generator (spec 02 §1)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drivelash.errors import ParameterError
from drivelash.physics.rack_pinion import RackPinionBench, TEGeneratorParams, TransmissionErrorModel

from .helpers import spectrum_over_position

BENCH = RackPinionBench()
N_REV = 8  # analysis window: 8 pinion revolutions = 160 tooth pitches ≈ 2.133 m


def test_geometry_matches_spec_numbers():
    b = BENCH
    # spec 02 §1: d_p = 84.882 mm, pitch 13.333 mm, revolution 266.67 mm, reflected table 2.81e-3
    assert b.d_p == pytest.approx(84.882e-3, rel=1e-9)
    assert b.tooth_pitch == pytest.approx(13.333e-3, rel=1e-4)
    assert b.circumference == pytest.approx(266.67e-3, rel=1e-4)
    assert b.J_T_reflected == pytest.approx(2.81e-3, rel=2e-3)
    assert math.degrees(b.helix_angle) == pytest.approx(19.53, abs=0.01)
    assert b.J_s == pytest.approx(b.J_T_reflected + b.J_motor + b.J_gearbox + b.J_pinion / 256)


def test_contact_ratio_against_path_of_contact_construction():
    """ε_α from an independent construction: path of contact along the line of action,
    pinion tip circle intersected numerically, rack tip line; ε_β from the axial overlap."""
    b = BENCH
    m_t = b.m_n / math.cos(b.helix_angle)
    a_t = math.atan(math.tan(b.alpha_n) / math.cos(b.helix_angle))
    r = b.d_p / 2
    r_b = r * math.cos(a_t)
    # points along the line of action from the pitch point: distance s, radius² = r² + s² + 2 r s sin α_t
    from scipy.optimize import brentq

    s_tip = brentq(lambda s: math.hypot(r * math.cos(a_t), r * math.sin(a_t) + s) - (r + b.m_n), 0, r)
    s_rack = b.m_n / math.sin(a_t)
    eps_a = (s_tip + s_rack) / (math.pi * m_t * math.cos(a_t))
    assert r_b < r
    assert b.epsilon_alpha == pytest.approx(eps_a, rel=1e-9)
    eps_b = b.face_width * math.tan(b.helix_angle) / (math.pi * m_t)  # b tanβ / p_t
    assert b.epsilon_beta == pytest.approx(eps_b, rel=1e-9)
    assert 2.0 < b.epsilon < 3.5


def test_kinematics_eq1():
    theta = np.array([0.0, 1.0, -2.5])
    assert np.allclose(BENCH.x_M(theta), theta * BENCH.d_p / (2 * 16))
    x_T = np.array([0.1, 0.2, 0.3])
    assert np.allclose(BENCH.te_from_measurement(x_T, theta), x_T - theta * BENCH.d_p / 32)


def _amps(model, direction, F=0.0):
    x = np.arange(0.0, BENCH.travel, 20e-6)
    y = model.te(x, F, direction)
    k, a = spectrum_over_position(x, y, 0.02, N_REV * BENCH.circumference)
    return k, a


@pytest.mark.parametrize("direction", [1, -1])
def test_spectrum_peaks_at_pinion_and_tooth_periods(direction):
    model = TransmissionErrorModel.generate(BENCH, seed=3)
    k, a = _amps(model, direction)
    k_pin, k_mesh = N_REV, N_REV * BENCH.n_t
    conf = model.component_amplitudes(direction)
    # the peaks are where they should be ...
    assert k[4 + np.argmax(a[4:60])] == k_pin
    assert k[100 + np.argmax(a[100:400])] == k_mesh
    # ... with the configured amplitudes (acceptance: ±10 %; the generator alone is within 2 %)
    assert a[k_pin] == pytest.approx(conf["runout"], rel=0.02)
    assert a[k_mesh] == pytest.approx(conf["mesh"], rel=0.02)
    assert a[2 * k_mesh] == pytest.approx(conf["mesh2"], rel=0.1)
    assert 20e-6 < conf["runout"] < 30e-6
    assert 4e-6 <= conf["mesh"] <= 8e-6


@pytest.mark.parametrize("direction", [1, -1])
def test_mesh_amplitude_falls_with_load(direction):
    model = TransmissionErrorModel.generate(BENCH, seed=3)
    k_mesh = N_REV * BENCH.n_t
    amps = [_amps(model, direction, F)[1][k_mesh] for F in range(0, 5001, 500)]
    assert np.all(np.diff(amps) < 0)
    assert amps[-1] < 0.6 * amps[0]
    for F, a in zip(range(0, 5001, 500), amps, strict=True):
        assert a == pytest.approx(model.component_amplitudes(direction, F)["mesh"], rel=0.03)


def test_deformation_is_elastic_deflection_against_motion():
    model = TransmissionErrorModel.generate(BENCH, seed=4)
    x = np.linspace(0.1, 2.0, 5001)
    for d in (1, -1):
        mean_def = np.mean(model.deformation(x, 5000.0, d))
        # mean compliance c0 (the meshing and pinion parts average out over many periods)
        assert mean_def == pytest.approx(-d * 5000.0 * np.mean(model.c[(1 - d) // 2]), rel=0.02)
        assert np.allclose(model.te(x, 0.0, d), model.geometric(x, d))


def test_backlash_varies_within_configured_range():
    p = TEGeneratorParams()
    x = np.arange(0.0, BENCH.travel, 50e-6)
    for seed in range(6):
        model = TransmissionErrorModel.generate(BENCH, seed, p)
        b = model.backlash(x)
        assert b.min() >= p.b_min and b.max() <= p.b_max
        assert np.ptp(b) > 0.3 * (p.b_max - p.b_min)
        # the two direction curves differ by more than a constant: b varies also
        # at the pinion and tooth periods
        k, a = spectrum_over_position(x, b, 0.02, N_REV * BENCH.circumference)
        assert a[N_REV * BENCH.n_t] > 0.05e-6


def test_same_seed_identical_different_seed_different_but_alike():
    x = np.arange(0.0, BENCH.travel, 100e-6)
    a = TransmissionErrorModel.generate(BENCH, 11)
    b = TransmissionErrorModel.generate(BENCH, 11)
    assert np.array_equal(a.te(x, 1000.0, 1), b.te(x, 1000.0, 1))
    stats = []
    curves = []
    for seed in range(8):
        m = TransmissionErrorModel.generate(BENCH, seed)
        k, amp = _amps(m, 1)
        stats.append((amp[N_REV], amp[N_REV * BENCH.n_t]))
        curves.append(m.te(x, 0.0, 1))
    stats = np.array(stats)
    # statistically alike: runout 25 µm ± 10 %, mesh within 4–8 µm (paper §II)
    assert np.all(np.abs(stats[:, 0] / 25e-6 - 1) < 0.1)
    assert np.all((stats[:, 1] > 4e-6) & (stats[:, 1] < 8e-6))
    # but different drives
    for i in range(1, 8):
        assert np.sqrt(np.mean((curves[i] - curves[0]) ** 2)) > 5e-6


def test_local_defect_changes_only_locally():
    m = TransmissionErrorModel.generate(BENCH, 2)
    m2 = m.with_local_defect(1.0, 0.01, 3e-6)
    x = np.linspace(0.0, 2.2, 22001)
    diff = m2.te(x, 500.0, 1) - m.te(x, 500.0, 1)
    assert diff.max() == pytest.approx(3e-6, rel=1e-3)
    assert np.all(np.abs(diff[np.abs(x - 1.0) > 0.06]) < 1e-9)
    assert m.defects == ()  # the original is unchanged
    m3 = m.with_local_defect(1.0, 0.01, 3e-6, direction=-1)
    assert m3.backlash(1.0) - m.backlash(1.0) == pytest.approx(3e-6, rel=1e-6)
    # round trip through the manifest form
    m4 = TransmissionErrorModel.from_dict(m3.to_dict())
    assert np.array_equal(m4.te(x, 100.0, -1), m3.te(x, 100.0, -1))


def test_tables_reproduce_the_model():
    m = TransmissionErrorModel.generate(BENCH, 5)
    x0, dx, tab = m.tables(dx=10e-6)
    x = np.linspace(0.0, 2.2, 7777)
    lf = float(m.load_factor(2000.0))
    for j, d in enumerate((1, -1)):
        S = np.interp(x, x0 + dx * np.arange(tab.shape[1]), tab[3 * j])
        M = np.interp(x, x0 + dx * np.arange(tab.shape[1]), tab[3 * j + 1])
        c = np.interp(x, x0 + dx * np.arange(tab.shape[1]), tab[3 * j + 2])
        te_tab = S + M * lf - d * 2000.0 * c
        assert np.max(np.abs(te_tab - m.te(x, 2000.0, d))) < 2e-10  # linear-interpolation error on 10 µm


def test_invalid_parameters_raise_parameter_error():
    with pytest.raises(ParameterError, match="travel"):
        RackPinionBench(travel=0.02)  # less than two tooth pitches (26.7 mm)
    with pytest.raises(ParameterError, match="contact_ratio"):
        RackPinionBench(contact_ratio=1e9)
    with pytest.raises(ParameterError, match="b_max"):
        TEGeneratorParams(b_min=50e-6, b_max=40e-6)
    with pytest.raises(ParameterError, match="b_max"):
        TransmissionErrorModel.generate(BENCH, 0, TEGeneratorParams(b_min=30e-6, b_max=32e-6))
    with pytest.raises(ParameterError, match="direction"):
        TransmissionErrorModel.generate(BENCH, 0).te(0.1, 0.0, 0)


def test_vectorised_over_direction_and_force():
    m = TransmissionErrorModel.generate(BENCH, 6)
    x = np.linspace(0.1, 2.0, 101)
    d = np.where(np.arange(101) % 2 == 0, 1, -1)
    F = np.linspace(0.0, 5000.0, 101)
    te = m.te(x, F, d)
    ref = np.array([float(m.te(xi, Fi, int(di))) for xi, Fi, di in zip(x, F, d, strict=True)])
    np.testing.assert_allclose(te, ref, rtol=0, atol=1e-15)
    assert BENCH.table_friction(-0.1) == pytest.approx(BENCH.F_CT + 0.1 * BENCH.beta_T)


def test_geometry_and_drive_make_the_bench():
    """[geometry] and [drive] are the two parts of one bench; any travel the gearing allows."""
    from drivelash.physics.rack_pinion import RackDrive, RackGeometry

    geo = RackGeometry(m_n=3e-3, n_t=24, i_PG=10.0, travel=1.2, contact_ratio=2.1)
    bench = RackPinionBench.from_parts(geo, RackDrive(m_T=250.0))
    assert bench.geometry == geo and bench.drive == RackDrive(m_T=250.0)
    assert bench.epsilon == 2.1 and geo.epsilon == 2.1
    # d_p = m_n n_t / cos(beta), r_eff = d_p / (2 i_PG)
    assert bench.r_eff == pytest.approx(3e-3 * 24 / math.cos(bench.helix_angle) / 20.0, rel=1e-12)
    assert RackPinionBench.from_dict(bench.to_dict()) == bench
    assert RackGeometry().epsilon == pytest.approx(
        RackPinionBench().epsilon_alpha + RackPinionBench().epsilon_beta
    )
