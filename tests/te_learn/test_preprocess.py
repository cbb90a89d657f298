"""Preprocessing steps, each against an independent reference."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import butter, sosfreqz

from drivelash.errors import DataError, ParameterError
from drivelash.te.learn.features import bump_features, bump_row
from drivelash.te.learn.preprocess import (
    GearGeometry,
    GeometricCurve,
    TEPipeline,
    deformation,
    geometric_curve,
    lowpass,
    mesh_cutoff,
    monotone_part,
    remove_offset,
    resample_on_grid,
    transmission_error,
)

from .conftest import GEOM, PITCH, R_EFF


def test_monotone_part_drops_standstill_and_backlash_creep():
    x = np.array([0.0, 0.0, 1.0, 0.9, 1.0, 2.0, 2.0, 3.0])
    np.testing.assert_array_equal(monotone_part(x, 1), [0, 2, 5, 7])
    np.testing.assert_array_equal(monotone_part(-x, -1), [0, 2, 5, 7])


def test_resample_grid_is_aligned_and_exact_for_linear_columns():
    rng = np.random.default_rng(0)
    x = np.sort(rng.uniform(0.01234, 0.05678, 500))
    grid, cols = resample_on_grid(x[::-1], {"a": 3.0 * x[::-1] - 1.0}, step=50e-6)
    k = grid / 50e-6
    np.testing.assert_allclose(k, np.round(k), atol=1e-9)
    assert grid[0] >= x[0] and grid[-1] <= x[-1] and grid[0] - x[0] < 50e-6 and x[-1] - grid[-1] < 50e-6
    np.testing.assert_allclose(cols["a"], 3.0 * grid - 1.0, atol=1e-13)
    with pytest.raises(DataError):
        resample_on_grid(np.array([0.0, 1.0, 1.0]), {}, 0.1)
    with pytest.raises(ParameterError):
        resample_on_grid(x, {}, 0.0)


def test_transmission_error_eq1_with_bench_numbers():
    # paper §II: d_p = 84.882 mm, i_PG = 16: one motor revolution moves x_M by π d_p / 16
    theta = np.array([0.0, 2 * np.pi])
    te = transmission_error(np.array([0.0, 0.0166666]), theta, 0.084882, 16.0)
    np.testing.assert_allclose(te, [0.0, 0.0166666 - np.pi * 0.084882 / 16.0], atol=1e-15)


def test_geometric_curve_averages_runs_on_union_grid():
    g1 = np.arange(10, 20) * 1e-3
    g2 = np.arange(15, 30) * 1e-3
    geo = geometric_curve([g1, g2], [np.ones(10), 3 * np.ones(15)], step=1e-3)
    assert geo.x0 == pytest.approx(0.010) and geo.te.size == 20
    np.testing.assert_allclose(geo.te[:5], 1.0)
    np.testing.assert_allclose(geo.te[5:10], 2.0)
    np.testing.assert_allclose(geo.te[10:], 3.0)
    assert geo(0.0) == pytest.approx(1.0) and geo(1.0) == pytest.approx(3.0)  # clamped
    np.testing.assert_allclose(deformation(g1, np.full(10, 5.0), geo), [4.0] * 5 + [3.0] * 5)
    with pytest.raises(DataError):
        geometric_curve([], [])


def test_remove_offset():
    v = np.array([1.0, 2.0, 6.0])
    np.testing.assert_allclose(remove_offset(v), [-2.0, -1.0, 3.0])
    np.testing.assert_allclose(remove_offset(v, "none"), v)
    with pytest.raises(ParameterError):
        remove_offset(v, "median")


def test_lowpass_matches_squared_butterworth_response_and_has_no_phase():
    step = 50e-6
    fc = mesh_cutoff(GEOM.d_p, GEOM.n_t)
    # 3 × 20 / (π · 84.882 mm) = 225.0 1/m: the third tooth-meshing harmonic
    assert fc == pytest.approx(3 * 20 / (np.pi * 0.084882), rel=1e-12)
    x = np.arange(0, 2.0, step)
    sos = butter(4, fc / (0.5 / step), output="sos")
    for f in (1 / PITCH, 2 * fc):
        _, h = sosfreqz(sos, worN=[f], fs=1 / step)
        y = lowpass(np.sin(2 * np.pi * f * x), step, fc)
        mid = slice(x.size // 4, 3 * x.size // 4)
        np.testing.assert_allclose(y[mid], np.abs(h[0]) ** 2 * np.sin(2 * np.pi * f * x[mid]), atol=2e-4)


def test_bump_features_eq4_5_properties():
    eps = GEOM.eps
    x = np.linspace(0.0, 2 * GEOM.n_t * PITCH, 20001)
    M = bump_features(x, GEOM.n_t, GEOM.d_p, eps)
    assert M.shape == (x.size, GEOM.n_t)
    assert M.max() <= 1.0 and M.min() >= 0.0
    # tooth j peaks (η = 0, M = e⁰ = 1) where x n_t/(π d_p) − j ≡ ε/2 (mod n_t)
    for j in (1, 7, 20):
        xp = (j + eps / 2) * PITCH
        row = bump_features(np.array([xp]), GEOM.n_t, GEOM.d_p, eps)[0]
        assert row[j - 1] == pytest.approx(1.0, rel=1e-12)
    # each tooth is in mesh for ε pitches per pinion revolution; at any position ⌊ε⌋ or ⌈ε⌉ teeth
    active = (M > 0).sum(axis=1)
    assert set(np.unique(active)) <= {int(np.floor(eps)), int(np.ceil(eps))}
    frac = (M[:, 0] > 0).mean()
    assert frac == pytest.approx(eps / GEOM.n_t, abs=2e-3)
    # periodic with the pinion circumference
    np.testing.assert_allclose(
        bump_features(x[:100] + GEOM.n_t * PITCH, GEOM.n_t, GEOM.d_p, eps), M[:100], atol=1e-9
    )
    # the njit row kernel agrees with the vectorised form
    out = np.empty(GEOM.n_t)
    for i in (0, 123, 4567, 20000):
        bump_row(x[i], GEOM.n_t, GEOM.d_p, eps, out)
        np.testing.assert_allclose(out, M[i], rtol=1e-13, atol=1e-300)


def _synthetic_run(direction: int, te_fn, F: float = 0.0, v: float = 0.02, T_s: float = 1e-3):
    """Columns of a constant-velocity pass whose TE is ``te_fn(x)`` exactly."""
    t = np.arange(0.0, 0.3 / v, T_s)
    x = 0.01 + v * t if direction > 0 else 0.31 - v * t
    x = np.concatenate([np.full(50, x[0]), x, np.full(50, x[-1])])  # standstill at both ends
    te = te_fn(x)
    return {
        "t": np.arange(x.size) * T_s,
        "x_T": x,
        "theta_m": (x - te) / R_EFF,
        "torque_m": np.full(x.size, F * R_EFF + 0.4),
        "direction": np.full(x.size, float(direction)),
    }


def test_pipeline_recovers_deformation():
    pipe = TEPipeline(GEOM, offset="none")

    def geo_fn(x):
        return 20e-6 * np.sin(2 * np.pi * x / (GEOM.n_t * PITCH)) + 5e-6 * np.cos(2 * np.pi * x / PITCH)

    def def_fn(x):
        return -2e-6 * np.cos(2 * np.pi * x / PITCH + 0.3) - 8e-6

    geo = pipe.geometric([_synthetic_run(1, geo_fn)], 1)
    assert isinstance(geo, GeometricCurve)
    run = pipe.process(_synthetic_run(1, lambda x: geo_fn(x) + def_fn(x), F=2000.0), 1, geo, {"load": 2000.0})
    assert run.x[0] >= 0.01 + pipe.trim - 1e-9 and run.direction == 1
    mid = slice(run.x.size // 8, -run.x.size // 8)
    np.testing.assert_allclose(run.te_def_um[mid], def_fn(run.x[mid]) * 1e6, atol=2e-3)
    np.testing.assert_allclose(run.torque, 2000.0 * R_EFF + 0.4, atol=1e-9)
    # default offset removal: the run mean goes, the shape stays
    run2 = TEPipeline(GEOM).process(_synthetic_run(1, lambda x: geo_fn(x) + def_fn(x)), 1, geo)
    assert abs(run2.te_def_um.mean()) < 1e-3  # removed before the filter (edge effects only)
    # negative direction
    geo_n = pipe.geometric([_synthetic_run(-1, geo_fn)], -1)
    run_n = pipe.process(_synthetic_run(-1, lambda x: geo_fn(x) + def_fn(x)), -1, geo_n)
    np.testing.assert_allclose(run_n.te_def_um[mid], def_fn(run_n.x[mid]) * 1e6, atol=2e-3)
    X = pipe.design_matrix(run.x, run.torque)
    assert X.shape == (run.x.size, 2 + GEOM.n_t)


def test_geometry_validation_and_roundtrip():
    with pytest.raises(ParameterError):
        GearGeometry(0.08, 1, 16.0, 2.0)
    with pytest.raises(ParameterError):
        GearGeometry(-0.08, 20, 16.0, 2.0)
    p = TEPipeline(GEOM, step=1e-4)
    assert TEPipeline.from_dict(p.to_dict()) == p
