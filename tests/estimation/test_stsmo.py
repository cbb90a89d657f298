"""STSMO: recovers a known perturbation; kernel equals its pure-Python version."""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.errors import ParameterError
from drivelash.estimation.stsmo import STSMOParams, SuperTwistingObserver, stsmo_run


def _signal(n: int, T_s: float, rng: np.random.Generator):
    t = np.arange(n) * T_s
    # ω̇ = a_known + φ with φ = 20 sin(2π·3 t) (the perturbation to recover)
    phi = 20.0 * np.sin(2 * np.pi * 3.0 * t)
    a_known = -2.0 * np.ones(n)
    omega = np.cumsum((a_known + phi) * T_s)
    return t, omega, a_known, phi


def test_recovers_perturbation(rng):
    T_s = 1e-4
    t, omega, a_known, phi = _signal(20000, T_s, rng)
    obs = SuperTwistingObserver(STSMOParams.from_rho(20 * 2 * np.pi * 3 * 4, T_s))
    _, phi_hat = obs.run(omega, a_known)
    late = t > 0.5
    # dφ/dt ≤ 377 rad/s³; chattering of the Euler-discretised STA is O(k2 T_s) ≈ 0.17 rad/s²,
    # lag O(φ̇/k2); 1.0 rad/s² is 5 % of the amplitude.
    assert np.max(np.abs(phi_hat[late] - phi[late])) < 1.0


def test_chunked_equals_single_and_py_func(rng):
    T_s = 1e-4
    _, omega, a_known, _ = _signal(3000, T_s, rng)
    omega = omega + 0.01 * rng.standard_normal(omega.size)
    p = STSMOParams(k1=30.0, k2=400.0, T_s=T_s).as_array()
    s0 = np.array([0.1, -0.5])
    s1, w1, f1 = stsmo_run(s0, omega, a_known, p)
    sa, wa, fa = stsmo_run(s0, omega[:1234], a_known[:1234], p)
    sb, wb, fb = stsmo_run(sa, omega[1234:], a_known[1234:], p)
    np.testing.assert_array_equal(np.concatenate([wa, wb]), w1)
    np.testing.assert_array_equal(np.concatenate([fa, fb]), f1)
    np.testing.assert_array_equal(sb, s1)
    s2, w2, f2 = stsmo_run.py_func(s0, omega, a_known, p)
    np.testing.assert_allclose(w2, w1, rtol=0, atol=1e-12)
    np.testing.assert_allclose(f2, f1, rtol=0, atol=1e-12)
    obs = SuperTwistingObserver(STSMOParams(k1=30.0, k2=400.0, T_s=T_s), 0.1, -0.5)
    steps = np.array([obs.step(omega[i], a_known[i]) for i in range(omega.size)])
    np.testing.assert_array_equal(steps[:, 1], f1)


def test_bad_gain():
    with pytest.raises(ParameterError, match="k2"):
        STSMOParams(k1=1.0, k2=-1.0, T_s=1e-3)
