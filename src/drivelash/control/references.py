"""Reference trajectories sampled at the control instants.

Every generator returns a :class:`Reference`: position reference θ_r [rad] and its
velocity ω_r [rad/s] (used as velocity feed-forward), both on the time grid
``t = k·T_s``. Closed-form derivatives are used where they exist.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drivelash.errors import ParameterError


@dataclass(frozen=True)
class Reference:
    """A sampled reference.

    Parameters
    ----------
    t : numpy.ndarray
        Sample instants [s].
    theta_ref : numpy.ndarray
        Position reference θ_r [rad].
    omega_ref : numpy.ndarray
        Velocity reference / feed-forward ω_r [rad/s].
    """

    t: np.ndarray
    theta_ref: np.ndarray
    omega_ref: np.ndarray


def time_grid(duration: float, T_s: float) -> np.ndarray:
    """``k·T_s`` for k = 0 … round(duration/T_s) − 1 [s]."""
    if not (duration > 0 and math.isfinite(duration)):
        raise ParameterError("reference", "duration", f"must be > 0, got {duration!r}")
    if not T_s > 0:
        raise ParameterError("reference", "T_s", f"must be > 0, got {T_s!r}")
    n = int(round(duration / T_s))
    return np.arange(max(n, 1), dtype=np.float64) * T_s


def position_sine(
    duration: float, T_s: float, amplitude: float = 1.0, frequency: float = 0.5, offset: float = 0.0
) -> Reference:
    """θ_r = offset + Θ0 sin(2π f t), ω_r = 2π f Θ0 cos(2π f t) (spec 01 §1, test bench).

    Parameters
    ----------
    duration : float
        Length [s].
    T_s : float
        Sample period [s].
    amplitude : float
        Θ0 [rad].
    frequency : float
        f_r [Hz].
    offset : float
        Constant offset [rad].
    """
    t = time_grid(duration, T_s)
    w = 2.0 * math.pi * frequency
    return Reference(t, offset + amplitude * np.sin(w * t), amplitude * w * np.cos(w * t))


def velocity_sine(duration: float, T_s: float, amplitude: float, frequency: float) -> Reference:
    """ω_r = Ω0 sin(2π f t) and its integral θ_r = Ω0/(2π f) (1 − cos 2π f t).

    The paper's simulation study uses Ω0 = 4π rad/s, f = 2 Hz (ω_r = 4π sin 4πt).

    Parameters
    ----------
    duration : float
        Length [s].
    T_s : float
        Sample period [s].
    amplitude : float
        Ω0 [rad/s].
    frequency : float
        f [Hz].
    """
    t = time_grid(duration, T_s)
    w = 2.0 * math.pi * frequency
    return Reference(t, amplitude / w * (1.0 - np.cos(w * t)), amplitude * np.sin(w * t))


def constant_velocity_passes(
    duration: float,
    T_s: float,
    velocity: float,
    stroke: float,
    acceleration: float,
    dwell: float = 0.0,
) -> Reference:
    """Back-and-forth passes at constant velocity between 0 and ``stroke`` with reversals.

    Each pass accelerates at ``acceleration`` to ``velocity``, cruises, decelerates to
    rest at the end of the stroke, dwells ``dwell`` seconds and returns (trapezoidal
    velocity profile), repeated until ``duration``.

    Parameters
    ----------
    duration, T_s : float
        Length and sample period [s].
    velocity : float
        Cruise velocity [rad/s], > 0.
    stroke : float
        Travel per pass [rad], > 0.
    acceleration : float
        Magnitude of the acceleration [rad/s²], > 0.
    dwell : float
        Standstill at each reversal [s], >= 0.

    Raises
    ------
    ParameterError
        ``velocity``, ``stroke`` or ``acceleration`` not > 0, or ``dwell`` < 0.
    """
    for name, v in (("velocity", velocity), ("stroke", stroke), ("acceleration", acceleration)):
        if not v > 0:
            raise ParameterError("reference", name, f"must be > 0, got {v!r}")
    if not dwell >= 0:
        raise ParameterError("reference", "dwell", f"must be >= 0, got {dwell!r}")
    t = time_grid(duration, T_s)
    t_a = velocity / acceleration
    if acceleration * t_a**2 > stroke:  # triangular profile: peak velocity not reached
        t_a = math.sqrt(stroke / acceleration)
        v_pk = acceleration * t_a
        t_c = 0.0
    else:
        v_pk = velocity
        t_c = (stroke - acceleration * t_a**2) / v_pk
    t_pass = 2 * t_a + t_c
    period = 2 * (t_pass + dwell)
    tau = np.mod(t, period)
    sign = np.where(tau < t_pass + dwell, 1.0, -1.0)
    s = np.where(tau < t_pass + dwell, tau, tau - (t_pass + dwell))  # time within the half-cycle
    pos = np.empty_like(t)
    vel = np.empty_like(t)
    a = acceleration
    m1 = s < t_a
    m2 = (s >= t_a) & (s < t_a + t_c)
    m3 = (s >= t_a + t_c) & (s < t_pass)
    m4 = s >= t_pass
    pos[m1] = 0.5 * a * s[m1] ** 2
    vel[m1] = a * s[m1]
    pos[m2] = 0.5 * a * t_a**2 + v_pk * (s[m2] - t_a)
    vel[m2] = v_pk
    r = t_pass - s[m3]
    pos[m3] = stroke - 0.5 * a * r**2
    vel[m3] = a * r
    pos[m4] = stroke
    vel[m4] = 0.0
    theta = np.where(sign > 0, pos, stroke - pos)
    omega = sign * vel
    return Reference(t, theta, omega)


def sampled(t: np.ndarray, theta_ref: np.ndarray, omega_ref: np.ndarray | None = None) -> Reference:
    """A reference from arbitrary arrays on a constant grid.

    Parameters
    ----------
    t : numpy.ndarray
        Sample instants [s], constant period.
    theta_ref : numpy.ndarray
        Position reference [rad].
    omega_ref : numpy.ndarray, optional
        Velocity reference [rad/s]; default: central differences of ``theta_ref``.

    Raises
    ------
    ParameterError
        ``t`` and ``theta_ref`` not 1-D of equal length ≥ 2, or a non-finite value in them or
        in ``omega_ref``.
    """
    t = np.asarray(t, dtype=np.float64)
    th = np.asarray(theta_ref, dtype=np.float64)
    if t.ndim != 1 or th.shape != t.shape or t.size < 2:
        raise ParameterError("reference", "theta_ref", "t and theta_ref must be 1-D of equal length >= 2")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(th))):
        raise ParameterError("reference", "theta_ref", "must be finite")
    if omega_ref is None:
        om = np.gradient(th, t)
    else:
        om = np.asarray(omega_ref, dtype=np.float64)
        if om.shape != t.shape or not np.all(np.isfinite(om)):
            raise ParameterError("reference", "omega_ref", "must be finite and match t")
    return Reference(t, th, om)
