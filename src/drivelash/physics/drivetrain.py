"""Two-mass drive train with backlash, eqs (1)–(4) of spec 01.

State x = [ω_m, θ_m, ω_l, θ_l] (motor / load velocity [rad/s] and position [rad]):

    J_m ω̇_m = u − T_F,m(ω_m) − T_l(x)/N        θ̇_m = ω_m
    J_l ω̇_l = T_l(x) − T_F,l(ω_l)              θ̇_l = ω_l

with Δθ = θ_m/N − θ_l, Δω = ω_m/N − ω_l and the shaft torque T_l either the
deadzone model (10) or the smooth varying-stiffness model (12).

The kernels take the plant parameters as one float64 array (layout :data:`PLANT_FIELDS`,
built by :func:`plant_params_array`) and return plain tuples, so that an RK4 step
allocates nothing. :func:`rhs` is the array form used by ``scipy.integrate.solve_ivp``
in the cross-checks.

Friction (6)–(7) uses :func:`drivelash.physics.friction.friction_scalar` with the
regularised sign ``tanh(ω/ω_reg)``. The choice of ω_reg and of the integration step
is a stability question for explicit RK4: near standstill the friction acts like a
viscous damper of coefficient T_S/ω_reg, i.e. an eigenvalue λ = T_S/(ω_reg J); RK4
is stable for h·|λ| < 2.78. See :data:`DEFAULT_OMEGA_REG` and
:data:`drivelash.sim.engine.DEFAULT_SUBSTEPS`.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numba import njit

from drivelash.errors import ParameterError
from drivelash.params import BacklashParams, DrivetrainParams
from drivelash.physics.backlash import deadzone_torque_scalar, smooth_torque_scalar
from drivelash.physics.friction import friction_inv_scalar, friction_scalar

#: Layout of the plant parameter array used by the kernels.
PLANT_FIELDS: tuple[str, ...] = (
    "J_m",
    "J_l",
    "N",
    "K_S",
    "D_S",
    "T_Cm",
    "T_Cl",
    "beta_m",
    "beta_l",
    "T_Sm",
    "T_Sl",
    "omega_s",
    "omega_reg",
    "alpha",
    "model",
    "inv_J_m",
    "inv_J_l",
    "inv_N",
    "inv_omega_s",
    "inv_omega_reg",
)
P_J_M, P_J_L, P_N, P_K_S, P_D_S, P_T_CM, P_T_CL, P_BETA_M, P_BETA_L = range(9)
P_T_SM, P_T_SL, P_OMEGA_S, P_OMEGA_REG, P_ALPHA, P_MODEL = range(9, 15)
# reciprocals precomputed for the engine's hot loop (multiplication instead of division)
P_INV_J_M, P_INV_J_L, P_INV_N, P_INV_OMEGA_S, P_INV_OMEGA_REG = range(15, 20)

#: Shaft model codes in the parameter array.
MODEL_DEADZONE = 0.0
MODEL_SMOOTH = 1.0

#: Regularisation velocity of the friction sign [rad/s]. 20 mrad/s is below 1 % of the
#: reference velocities (π … 4π rad/s peak) and below the velocity noise of the rig
#: (σ = 31.6 mrad/s); the "sticking damper" T_S/ω_reg = 2.2 N·m·s/rad (T_S = 0.044 N·m)
#: gives λ = 2.6e3 1/s with J = 8.31e-4 kg·m², h·λ = 0.17 at the 62.5 µs RK4 substep —
#: stable (< 2.78) *and* resolved: the engine then agrees with solve_ivp to ~3e-6 rad over
#: 5 s of bench-0A, whereas 5 mrad/s gave 4e-5 rad after 1 s (h·λ = 0.66, the tanh
#: transition at each reversal lasts only ~1e-4 s and is not resolved).
DEFAULT_OMEGA_REG = 2e-2


def plant_params_array(
    drivetrain: DrivetrainParams,
    backlash: BacklashParams,
    *,
    model: Literal["deadzone", "smooth"] = "deadzone",
    omega_reg: float = DEFAULT_OMEGA_REG,
) -> np.ndarray:
    """Pack plant parameters for the kernels (layout :data:`PLANT_FIELDS`).

    Parameters
    ----------
    drivetrain : DrivetrainParams
        Inertias [kg·m²], gear ratio, shaft stiffness [N·m/rad] and damping
        [N·m·s/rad], friction [N·m], [N·m·s/rad].
    backlash : BacklashParams
        Only ``alpha`` [1/rad] is used here (δ and δ1 are time-varying kernel inputs).
    model : {"deadzone", "smooth"}
        Shaft torque model: (10) or (12).
    omega_reg : float
        Friction regularisation velocity [rad/s]; 0 = exact sign (not for RK4).

    Returns
    -------
    numpy.ndarray
        float64 array of length ``len(PLANT_FIELDS)``.

    Raises
    ------
    ParameterError
        ``model`` other than ``"deadzone"``/``"smooth"``, or ``omega_reg`` not finite ≥ 0.
    """
    if model not in ("deadzone", "smooth"):
        raise ParameterError("plant", "model", f"must be 'deadzone' or 'smooth', got {model!r}")
    if not omega_reg >= 0.0 or not np.isfinite(omega_reg):
        raise ParameterError("plant", "omega_reg", f"must be finite and >= 0, got {omega_reg!r}")
    d = drivetrain
    return np.array(
        [
            d.J_m,
            d.J_l,
            d.N,
            d.K_S,
            d.D_S,
            d.T_Cm,
            d.T_Cl,
            d.beta_m,
            d.beta_l,
            d.T_Sm,
            d.T_Sl,
            d.omega_s,
            omega_reg,
            backlash.alpha,
            MODEL_DEADZONE if model == "deadzone" else MODEL_SMOOTH,
            1.0 / d.J_m,
            1.0 / d.J_l,
            1.0 / d.N,
            1.0 / d.omega_s,
            1.0 / omega_reg if omega_reg > 0 else 0.0,
        ],
        dtype=np.float64,
    )


@njit(cache=True)
def shaft_torque_scalar(dtheta, domega, p, delta, delta1):
    """Shaft torque T_l [N·m] by the model selected in ``p`` (deadzone (10) or smooth (12))."""
    if p[P_MODEL] == MODEL_DEADZONE:
        return deadzone_torque_scalar(dtheta, domega, p[P_K_S], p[P_D_S], delta, delta1)
    return smooth_torque_scalar(dtheta, domega, p[P_K_S], p[P_D_S], delta, delta1, p[P_ALPHA])


@njit(cache=True)
def rhs_scalar(omega_m, theta_m, omega_l, theta_l, u, delta, delta1, p):
    """Right-hand side of (1)–(4).

    Parameters
    ----------
    omega_m, theta_m, omega_l, theta_l : float
        State [rad/s, rad, rad/s, rad].
    u : float
        Motor torque [N·m].
    delta, delta1 : float
        Deadzone δ and offset δ1 [rad].
    p : numpy.ndarray
        Plant parameters, layout :data:`PLANT_FIELDS`.

    Returns
    -------
    tuple of float
        (dω_m/dt [rad/s²], dθ_m/dt [rad/s], dω_l/dt [rad/s²], dθ_l/dt [rad/s]).
    """
    N = p[P_N]
    dtheta = theta_m / N - theta_l
    domega = omega_m / N - omega_l
    T_l = shaft_torque_scalar(dtheta, domega, p, delta, delta1)
    T_Fm = friction_scalar(omega_m, p[P_T_CM], p[P_BETA_M], p[P_T_SM], p[P_OMEGA_S], p[P_OMEGA_REG])
    T_Fl = friction_scalar(omega_l, p[P_T_CL], p[P_BETA_L], p[P_T_SL], p[P_OMEGA_S], p[P_OMEGA_REG])
    domega_m = (u - T_Fm - T_l / N) / p[P_J_M]
    domega_l = (T_l - T_Fl) / p[P_J_L]
    return domega_m, omega_m, domega_l, omega_l


@njit(cache=True)
def rk4_step_scalar(omega_m, theta_m, omega_l, theta_l, u, delta, delta1, p, h):
    """One classical RK4 step of length ``h`` [s] with constant ``u``, δ, δ1 (no allocation)."""
    a1, b1, c1, d1 = rhs_scalar(omega_m, theta_m, omega_l, theta_l, u, delta, delta1, p)
    hh = 0.5 * h
    a2, b2, c2, d2 = rhs_scalar(
        omega_m + hh * a1, theta_m + hh * b1, omega_l + hh * c1, theta_l + hh * d1, u, delta, delta1, p
    )
    a3, b3, c3, d3 = rhs_scalar(
        omega_m + hh * a2, theta_m + hh * b2, omega_l + hh * c2, theta_l + hh * d2, u, delta, delta1, p
    )
    a4, b4, c4, d4 = rhs_scalar(
        omega_m + h * a3, theta_m + h * b3, omega_l + h * c3, theta_l + h * d3, u, delta, delta1, p
    )
    s = h / 6.0
    return (
        omega_m + s * (a1 + 2.0 * a2 + 2.0 * a3 + a4),
        theta_m + s * (b1 + 2.0 * b2 + 2.0 * b3 + b4),
        omega_l + s * (c1 + 2.0 * c2 + 2.0 * c3 + c4),
        theta_l + s * (d1 + 2.0 * d2 + 2.0 * d3 + d4),
    )


@njit(cache=True)
def contact_mode_scalar(dtheta, delta, delta1):
    """Contact state of the deadzone model: −1 lower flank (Δθ < −δ1), +1 upper (Δθ > δ − δ1), 0 free."""
    if dtheta < -delta1:
        return -1
    if dtheta > delta - delta1:
        return 1
    return 0


@njit(cache=True)
def rhs_mode_scalar(omega_m, theta_m, omega_l, theta_l, u, delta, delta1, p, mode):
    """:func:`rhs_scalar` with the deadzone branch fixed to ``mode`` (−1, 0, +1).

    The branch formula of (10) is extended beyond its region, so that an RK4 step
    which straddles a contact point integrates one smooth vector field; the engine
    locates the contact instant and switches the mode there (event handling). For the
    smooth model (12) ``mode`` is ignored. Same equations as :func:`rhs_scalar`, written
    with precomputed reciprocals for speed (requires ω_reg > 0); the two are
    cross-checked in the tests.
    """
    inv_N = p[P_INV_N]
    dtheta = theta_m * inv_N - theta_l
    domega = omega_m * inv_N - omega_l
    if p[P_MODEL] != MODEL_DEADZONE:
        T_l = smooth_torque_scalar(dtheta, domega, p[P_K_S], p[P_D_S], delta, delta1, p[P_ALPHA])
    elif mode < 0:
        T_l = p[P_K_S] * (dtheta + delta1) + p[P_D_S] * domega
    elif mode > 0:
        T_l = p[P_K_S] * (dtheta + delta1 - delta) + p[P_D_S] * domega
    else:
        T_l = 0.0
    inv_ws = p[P_INV_OMEGA_S]
    inv_wr = p[P_INV_OMEGA_REG]
    T_Fm = friction_inv_scalar(omega_m, p[P_T_CM], p[P_BETA_M], p[P_T_SM], inv_ws, inv_wr)
    T_Fl = friction_inv_scalar(omega_l, p[P_T_CL], p[P_BETA_L], p[P_T_SL], inv_ws, inv_wr)
    return (u - T_Fm - T_l * inv_N) * p[P_INV_J_M], omega_m, (T_l - T_Fl) * p[P_INV_J_L], omega_l


@njit(cache=True)
def rk4_mode_scalar(omega_m, theta_m, omega_l, theta_l, u, delta, delta1, p, h, mode):
    """One RK4 step of length ``h`` [s] on the vector field of contact ``mode``."""
    a1, b1, c1, d1 = rhs_mode_scalar(omega_m, theta_m, omega_l, theta_l, u, delta, delta1, p, mode)
    hh = 0.5 * h
    a2, b2, c2, d2 = rhs_mode_scalar(
        omega_m + hh * a1, theta_m + hh * b1, omega_l + hh * c1, theta_l + hh * d1, u, delta, delta1, p, mode
    )
    a3, b3, c3, d3 = rhs_mode_scalar(
        omega_m + hh * a2, theta_m + hh * b2, omega_l + hh * c2, theta_l + hh * d2, u, delta, delta1, p, mode
    )
    a4, b4, c4, d4 = rhs_mode_scalar(
        omega_m + h * a3, theta_m + h * b3, omega_l + h * c3, theta_l + h * d3, u, delta, delta1, p, mode
    )
    s = h / 6.0
    return (
        omega_m + s * (a1 + 2.0 * a2 + 2.0 * a3 + a4),
        theta_m + s * (b1 + 2.0 * b2 + 2.0 * b3 + b4),
        omega_l + s * (c1 + 2.0 * c2 + 2.0 * c3 + c4),
        theta_l + s * (d1 + 2.0 * d2 + 2.0 * d3 + d4),
    )


@njit(cache=True)
def rk4_event_step_scalar(omega_m, theta_m, omega_l, theta_l, u, delta, delta1, p, h):
    """RK4 step of length ``h`` [s] that locates contact events of the deadzone model.

    The deadzone torque (10) jumps by D_S Δω when a flank is reached, so a plain RK4
    step across the contact loses its order (error ∝ h · D_S Δω / J per contact). Here
    the step is taken on the vector field of the contact mode at its start; if the mode
    at the end differs, the crossing instant s of Δθ through the contact point is found
    by Illinois regula falsi on s ↦ Δθ(RK4(s)) (6 iterations), the step is split at s and
    finished with the new mode. For the smooth model this is a plain RK4 step.
    """
    if p[P_MODEL] != MODEL_DEADZONE:
        return rk4_mode_scalar(omega_m, theta_m, omega_l, theta_l, u, delta, delta1, p, h, 0)
    N = p[P_N]
    mode0 = contact_mode_scalar(theta_m / N - theta_l, delta, delta1)
    a, b, c, d = rk4_mode_scalar(omega_m, theta_m, omega_l, theta_l, u, delta, delta1, p, h, mode0)
    mode1 = contact_mode_scalar(b / N - d, delta, delta1)
    if mode1 == mode0:
        return a, b, c, d
    # contact point crossed: the flank of the mode we leave or enter
    side = mode1 if mode0 == 0 else mode0
    bound = -delta1 if side < 0 else delta - delta1
    s0 = 0.0
    g0 = theta_m / N - theta_l - bound
    s1 = h
    g1 = b / N - d - bound
    side0 = 0
    for _ in range(6):
        if g1 == g0:
            break
        sm = (s0 * g1 - s1 * g0) / (g1 - g0)
        a, b, c, d = rk4_mode_scalar(omega_m, theta_m, omega_l, theta_l, u, delta, delta1, p, sm, mode0)
        gm = b / N - d - bound
        if gm == 0.0:
            s0 = sm
            s1 = sm
            break
        if (gm > 0.0) == (g1 > 0.0):
            s1 = sm
            g1 = gm
            if side0 == 1:
                g0 *= 0.5
            side0 = 1
        else:
            s0 = sm
            g0 = gm
            if side0 == -1:
                g1 *= 0.5
            side0 = -1
    s = 0.5 * (s0 + s1)
    a, b, c, d = rk4_mode_scalar(omega_m, theta_m, omega_l, theta_l, u, delta, delta1, p, s, mode0)
    return rk4_mode_scalar(a, b, c, d, u, delta, delta1, p, h - s, mode1)


@njit(cache=True)
def rhs(x, u, delta, delta1, p):
    """Array form of :func:`rhs_scalar`: ``x`` = [ω_m, θ_m, ω_l, θ_l] → ẋ (new array).

    Parameters
    ----------
    x : numpy.ndarray
        State [ω_m, θ_m, ω_l, θ_l] [rad/s, rad, rad/s, rad].
    u : float
        Motor torque [N·m].
    delta, delta1 : float
        Deadzone δ and offset δ1 [rad].
    p : numpy.ndarray
        Plant parameters, layout :data:`PLANT_FIELDS` (:func:`plant_params_array`).

    Returns
    -------
    numpy.ndarray
        ẋ = [dω_m/dt, dθ_m/dt, dω_l/dt, dθ_l/dt] [rad/s², rad/s, rad/s², rad/s].
    """
    out = np.empty(4)
    a, b, c, d = rhs_scalar(x[0], x[1], x[2], x[3], u, delta, delta1, p)
    out[0] = a
    out[1] = b
    out[2] = c
    out[3] = d
    return out


@njit(cache=True)
def rk4_step(x, u, delta, delta1, p, h):
    """Array form of :func:`rk4_step_scalar` (returns a new array).

    Parameters
    ----------
    x : numpy.ndarray
        State [ω_m, θ_m, ω_l, θ_l] [rad/s, rad, rad/s, rad].
    u : float
        Motor torque, constant over the step [N·m].
    delta, delta1 : float
        Deadzone δ and offset δ1 [rad], constant over the step.
    p : numpy.ndarray
        Plant parameters, layout :data:`PLANT_FIELDS` (:func:`plant_params_array`).
    h : float
        Step length [s] (the simulator uses T_s / ``n_sub``).

    Returns
    -------
    numpy.ndarray
        The state after the step, same layout as ``x``.
    """
    out = np.empty(4)
    a, b, c, d = rk4_step_scalar(x[0], x[1], x[2], x[3], u, delta, delta1, p, h)
    out[0] = a
    out[1] = b
    out[2] = c
    out[3] = d
    return out


def linear_state_space(drivetrain: DrivetrainParams) -> tuple[np.ndarray, np.ndarray]:
    """Continuous (A, B) of (1)–(4) for δ = 0 and no Coulomb/static friction.

    State [ω_m, θ_m, ω_l, θ_l], input u [N·m]; used for cross-checks with python-control.

    Parameters
    ----------
    drivetrain : DrivetrainParams
        J_m, J_l [kg·m²], N [-], K_S [N·m/rad], D_S, beta_m, beta_l [N·m·s/rad] (the
        Coulomb and static friction are left out).

    Returns
    -------
    A : numpy.ndarray
        (4, 4) system matrix of ẋ = A x + B u (SI: ẋ in the state's units per second).
    B : numpy.ndarray
        (4, 1) input matrix: 1/J_m [1/(kg·m²)] in the ω_m row, zeros elsewhere.
    """
    d = drivetrain
    N, K, D = d.N, d.K_S, d.D_S
    # T_l = K (θ_m/N − θ_l) + D (ω_m/N − ω_l)
    A = np.array(
        [
            [(-d.beta_m - D / N**2) / d.J_m, -K / N**2 / d.J_m, D / N / d.J_m, K / N / d.J_m],
            [1.0, 0.0, 0.0, 0.0],
            [D / N / d.J_l, K / N / d.J_l, (-D - d.beta_l) / d.J_l, -K / d.J_l],
            [0.0, 0.0, 1.0, 0.0],
        ]
    )
    B = np.array([[1.0 / d.J_m], [0.0], [0.0], [0.0]])
    return A, B
