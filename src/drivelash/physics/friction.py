"""Friction models, eqs (6)–(7) of spec 01.

``T_F(ω) = T_C sgn(ω) + β ω`` (plus an optional Stribeck/static part).

Simulation uses a *regularised* sign, ``tanh(ω / ω_reg)``: the sign function
makes the ODE discontinuous at ω = 0 and a fixed-step integrator would chatter
across zero. With ω_reg much smaller than any velocity of interest the friction
torque equals the Coulomb model except in a band |ω| ≲ 3 ω_reg around standstill,
where it behaves like a steep viscous damper (a "sticking" approximation). The
estimator side uses the exact sign, as the paper does.
"""

from __future__ import annotations

import math

from numba import njit

from drivelash._lazy import lazy_ufuncs


@njit(cache=True)
def friction_inv_scalar(omega, T_C, beta, T_S, inv_omega_s, inv_omega_reg):
    """:func:`friction_scalar` with the reciprocals 1/ω_s and 1/ω_reg [s/rad] (hot loops).

    ``inv_omega_reg = 0`` selects the exact sign function.
    """
    if omega == 0.0:  # at rest: sign, tanh and the viscous term are all zero
        return 0.0
    # Fast paths: tanh(x) rounds to ±1 in float64 for |x| > 19.1 (exact), and for
    # (ω/ω_s)² > 40 the Stribeck term is below 5e-18·(T_S − T_C) (negligible).
    if inv_omega_reg > 0.0:
        x = omega * inv_omega_reg
        if x > 20.0:
            s = 1.0
        elif x < -20.0:
            s = -1.0
        else:
            s = math.tanh(x)
    else:
        s = 1.0 if omega > 0.0 else -1.0
    level = T_C
    if T_S > 0.0:
        r = omega * inv_omega_s
        r2 = r * r
        if r2 < 40.0:
            level = T_C + (T_S - T_C) * math.exp(-r2)
    return level * s + beta * omega


@njit(cache=True)
def friction_scalar(omega, T_C, beta, T_S, omega_s, omega_reg):
    """Friction torque [N·m] at velocity ``omega`` [rad/s].

    Parameters
    ----------
    omega : float
        Velocity [rad/s].
    T_C : float
        Coulomb torque [N·m].
    beta : float
        Viscous coefficient [N·m·s/rad].
    T_S : float
        Static (breakaway) torque [N·m]; 0 for none. Adds the Stribeck term
        (T_S − T_C) exp(−(ω/ω_s)²) to the Coulomb part.
    omega_s : float
        Stribeck velocity [rad/s].
    omega_reg : float
        Regularisation velocity [rad/s]; 0 selects the exact sign function.
    """
    inv_omega_reg = 1.0 / omega_reg if omega_reg > 0.0 else 0.0
    return friction_inv_scalar(omega, T_C, beta, T_S, 1.0 / omega_s, inv_omega_reg)


#: ``friction``: the NumPy ufunc of :func:`friction_scalar`, built on first use
#: (:func:`drivelash._lazy.lazy_ufuncs`).
__getattr__, __dir__ = lazy_ufuncs(__name__, {"friction": (friction_scalar, 6)}, globals())
