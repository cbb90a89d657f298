"""Sampled-data closed-loop simulation engine (numba).

One control period T_s (default 125 µs) of :func:`run_closed_loop`:

1. sample the sensors at t_k (quantisation, noise; :mod:`drivelash.sim.sensors`);
2. cascade controller → torque u_k (limited; :mod:`drivelash.control.cascade`);
3. hold u_k, δ_k, δ1_k constant (zero-order hold) and integrate the plant (1)–(4)
   over [t_k, t_k + T_s) with ``n_sub`` classical RK4 substeps;
4. controller integrator update with the realised torque.

Everything runs inside one ``@njit`` loop with explicit state in/out, so running in
chunks (used for progress reporting) gives exactly the result of one run.

Integration step: with the shaft engaged the two-mass mode of the rig is at
ω = sqrt(K_S (1/J_m + 1/J_l)) ≈ 282 rad/s (load-side antiresonance ≈ 199 rad/s), so
h·ω = 0.018 at h = 62.5 µs — RK4 is accurate to ~(hω)^5/120 per step there. The binding
constraints are (a) the regularised friction near standstill (see
:data:`drivelash.physics.drivetrain.DEFAULT_OMEGA_REG`): h·T_S/(ω_reg J) = 0.17, and (b)
the jump of the deadzone torque by D_S Δω at each contact, which the RK4 step handles
by locating the contact instant (:func:`~drivelash.physics.drivetrain.rk4_event_step_scalar`).
Measured against solve_ivp on 5 s of bench-0A: 1 substep 1.8e-5 rad after 1 s,
2 substeps ≈ 3e-6 rad after 5 s, 4 substeps ≈ 2.5e-7 rad after 1 s. Hence
:data:`DEFAULT_SUBSTEPS` = 2 substeps of 62.5 µs per control period.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numba import njit

from drivelash.control.cascade import C_T_S, cascade_output, cascade_update, gains_array
from drivelash.control.references import Reference
from drivelash.errors import ParameterError
from drivelash.io.trace import Trace
from drivelash.params import BacklashParams, CascadeGains, DrivetrainParams, SensorParams
from drivelash.physics.drivetrain import DEFAULT_OMEGA_REG, plant_params_array, rk4_event_step_scalar
from drivelash.sim.sensors import (
    NOISE_OMEGA_L,
    NOISE_OMEGA_M,
    NOISE_THETA_L,
    NOISE_THETA_M,
    NOISE_TORQUE,
    S_COUNTS_L,
    S_COUNTS_M,
    S_DIFF,
    S_SIG_OM_L,
    S_SIG_OM_M,
    S_SIG_T,
    S_SIG_TH_L,
    S_SIG_TH_M,
    draw_noise,
    needs_noise,
    quantise_scalar,
    sensor_params_array,
)

#: RK4 substeps per control period (see module docstring).
DEFAULT_SUBSTEPS = 2

#: Engine state layout: plant state, controller integrator, previous quantised positions.
STATE_FIELDS = ("omega_m", "theta_m", "omega_l", "theta_l", "x_i", "theta_m_prev", "theta_l_prev", "k")
#: Output columns of the kernel.
OUT_FIELDS = (
    "theta_m",
    "omega_m",
    "theta_l",
    "omega_l",
    "torque_m",
    "u",
    "omega_m_true",
    "theta_m_true",
    "omega_l_true",
    "theta_l_true",
)
N_OUT = len(OUT_FIELDS)
#: Velocities below this magnitude [rad/s] are set to 0 after each period.
_TINY = 1e-150


@njit(cache=True)
def run_closed_loop(
    state, theta_ref, omega_ref, delta, delta1, noise, plant_p, ctrl_p, sens_p, n_sub, fb, out
):
    """Simulate ``len(theta_ref)`` control periods.

    Parameters
    ----------
    state : numpy.ndarray
        Engine state (layout :data:`STATE_FIELDS`); not modified.
    theta_ref, omega_ref : numpy.ndarray
        Position [rad] and velocity feed-forward [rad/s] references per period.
    delta, delta1 : numpy.ndarray
        True deadzone δ and offset δ1 per period [rad] (held over the period).
    noise : numpy.ndarray
        ``(n, 5)`` standard-normal draws (θ_m, θ_l, ω_m, ω_l, torque).
    plant_p, ctrl_p, sens_p : numpy.ndarray
        Parameter arrays (PLANT_FIELDS, CTRL_FIELDS, SENS_FIELDS).
    n_sub : int
        RK4 substeps per period.
    fb : int
        1: the controller uses the measured motor position/velocity; 0: the true ones.
    out : numpy.ndarray
        ``(n, N_OUT)`` output, written in place (layout :data:`OUT_FIELDS`).

    Returns
    -------
    numpy.ndarray
        The engine state after the last period.
    """
    n = theta_ref.shape[0]
    w_m = state[0]
    th_m = state[1]
    w_l = state[2]
    th_l = state[3]
    x_i = state[4]
    thq_m_prev = state[5]
    thq_l_prev = state[6]
    kk = state[7]
    T_s = ctrl_p[C_T_S]
    h = T_s / n_sub
    cm = sens_p[S_COUNTS_M]
    cl = sens_p[S_COUNTS_L]
    diff = sens_p[S_DIFF] > 0.0
    for k in range(n):
        # 1. sensors
        thq_m = quantise_scalar(th_m, cm) + sens_p[S_SIG_TH_M] * noise[k, NOISE_THETA_M]
        thq_l = quantise_scalar(th_l, cl) + sens_p[S_SIG_TH_L] * noise[k, NOISE_THETA_L]
        if diff:
            if kk > 0.0:
                wq_m = (thq_m - thq_m_prev) / T_s
                wq_l = (thq_l - thq_l_prev) / T_s
            else:
                wq_m = 0.0
                wq_l = 0.0
        else:
            wq_m = w_m + sens_p[S_SIG_OM_M] * noise[k, NOISE_OMEGA_M]
            wq_l = w_l + sens_p[S_SIG_OM_L] * noise[k, NOISE_OMEGA_L]
        # 2. controller
        if fb == 1:
            u, u_un, e_w, _ = cascade_output(x_i, theta_ref[k], omega_ref[k], thq_m, wq_m, 0.0, 1.0, ctrl_p)
        else:
            u, u_un, e_w, _ = cascade_output(x_i, theta_ref[k], omega_ref[k], th_m, w_m, 0.0, 1.0, ctrl_p)
        out[k, 0] = thq_m
        out[k, 1] = wq_m
        out[k, 2] = thq_l
        out[k, 3] = wq_l
        out[k, 4] = u + sens_p[S_SIG_T] * noise[k, NOISE_TORQUE]
        out[k, 5] = u
        out[k, 6] = w_m
        out[k, 7] = th_m
        out[k, 8] = w_l
        out[k, 9] = th_l
        # 3. plant over one period with ZOH input
        d = delta[k]
        d1 = delta1[k]
        for _ in range(n_sub):
            w_m, th_m, w_l, th_l = rk4_event_step_scalar(w_m, th_m, w_l, th_l, u, d, d1, plant_p, h)
        # flush velocities that decay towards subnormal numbers (load at rest in the gap:
        # friction damps ω exponentially); subnormal arithmetic is ~100× slower
        if abs(w_m) < _TINY:
            w_m = 0.0
        if abs(w_l) < _TINY:
            w_l = 0.0
        # 4. controller update
        x_i = cascade_update(x_i, e_w, u, u_un, T_s, ctrl_p)
        thq_m_prev = thq_m
        thq_l_prev = thq_l
        kk += 1.0
    new = np.empty(8)
    new[0] = w_m
    new[1] = th_m
    new[2] = w_l
    new[3] = th_l
    new[4] = x_i
    new[5] = thq_m_prev
    new[6] = thq_l_prev
    new[7] = kk
    return new


# --------------------------------------------------------------------------------------
# time-varying deadzone
# --------------------------------------------------------------------------------------
def delta_constant(t: np.ndarray, delta: float) -> np.ndarray:
    """δ(t) = δ [rad] on the grid ``t``.

    Parameters
    ----------
    t : numpy.ndarray
        Sample instants [s].
    delta : float
        Deadzone δ [rad].
    """
    return np.full(np.shape(t), float(delta))


def delta_step(t: np.ndarray, delta0: float, t_step: float, delta_after: float) -> np.ndarray:
    """δ(t) = δ0 for t < t_step, ``delta_after`` from t_step on [rad] (sudden wear / a swap).

    Parameters
    ----------
    t : numpy.ndarray
        Sample instants [s].
    delta0 : float
        δ before the step [rad].
    t_step : float
        Time of the step [s] (a sample within 1 ns of it takes the new value).
    delta_after : float
        δ from ``t_step`` on [rad].
    """
    t = np.asarray(t, dtype=np.float64)
    # tolerance of a nanosecond so that t_step on the grid switches exactly there
    return np.where(t >= t_step - 1e-9, float(delta_after), float(delta0))


def delta_ramp(t: np.ndarray, delta0: float, t0: float, t1: float, delta_end: float) -> np.ndarray:
    """δ(t) ramping linearly from δ0 at t0 to ``delta_end`` at t1, constant outside [rad] (wear).

    Parameters
    ----------
    t : numpy.ndarray
        Sample instants [s].
    delta0 : float
        δ up to ``t0`` [rad].
    t0, t1 : float
        Start and end of the ramp [s], ``t1 > t0``.
    delta_end : float
        δ from ``t1`` on [rad].

    Raises
    ------
    ParameterError
        ``t1`` is not greater than ``t0``.
    """
    if not t1 > t0:
        raise ParameterError("delta_ramp", "t1", f"must be > t0 = {t0}, got {t1!r}")
    t = np.asarray(t, dtype=np.float64)
    frac = np.clip((t - t0) / (t1 - t0), 0.0, 1.0)
    return delta0 + (delta_end - delta0) * frac


# --------------------------------------------------------------------------------------
# Python wrapper
# --------------------------------------------------------------------------------------
ProgressCallback = Callable[[int, int], None]


@dataclass
class SimResult:
    """Raw result of :func:`simulate`.

    Attributes
    ----------
    t : numpy.ndarray
        Sample instants [s].
    out : numpy.ndarray
        ``(n, N_OUT)`` kernel output (layout :data:`OUT_FIELDS`).
    delta, delta1 : numpy.ndarray
        True δ(t), δ1(t) [rad].
    reference : Reference
        The reference used.
    state : numpy.ndarray
        Final engine state (to continue a run).
    meta : dict
        Metadata passed on to :meth:`to_trace`'s :class:`Trace` (over its
        ``encoder_reading = "nearest"``).
    """

    t: np.ndarray
    out: np.ndarray
    delta: np.ndarray
    delta1: np.ndarray
    reference: Reference
    state: np.ndarray
    meta: dict = field(default_factory=dict)

    def column(self, name: str) -> np.ndarray:
        """One output column by name (see :data:`OUT_FIELDS`).

        Parameters
        ----------
        name : str
            A name of :data:`OUT_FIELDS` (e.g. ``"theta_l"`` [rad], ``"torque_m"`` [N·m]).
        """
        return self.out[:, OUT_FIELDS.index(name)]

    def to_trace(self, return_states: bool = False) -> Trace:
        """The measured signals as a :class:`Trace` (+ the true plant states if asked).

        Parameters
        ----------
        return_states : bool
            Also the applied torque ``u`` [N·m] and the noiseless plant states
            ``omega_m_true``, ``theta_m_true``, ``omega_l_true``, ``theta_l_true`` [rad/s, rad].
        """
        cols = {
            "t": self.t,
            "theta_m": self.column("theta_m"),
            "omega_m": self.column("omega_m"),
            "theta_l": self.column("theta_l"),
            "omega_l": self.column("omega_l"),
            "torque_m": self.column("torque_m"),
            "delta_true": self.delta,
            "delta1_true": self.delta1,
            "theta_ref": self.reference.theta_ref,
            "omega_ref": self.reference.omega_ref,
        }
        if return_states:
            for n in ("u", "omega_m_true", "theta_m_true", "omega_l_true", "theta_l_true"):
                cols[n] = self.column(n)
        # the sensor model quantises to the nearest count (mid-tread): the estimator needs no
        # reading-convention margin for these recordings
        return Trace(cols, {"encoder_reading": "nearest"} | dict(self.meta))


def initial_state(theta_m: float = 0.0, theta_l: float = 0.0, omega_m: float = 0.0, omega_l: float = 0.0):
    """Engine state with the given positions [rad] and velocities [rad/s] (at rest by default).

    Parameters
    ----------
    theta_m, theta_l : float
        Motor and load position [rad].
    omega_m, omega_l : float
        Motor and load velocity [rad/s].

    Returns
    -------
    numpy.ndarray
        The engine state, shape (8,) (the controller's states zero), for ``simulate(state0=…)``.
    """
    s = np.zeros(8)
    s[0], s[1], s[2], s[3] = omega_m, theta_m, omega_l, theta_l
    return s


def simulate(
    drivetrain: DrivetrainParams,
    backlash: BacklashParams,
    gains: CascadeGains,
    reference: Reference,
    *,
    sensors: SensorParams | None = None,
    delta: np.ndarray | float | None = None,
    delta1: np.ndarray | float | None = None,
    model: Literal["deadzone", "smooth"] = "deadzone",
    seed: int = 0,
    omega_reg: float = DEFAULT_OMEGA_REG,
    n_sub: int = DEFAULT_SUBSTEPS,
    feedback: Literal["measured", "true"] = "measured",
    state0: np.ndarray | None = None,
    chunk: int = 80_000,
    progress: ProgressCallback | None = None,
) -> SimResult:
    """Closed-loop simulation of the drive train on ``reference``.

    Parameters
    ----------
    drivetrain, backlash : DrivetrainParams, BacklashParams
        True plant. δ and δ1 default to ``backlash.delta`` / ``backlash.delta1``.
    gains : CascadeGains
        Controller; ``gains.T_s`` is the control and sample period [s] and must match
        the reference grid.
    reference : Reference
        θ_r [rad], ω_r [rad/s] on the grid k·T_s.
    sensors : SensorParams, optional
        Sensor model (default: ideal).
    delta, delta1 : array or float, optional
        True δ(t), δ1(t) [rad] per sample (time-varying deadzone: :func:`delta_step`,
        :func:`delta_ramp`).
    model : {"deadzone", "smooth"}
        Plant shaft model: (10) or (12) with ``backlash.alpha``.
    seed : int
        Seed of the sensor noise.
    omega_reg : float
        Friction regularisation velocity [rad/s].
    n_sub : int
        RK4 substeps per period.
    feedback : {"measured", "true"}
        Whether the controller sees the sensor model's motor position/velocity
        (a drive controls on what it measures) or the true ones.
    state0 : numpy.ndarray, optional
        Initial engine state (:func:`initial_state`); default at rest at 0.
    chunk : int
        Periods per kernel call (progress granularity).
    progress : callable, optional
        ``progress(done, total)`` after each chunk.

    Returns
    -------
    SimResult

    Raises
    ------
    ParameterError
        ``n_sub`` not an integer ≥ 1, ``feedback`` unknown, a reference period other than
        ``gains.T_s``, or 0 ≤ δ1(t) ≤ δ(t) violated at a sample.
    """
    sensors = sensors or SensorParams()
    n = reference.t.size
    if not (isinstance(n_sub, int | np.integer) and n_sub >= 1):
        raise ParameterError("simulate", "n_sub", f"must be an integer >= 1, got {n_sub!r}")
    if feedback not in ("measured", "true"):
        raise ParameterError("simulate", "feedback", f"must be 'measured' or 'true', got {feedback!r}")
    if n > 1 and abs((reference.t[1] - reference.t[0]) - gains.T_s) > 1e-9 * gains.T_s + 1e-15:
        raise ParameterError("simulate", "reference", "sample period differs from gains.T_s")
    d = _per_sample(delta if delta is not None else backlash.delta, n, "delta")
    d1 = _per_sample(delta1 if delta1 is not None else backlash.delta1, n, "delta1")
    if np.any(d < 0) or np.any(d1 < 0) or np.any(d1 > d):
        raise ParameterError("simulate", "delta1", "need 0 <= delta1(t) <= delta(t) at every sample")
    plant_p = plant_params_array(drivetrain, backlash, model=model, omega_reg=omega_reg)
    ctrl_p = gains_array(gains)
    sens_p = sensor_params_array(sensors)
    fb = 1 if feedback == "measured" else 0
    state = initial_state() if state0 is None else np.asarray(state0, dtype=np.float64).copy()
    out = np.empty((n, N_OUT))
    rng = np.random.default_rng(seed)
    noisy = needs_noise(sensors)
    th_r = np.ascontiguousarray(reference.theta_ref, dtype=np.float64)
    om_r = np.ascontiguousarray(reference.omega_ref, dtype=np.float64)
    chunk = max(int(chunk), 1)
    for a in range(0, n, chunk):
        b = min(a + chunk, n)
        noise = draw_noise(rng, b - a, noisy)
        state = run_closed_loop(
            state,
            th_r[a:b],
            om_r[a:b],
            d[a:b],
            d1[a:b],
            noise,
            plant_p,
            ctrl_p,
            sens_p,
            int(n_sub),
            fb,
            out[a:b],
        )
        if progress is not None:
            progress(b, n)
    return SimResult(reference.t, out, d, d1, reference, state)


def _per_sample(x: np.ndarray | float, n: int, name: str) -> np.ndarray:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim == 0:
        return np.full(n, float(a))
    if a.shape != (n,):
        raise ParameterError("simulate", name, f"needs {n} samples, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ParameterError("simulate", name, "must be finite")
    return np.ascontiguousarray(a)
