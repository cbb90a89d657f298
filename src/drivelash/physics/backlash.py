"""Backlash (deadzone) models of spec 01: eqs (10)–(12), (45)–(50).

Notation: ``dtheta`` = Δθ = θ_m/N − θ_l [rad], ``domega`` = Δω = ω_m/N − ω_l [rad/s],
``delta`` = δ (total gap) [rad], ``delta1`` = δ1 (offset) [rad], ``alpha`` = α [1/rad].
The shafts are disengaged for −δ1 ≤ Δθ ≤ δ − δ1.

Each model is a scalar ``@njit`` kernel (``*_scalar``, callable from other kernels)
and a NumPy ufunc of the same name that broadcasts over arrays.
"""

from __future__ import annotations

import math

from numba import njit

from drivelash._lazy import lazy_ufuncs


@njit(cache=True, inline="always")
def sgn(x: float) -> float:
    """Sign function with sgn(0) = 0 (the paper's convention), for kernels."""
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return 0.0


@njit(cache=True)
def deadzone_torque_scalar(dtheta, domega, K_S, D_S, delta, delta1):
    """Deadzone shaft torque T_l^DZ, eq (10) [N·m].

    Parameters
    ----------
    dtheta : float
        Δθ = θ_m/N − θ_l [rad].
    domega : float
        Δω = ω_m/N − ω_l [rad/s].
    K_S : float
        Shaft stiffness [N·m/rad].
    D_S : float
        Shaft damping [N·m·s/rad].
    delta : float
        Deadzone (gap) δ [rad].
    delta1 : float
        Offset δ1 [rad]: the shafts are disengaged for −δ1 ≤ Δθ ≤ δ − δ1.

    Returns
    -------
    float
        Shaft torque [N·m] (0 inside the gap).
    """
    if dtheta < -delta1:
        return K_S * (dtheta + delta1) + D_S * domega
    if dtheta > delta - delta1:
        return K_S * (dtheta + delta1 - delta) + D_S * domega
    return 0.0


@njit(cache=True)
def smooth_stiffness_scalar(dtheta, K_S, delta, delta1, alpha):
    """Varying stiffness K_BL(Δθ, δ), eq (11) [N·m/rad]."""
    return (K_S / math.pi) * (
        math.pi + math.atan(alpha * (dtheta - delta + delta1)) - math.atan(alpha * (dtheta + delta1))
    )


@njit(cache=True)
def smooth_torque_scalar(dtheta, domega, K_S, D_S, delta, delta1, alpha):
    """Smooth shaft torque T_l(x, δ), eq (12) [N·m].

    Parameters
    ----------
    dtheta : float
        Δθ = θ_m/N − θ_l [rad].
    domega : float
        Δω = ω_m/N − ω_l [rad/s].
    K_S : float
        Shaft stiffness [N·m/rad].
    D_S : float
        Shaft damping [N·m·s/rad].
    delta : float
        Deadzone (gap) δ [rad].
    delta1 : float
        Offset δ1 [rad].
    alpha : float
        Smoothness α of the varying stiffness (11) [1/rad]; α → ∞ gives eq (10).

    Returns
    -------
    float
        Shaft torque [N·m].
    """
    arg = dtheta + delta1 - 0.5 * delta * (1.0 + sgn(dtheta)) + (D_S / K_S) * domega
    return arg * smooth_stiffness_scalar(dtheta, K_S, delta, delta1, alpha)


@njit(cache=True)
def chi1_scalar(dtheta, delta, delta1, alpha):
    """χ1(x, δ), eq (46) [-]."""
    return (
        0.5
        * (1.0 + sgn(dtheta))
        * (math.pi + math.atan(alpha * (dtheta - delta + delta1)) - math.atan(alpha * (dtheta + delta1)))
    )


@njit(cache=True)
def chi2_scalar(dtheta, domega, K_S, D_S, delta, delta1, alpha):
    """χ2(x, δ), eq (47) [-]."""
    arg = dtheta + delta1 - 0.5 * delta * (1.0 + sgn(dtheta)) + (D_S / K_S) * domega
    z = alpha * (dtheta + delta1 - delta)
    return arg * alpha / (1.0 + z * z)


@njit(cache=True)
def dtorque_ddelta_scalar(dtheta, domega, K_S, D_S, delta, delta1, alpha):
    """Sensitivity ∂T_l/∂δ, eq (50) [N·m/rad]."""
    return -(K_S / math.pi) * (
        chi1_scalar(dtheta, delta, delta1, alpha)
        + chi2_scalar(dtheta, domega, K_S, D_S, delta, delta1, alpha)
    )


@njit(cache=True)
def excitation_scalar(dtheta, domega, K_S, D_S, Lambda, delta1, alpha):
    """Excitation measure σ(x) = (χ1(x, Λ) + χ2(x, Λ))² / π², eq (45) [-]."""
    s = chi1_scalar(dtheta, Lambda, delta1, alpha) + chi2_scalar(
        dtheta, domega, K_S, D_S, Lambda, delta1, alpha
    )
    return s * s / (math.pi * math.pi)


#: NumPy ufuncs of the scalar kernels above (same arguments, float64), built on first use
#: (:func:`drivelash._lazy.lazy_ufuncs`): ``deadzone_torque``, ``smooth_stiffness``,
#: ``smooth_torque``, ``chi1``, ``chi2``, ``dtorque_ddelta``, ``excitation``.
_UFUNCS = {
    "deadzone_torque": (deadzone_torque_scalar, 6),
    "smooth_stiffness": (smooth_stiffness_scalar, 5),
    "smooth_torque": (smooth_torque_scalar, 7),
    "chi1": (chi1_scalar, 4),
    "chi2": (chi2_scalar, 7),
    "dtorque_ddelta": (dtorque_ddelta_scalar, 7),
    "excitation": (excitation_scalar, 7),
}
__getattr__, __dir__ = lazy_ufuncs(__name__, _UFUNCS, globals())
