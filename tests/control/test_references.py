"""Reference generators: closed forms, derivative consistency, validation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drivelash.control.references import constant_velocity_passes, position_sine, sampled, velocity_sine
from drivelash.errors import ParameterError

T_S = 125e-6


def test_position_sine_bench() -> None:
    r = position_sine(4.0, T_S, amplitude=1.0, frequency=0.5)
    assert r.t.size == 32000 and r.t[1] == T_S
    np.testing.assert_allclose(r.theta_ref, np.sin(math.pi * r.t), atol=1e-15)
    np.testing.assert_allclose(r.omega_ref, math.pi * np.cos(math.pi * r.t), atol=1e-14)


def test_velocity_sine_paper() -> None:
    r = velocity_sine(1.0, T_S, amplitude=4 * math.pi, frequency=2.0)
    np.testing.assert_allclose(r.omega_ref, 4 * math.pi * np.sin(4 * math.pi * r.t), atol=1e-13)
    # θ_r is the integral of ω_r: compare with the trapezoidal rule (error ~ T_s²)
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (r.omega_ref[1:] + r.omega_ref[:-1]) * T_S)])
    np.testing.assert_allclose(r.theta_ref, integral, atol=1e-6)


def test_constant_velocity_passes() -> None:
    r = constant_velocity_passes(10.0, T_S, velocity=0.5, stroke=1.0, acceleration=5.0, dwell=0.2)
    assert np.min(r.theta_ref) == pytest.approx(0.0, abs=1e-12)
    assert np.max(r.theta_ref) == pytest.approx(1.0, abs=1e-12)
    assert np.max(np.abs(r.omega_ref)) == pytest.approx(0.5)
    # ω_r is the derivative of θ_r
    np.testing.assert_allclose(np.gradient(r.theta_ref, T_S), r.omega_ref, atol=5.0 * T_S + 1e-9)
    # pass time 2·0.1 + (1 − 5·0.01)/0.5 = 2.1 s, + 0.2 s dwell: 10 s holds 4 reversals
    moving = np.abs(r.omega_ref) > 0.25
    signs = np.sign(r.omega_ref[moving])
    assert np.sum(signs[1:] != signs[:-1]) == 4
    # triangular profile when the stroke is too short to reach the velocity
    tri = constant_velocity_passes(2.0, T_S, velocity=10.0, stroke=0.1, acceleration=1.0)
    assert np.max(tri.omega_ref) == pytest.approx(math.sqrt(0.1), rel=1e-3)


def test_sampled_reference() -> None:
    t = np.arange(1000) * 1e-3
    r = sampled(t, np.sin(3 * t))
    np.testing.assert_allclose(r.omega_ref[1:-1], 3 * np.cos(3 * t[1:-1]), atol=1e-5)
    with pytest.raises(ParameterError):
        sampled(t, np.sin(3 * t)[:-1])
    with pytest.raises(ParameterError):
        constant_velocity_passes(1.0, T_S, velocity=-1.0, stroke=1.0, acceleration=1.0)
    with pytest.raises(ParameterError):
        position_sine(-1.0, T_S)
