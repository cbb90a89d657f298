"""Discrete P position / PI velocity cascade with velocity feed-forward (spec 01 §1).

At each control instant k (period T_s, torque held by a zero-order hold):

    ω_cmd = K_v (θ_r − θ_m) + k_ff ω_r                  velocity command [rad/s]
    e_ω   = ω_cmd − ω_m                                  velocity error [rad/s]
    u_un  = K_p e_ω + x_i                                unlimited torque [N·m]
    u     = clip(u_un, −T_max, T_max)                     applied torque [N·m]
    x_i  ← x_i + (K_p/T_n) T_s [e_ω + (u − u_un)/K_p]   integrator with anti-windup

The anti-windup is back-calculation with tracking gain 1/K_p (motulator's PI form,
tracking time constant T_n): without limitation u = u_un and this is the plain PI;
while limited, x_i ← x_i + (T_s/T_n)(u − x_i), i.e. the integrator relaxes towards the
applied torque and can never exceed the torque limit in magnitude. The electrical loop is taken as ideal
(u = commanded torque) and there is no computational delay: the torque computed from
the samples at t_k is applied over [t_k, t_k + T_s).

The split :meth:`CascadeController.compute_output` / :meth:`CascadeController.update`
follows motulator: ``update`` receives the torque that was actually realised.
The same arithmetic is available as scalar ``@njit`` kernels for the simulation engine.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from drivelash.params import CascadeGains, DrivetrainParams

#: Layout of the controller parameter array used by the kernels.
CTRL_FIELDS: tuple[str, ...] = ("K_v", "K_p", "T_n", "torque_limit", "k_ff", "T_s")
C_K_V, C_K_P, C_T_N, C_LIMIT, C_K_FF, C_T_S = range(6)


def gains_array(gains: CascadeGains) -> np.ndarray:
    """Pack :class:`CascadeGains` for the kernels (layout :data:`CTRL_FIELDS`)."""
    return np.array([getattr(gains, n) for n in CTRL_FIELDS], dtype=np.float64)


def gains_from_bandwidth(
    drivetrain: DrivetrainParams,
    omega_cv: float,
    *,
    omega_cp: float | None = None,
    integral_ratio: float = 4.0,
    torque_limit: float = 13.0,
    k_ff: float = 1.0,
    T_s: float = 125e-6,
) -> CascadeGains:
    """Cascade gains from loop bandwidths.

    The velocity loop is tuned on the *engaged* (loaded) inertia
    J = J_m + J_l/N²: K_p = ω_cv J gives crossover ω_cv with the load attached and
    ω_cv (J/J_m) while the coupling is in its gap. The PI zero sits a factor
    ``integral_ratio`` below: T_n = integral_ratio / ω_cv. The position loop
    K_v = ω_cp defaults to ω_cv / 4.

    Parameters
    ----------
    drivetrain : DrivetrainParams
        Plant (J_m, J_l [kg·m²], N).
    omega_cv : float
        Velocity-loop crossover with the load engaged [rad/s].
    omega_cp : float, optional
        Position-loop crossover [rad/s]; default ``omega_cv / 4``.
    integral_ratio : float
        ω_cv · T_n [-].
    torque_limit : float
        Torque limit [N·m].
    k_ff : float
        Velocity feed-forward gain [-].
    T_s : float
        Control period [s].

    Returns
    -------
    CascadeGains
    """
    J = drivetrain.J_m + drivetrain.J_l / drivetrain.N**2
    if omega_cp is None:
        omega_cp = omega_cv / 4.0
    return CascadeGains(
        K_v=float(omega_cp),
        K_p=float(omega_cv * J),
        T_n=float(integral_ratio / omega_cv) if omega_cv > 0 else float("nan"),
        torque_limit=torque_limit,
        k_ff=k_ff,
        T_s=T_s,
    )


@njit(cache=True)
def cascade_output_scalar(x_i, theta_ref, omega_ref, theta_m, omega_m, c):
    """Controller output at one instant.

    Parameters
    ----------
    x_i : float
        Integrator state [N·m].
    theta_ref, omega_ref : float
        Position reference [rad] and its velocity (feed-forward) [rad/s].
    theta_m, omega_m : float
        Measured motor position [rad] and velocity [rad/s].
    c : numpy.ndarray
        Gains, layout :data:`CTRL_FIELDS`.

    Returns
    -------
    tuple of float
        (u [N·m] limited, u_unlimited [N·m], e_ω [rad/s]).
    """
    omega_cmd = c[C_K_V] * (theta_ref - theta_m) + c[C_K_FF] * omega_ref
    e_w = omega_cmd - omega_m
    u_un = c[C_K_P] * e_w + x_i
    lim = c[C_LIMIT]
    u = u_un
    if u > lim:
        u = lim
    elif u < -lim:
        u = -lim
    return u, u_un, e_w


@njit(cache=True)
def cascade_update_scalar(x_i, e_w, u_realized, u_un, c):
    """Integrator update with back-calculation anti-windup; returns the new x_i [N·m]."""
    return x_i + c[C_T_S] / c[C_T_N] * (c[C_K_P] * e_w + (u_realized - u_un))


@dataclass
class CascadeController:
    """P position + PI velocity cascade (motulator-style ``compute_output`` / ``update``).

    Parameters
    ----------
    gains : CascadeGains
        Loop gains, torque limit, feed-forward and control period.
    x_i : float
        Initial integrator state [N·m].

    Examples
    --------
    >>> u = ctrl.compute_output(theta_ref, omega_ref, theta_m, omega_m)   # doctest: +SKIP
    >>> ctrl.update(u)                                                      # doctest: +SKIP
    """

    gains: CascadeGains
    x_i: float = 0.0

    def __post_init__(self) -> None:
        self._c = gains_array(self.gains)
        self._u_un = 0.0
        self._e_w = 0.0

    def compute_output(self, theta_ref: float, omega_ref: float, theta_m: float, omega_m: float) -> float:
        """Limited torque command u [N·m] from references [rad, rad/s] and measurements [rad, rad/s]."""
        u, self._u_un, self._e_w = cascade_output_scalar(
            self.x_i, theta_ref, omega_ref, theta_m, omega_m, self._c
        )
        return float(u)

    def update(self, u_realized: float) -> None:
        """Advance the integrator by one period given the torque actually applied [N·m]."""
        self.x_i = float(cascade_update_scalar(self.x_i, self._e_w, u_realized, self._u_un, self._c))
