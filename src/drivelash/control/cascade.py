"""Discrete P position / PI velocity cascade with velocity feed-forward (spec 01 §1, spec 02 §2).

The one cascade controller of drivelash: the simulation engine (:mod:`drivelash.sim.engine`)
and the rack-and-pinion bench (:mod:`drivelash.sim.rack_axis`) both call the kernels below.
At each control instant k (period T_s, torque held by a zero-order hold):

    ω_cmd = (K_v (x_r − x) + k_ff v_r − v_c) / r        velocity command [rad/s]
    e_ω   = ω_cmd − ω_m                                  velocity error [rad/s]
    u_un  = K_p e_ω + x_i                                unlimited torque [N·m]
    u     = clip(u_un, −T_max, T_max)                     applied torque [N·m]
    x_i  ← x_i + (T_s/T_n) [K_p e_ω + (u − u_un)]         integrator with anti-windup

The position loop closes on the position x that the drive uses for it, in that
measuring system's unit: the motor encoder (x = θ_m [rad], r = 1) or a load-side scale
(rack bench: x = x_T [m], r = d_p/(2 i) [m/rad] turns the table velocity into motor
velocity). v_c is a correction velocity subtracted from the command (TE compensation;
0 otherwise). With r = 1 and v_c = 0 the arithmetic is exactly K_v (θ_r − θ_m) + k_ff ω_r.

**Anti-windup: back-calculation with tracking time constant T_n** (tracking gain 1/K_p,
motulator's PI form). Without limitation u = u_un and this is the plain PI; while limited,
x_i ← x_i + (T_s/T_n)(u − x_i + …), i.e. the integrator relaxes towards the applied torque
with time constant T_n and never exceeds the torque limit in magnitude. The electrical
loop is taken as ideal (u = commanded torque) and there is no computational delay: the
torque computed from the samples at t_k is applied over [t_k, t_k + T_s).

The split :meth:`CascadeController.compute_output` / :meth:`CascadeController.update`
follows motulator: ``update(T_s, u_realized)`` receives the torque that was actually
realised. The kernels :func:`cascade_output` / :func:`cascade_update` carry the same
arithmetic with explicit state (x_i in, x_i out) for compiled simulation loops.
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


@njit(cache=True, nogil=True)
def cascade_output(x_i, x_ref, v_ref, x_meas, omega_m, v_corr, r, c):
    """Controller output at one instant (no state change).

    Parameters
    ----------
    x_i : float
        Integrator state [N·m].
    x_ref, v_ref : float
        Position reference and its velocity (feed-forward), in the position loop's
        unit [rad, rad/s] or [m, m/s].
    x_meas : float
        Measured position of the position loop, same unit.
    omega_m : float
        Measured motor velocity [rad/s].
    v_corr : float
        Correction velocity subtracted from the velocity command, position-loop unit
        per second (0: none).
    r : float
        Position-loop unit per motor radian (1 when the loop closes on the motor encoder).
    c : numpy.ndarray
        Gains, layout :data:`CTRL_FIELDS`.

    Returns
    -------
    tuple of float
        (u [N·m] limited, u_unlimited [N·m], e_ω [rad/s], ω_cmd [rad/s]).
    """
    omega_cmd = (c[C_K_V] * (x_ref - x_meas) + c[C_K_FF] * v_ref - v_corr) / r
    e_w = omega_cmd - omega_m
    u_un = c[C_K_P] * e_w + x_i
    lim = c[C_LIMIT]
    u = u_un
    if u > lim:
        u = lim
    elif u < -lim:
        u = -lim
    return u, u_un, e_w, omega_cmd


@njit(cache=True, nogil=True)
def cascade_update(x_i, e_w, u_realized, u_un, T_s, c):
    """Integrator update with back-calculation anti-windup (tracking time constant T_n).

    Parameters
    ----------
    x_i : float
        Integrator state [N·m].
    e_w, u_un : float
        Velocity error [rad/s] and unlimited torque [N·m] from :func:`cascade_output`.
    u_realized : float
        Torque actually applied over the period [N·m].
    T_s : float
        Period the torque was held [s].
    c : numpy.ndarray
        Gains, layout :data:`CTRL_FIELDS`.

    Returns
    -------
    float
        The new integrator state [N·m].
    """
    return x_i + T_s / c[C_T_N] * (c[C_K_P] * e_w + (u_realized - u_un))


@dataclass
class CascadeController:
    """P position + PI velocity cascade (motulator-style ``compute_output`` / ``update``).

    Parameters
    ----------
    gains : CascadeGains
        Loop gains, torque limit, feed-forward and control period.
    r : float
        Unit of the position loop per motor radian: 1 when it closes on the motor
        encoder [rad/rad], d_p/(2 i) [m/rad] on a rack drive with a linear scale.
    x_i : float
        Initial integrator state [N·m].

    Examples
    --------
    >>> from drivelash.sim.scenarios import get_scenario
    >>> gains = get_scenario("bench-0C").gains
    >>> ctrl = CascadeController(gains)
    >>> u = ctrl.compute_output(0.1, 0.0, 0.0, 0.0)   # 0.1 rad behind, at rest: K_p K_v 0.1 [N·m]
    >>> round(u, 4)
    0.4155
    >>> ctrl.update(gains.T_s, u)   # the torque that was actually applied
    """

    gains: CascadeGains
    r: float = 1.0
    x_i: float = 0.0

    def __post_init__(self) -> None:
        self._c = gains_array(self.gains)
        self._u_un = 0.0
        self._e_w = 0.0

    def compute_output(
        self, x_ref: float, v_ref: float, x_meas: float, omega_m: float, v_corr: float = 0.0
    ) -> float:
        """Limited torque command u [N·m].

        Parameters
        ----------
        x_ref, v_ref : float
            Position reference [rad or m] and feed-forward velocity [rad/s or m/s].
        x_meas : float
            Measured position of the position loop [rad or m].
        omega_m : float
            Measured motor velocity [rad/s].
        v_corr : float
            Correction velocity subtracted from the command [rad/s or m/s].
        """
        u, self._u_un, self._e_w, _ = cascade_output(
            self.x_i, x_ref, v_ref, x_meas, omega_m, v_corr, self.r, self._c
        )
        return float(u)

    def update(self, T_s: float, u_realized: float) -> None:
        """Advance the integrator by one period.

        Parameters
        ----------
        T_s : float
            Period over which ``u_realized`` was applied [s].
        u_realized : float
            Torque actually applied [N·m] (the limited output, or less if a further
            limit acted).
        """
        self.x_i = float(cascade_update(self.x_i, self._e_w, u_realized, self._u_un, T_s, self._c))
