"""Feed-forward compensation of transmission errors and backlash, spec 02 §5 (eqs 6–7).

The compensator runs once per compensation period t_s,c (5 ms). It keeps a model
estimate ``TE_hat`` of the transmission error TE = x_T − x_M and outputs its rate,
the correction velocity

    v_c = v_c,TE + v_c,BL,
    v_c,TE = (TE(x_d,n+1, T, flank) − TE(x_d,n, T, flank)) / t_s,c            (6)
    v_c,BL = d/dt [ b · s(t / t_ss) ],  s(τ) = 3τ² − 2τ³ on [0, 1]             (7)

with x_d,n the current and x_d,n+1 the look-ahead set position of the planned
trajectory, T the model torque (motor torque minus acceleration torque, held
constant over the cycle), and b the backlash at the current position from the two
direction models, applied after a change of the flank in contact. The flank is
found from the sign of the *mesh torque*: motor torque minus the estimated friction
and acceleration torque of the drive train, with hysteresis — not from the
set-point direction.

Sign convention. With e = x_d − x_T and a velocity loop that tracks its command,
ė = −K_v e + (v_c − dTE/dt) when the command is ``v_ff + K_v e − v_c``; the
compensator therefore *subtracts* v_c (table units, m/s) from the velocity command.
v_c integrates exactly to the change of ``TE_hat``: over a flank change
Σ v_c,BL · t_s,c = b (the discrete form of (7) is the difference of the smooth step
between cycle boundaries).

Outside the table. The table spans the model's valid range (where it was measured,
:func:`~drivelash.te.runtime.table.measured_range`). A set position beyond its grid is
evaluated at the nearest grid edge — the edge value is held, as a SINUMERIK compensation
table holds its first and last value beyond ``_MIN``/``_MAX`` — so v_c,TE is zero there and
nothing is extrapolated; every such cycle is counted (:attr:`Compensator.cycles_outside`,
state ``S_OUTSIDE``) so that a caller can state how much of a motion ran uncompensated.

Feed-forward only: the output depends on the planned trajectory and, through the
error models, on the torque state; no measured position or velocity error feeds
through, so the closed-loop poles are those of the uncompensated cascade (tested).

The table the cycle reads is a :class:`~drivelash.te.runtime.table.TETable`
(:mod:`drivelash.te.runtime.table`); exports for a CNC are in
:mod:`drivelash.te.runtime.export`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from numba import njit

from drivelash.errors import DataError, ParameterError
from drivelash.te.runtime.table import TETable, check_direction, table_te

__all__ = [
    "Compensator",
    "CompensatorParams",
    "X_SLACK",
    "compensate_run",
    "compensation_cycle",
    "init_state",
    "mesh_torque",
    "smooth_step",
    "smooth_step_rate",
]

# Layout of the compensator state vector (float64).
S_FLANK = 0  # flank in contact, +1 or −1
S_T_SINCE = 1  # time since the last flank change at the start of the next cycle [s]
S_B = 2  # signed backlash step b of the last flank change [m]
S_T_LAST = 3  # model torque of the previous cycle [N·m]
S_INIT = 4  # 0 before the first cycle, 1 afterwards
S_TE_HAT = 5  # integral of v_c: the compensator's running TE estimate (offset-free) [m]
S_TSS = 6  # duration of the running backlash step [s]
S_TM1 = 7  # mesh torque of the previous cycle [N·m]
S_TM2 = 8  # mesh torque two cycles back [N·m]
S_OUTSIDE = 9  # cycles whose set positions left the table's grid (its edge value was held) [-]
STATE_SIZE = 10
#: Distance [m] beyond the table's first or last grid position at which a set position counts
#: as outside the table (floating-point slack of the grid's end, far below any encoder step).
X_SLACK = 1e-9

# Layout of the parameter vector of the kernels.
P_T_SC = 0
P_T_SS = 1
P_J_FLANK = 2
P_T_C = 3
P_BETA = 4
P_OMEGA_REG = 5
P_HYST = 6
P_J_MODEL = 7
P_V_MAX = 8
P_RELEASE = 9
P_T_LOCK = 10
P_T_SS_SIGN = 11
P_BL_GAIN = 12
PARAM_SIZE = 13


@dataclass(frozen=True)
class CompensatorParams:
    """Settings of the compensator (spec 02 §5); values and reasons in docs/assumptions.md.

    Parameters
    ----------
    t_sc : float
        Compensation period t_s,c [s] (paper: 5 ms).
    t_ss : float
        Duration of the smooth backlash step t_ss [s] when the flank change is found
        at the start of the gap traverse (release with planned reversal).
    t_ss_sign : float
        Duration of the step when the change is found only from the torque sign, i.e.
        after the impact on the new flank, when the loop has already absorbed most of
        the jump [s] (paper: 35 ms for its single detection rule).
    bl_gain : float
        Share of the modelled backlash b applied by the step [-]; below 1 the motor
        approaches the new flank and the loop makes the last part of the contact
        (a soft landing instead of an impact that makes the table bounce).
    J_flank : float
        Inertia of motor + gearbox + pinion, motor side [kg·m²], whose acceleration
        torque is subtracted from the motor torque for flank detection.
    T_C : float
        Estimated Coulomb friction of the drive train, motor side [N·m].
    beta : float
        Estimated viscous friction of the drive train, motor side [N·m·s/rad].
    omega_reg : float
        Regularisation velocity of the friction sign [rad/s].
    hysteresis : float
        Mesh-torque band [N·m] the estimate must leave before a flank change is
        accepted (noise immunity). The default is the paper's bench;
        :func:`~drivelash.te.protocol.bench.compensator_for` converts it to another
        axis as the same force at the mesh (× r_eff / r_eff,paper).
    J_model : float
        Inertia [kg·m²] whose acceleration torque is removed from the motor torque
        before it enters the error models (the models are trained at constant
        velocity, where motor torque = friction + load).
    v_max : float
        Symmetric limit of |v_c| [m/s] (drive limit).
    release : float
        Mesh torque [N·m] below which (in this and the two previous cycles) the
        contact with the current flank counts as released when the *planned* motion
        (look-ahead) points towards the other flank: the flank change is then taken
        at the start of the gap traverse, not at the impact on the other flank (where
        the torque sign confirms it). 0 disables. The default is the paper's bench,
        converted to another axis like ``hysteresis``.
    t_lock : float
        Time after a flank change during which no further change is accepted [s]:
        the torque spikes of the impact on the new flank must not toggle the flank.

    Raises
    ------
    ParameterError
        A field outside its valid range (one line naming the class and the field).
    """

    t_sc: float = 5e-3
    t_ss: float = 5e-3
    J_flank: float = 0.0
    T_C: float = 0.0
    beta: float = 0.0
    omega_reg: float = 1.0
    hysteresis: float = 0.2
    J_model: float = 0.0
    v_max: float = 0.05
    release: float = 0.6
    t_lock: float = 50e-3
    t_ss_sign: float = 35e-3
    bl_gain: float = 0.95

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if not math.isfinite(v):
                raise ParameterError(type(self).__name__, f.name, f"must be finite, got {v!r}")
        for n in ("t_sc", "t_ss", "t_ss_sign", "omega_reg", "v_max"):
            if not getattr(self, n) > 0:
                raise ParameterError(type(self).__name__, n, f"must be > 0, got {getattr(self, n)!r}")
        for n in ("J_flank", "T_C", "beta", "hysteresis", "J_model", "release", "t_lock", "bl_gain"):
            if not getattr(self, n) >= 0:
                raise ParameterError(type(self).__name__, n, f"must be >= 0, got {getattr(self, n)!r}")

    def as_array(self) -> np.ndarray:
        """Parameters in kernel order (see ``P_*`` constants; field order = kernel order).

        Returns
        -------
        numpy.ndarray
            float64, shape (PARAM_SIZE,): each field in its own unit (s, m/s, N·m, …).
        """
        a = np.array([getattr(self, f.name) for f in fields(self)], dtype=np.float64)
        assert a.size == PARAM_SIZE
        return a


# ---------------------------------------------------------------------------
# smooth step (7)


@njit(cache=True)
def smooth_step(tau: float) -> float:
    """Smooth step s(τ) of eq (7) [-]: 0 for τ ≤ 0, 3τ² − 2τ³ on [0, 1], 1 for τ ≥ 1.

    Parameters
    ----------
    tau : float
        Normalised time since the flank change, t/t_ss [-].

    Returns
    -------
    float
        s(τ) [-] in [0, 1].
    """
    if tau <= 0.0:
        return 0.0
    if tau >= 1.0:
        return 1.0
    return tau * tau * (3.0 - 2.0 * tau)


@njit(cache=True)
def smooth_step_rate(tau: float) -> float:
    """ds/dτ of the smooth step [-]: 6τ(1 − τ) on [0, 1], else 0.

    Parameters
    ----------
    tau : float
        Normalised time since the flank change, t/t_ss [-].

    Returns
    -------
    float
        ds/dτ [-] in [0, 1.5].
    """
    if tau <= 0.0 or tau >= 1.0:
        return 0.0
    return 6.0 * tau * (1.0 - tau)


# ---------------------------------------------------------------------------
# lookup table


# ---------------------------------------------------------------------------
# the compensation cycle


@njit(cache=True)
def mesh_torque(torque_m, omega_m, alpha_m, p):
    """Estimated torque transmitted through the mesh [N·m], motor side.

    Motor torque minus the estimated friction ``T_C tanh(ω/ω_reg) + β ω`` and the
    acceleration torque ``J_flank α`` of the drive train.
    """
    fr = p[P_T_C] * math.tanh(omega_m / p[P_OMEGA_REG]) + p[P_BETA] * omega_m
    return torque_m - fr - p[P_J_FLANK] * alpha_m


@njit(cache=True)
def init_state(flank):
    """Fresh compensator state on flank ``flank`` (±1).

    njit kernel: ``flank`` is not checked here (≥ 0 starts on +1); :class:`Compensator`
    checks it.

    Parameters
    ----------
    flank : float
        Flank in contact at start: +1.0 or −1.0 [-].

    Returns
    -------
    numpy.ndarray
        The state vector, float64, shape (STATE_SIZE,) (see the ``S_*`` constants).
    """
    s = np.zeros(STATE_SIZE)
    s[S_FLANK] = 1.0 if flank >= 0 else -1.0
    s[S_T_SINCE] = 1e9
    s[S_TSS] = 1.0
    s[S_TM1] = 1e9 if flank >= 0 else -1e9  # no release before two cycles of history
    s[S_TM2] = s[S_TM1]
    return s


@njit(cache=True)
def compensation_cycle(state, te, x0, dx, torque0, dtorque, p, x_d_n, x_d_next, torque_m, omega_m, alpha_m):
    """One compensation cycle: update ``state`` in place and return (v_c, v_c,TE, v_c,BL) [m/s].

    Parameters
    ----------
    state : numpy.ndarray
        Compensator state (``init_state``), modified in place.
    te, x0, dx, torque0, dtorque
        The :class:`TETable` arrays.
    p : numpy.ndarray
        :meth:`CompensatorParams.as_array`.
    x_d_n, x_d_next : float
        Current and look-ahead (t + t_s,c) set positions [m]; beyond the table's grid the
        edge value is held and the cycle counted in ``state[S_OUTSIDE]``.
    torque_m : float
        Motor torque, mean over the last cycle [N·m].
    omega_m : float
        Motor velocity [rad/s].
    alpha_m : float
        Motor acceleration [rad/s²].
    """
    t_sc = p[P_T_SC]
    # beyond the table's grid its edge value is held (table_te clamps): counted, never extrapolated
    x_last = x0 + dx * (te.shape[1] - 1)
    if min(x_d_n, x_d_next) < x0 - X_SLACK or max(x_d_n, x_d_next) > x_last + X_SLACK:
        state[S_OUTSIDE] += 1.0
    # flank in contact from the mesh torque: (a) its sign, beyond the hysteresis band, or
    # (b) its release (below `release`) while the planned motion reverses
    tm = mesh_torque(torque_m, omega_m, alpha_m, p)
    flank = state[S_FLANK]
    new_flank = flank
    s_tm = tm * flank
    planned = (x_d_next - x_d_n) * flank
    locked = state[S_T_SINCE] < p[P_T_LOCK]
    # release: low mesh torque for three cycles (15 ms) — a process load that fades only
    # as the set velocity passes zero (and then throws the table across the gap) is excluded
    s_max = max(s_tm, state[S_TM1] * flank, state[S_TM2] * flank)
    released = p[P_RELEASE] > 0.0 and planned < 0.0 and s_max < p[P_RELEASE]
    state[S_TM2] = state[S_TM1]
    state[S_TM1] = tm
    by_sign = s_tm < -p[P_HYST]
    if not locked and (by_sign or released):
        new_flank = -flank
    # model torque: motor torque minus acceleration torque (trained at constant velocity)
    tq = torque_m - p[P_J_MODEL] * alpha_m
    d_new = 0 if new_flank > 0.0 else 1
    if new_flank != flank:
        d_old = 1 - d_new
        t_old = state[S_T_LAST] if state[S_INIT] > 0.0 else tq
        b = p[P_BL_GAIN] * (
            table_te(te, x0, dx, torque0, dtorque, d_new, x_d_n, tq)
            - table_te(te, x0, dx, torque0, dtorque, d_old, x_d_n, t_old)
        )
        # a flank change during a running step: the unfinished part of the previous
        # step is carried over so that the sum of v_c,BL still equals the net jump
        tau = state[S_T_SINCE] / state[S_TSS]
        rest = state[S_B] * (1.0 - smooth_step(tau))
        state[S_B] = b + rest
        state[S_T_SINCE] = 0.0
        state[S_TSS] = p[P_T_SS_SIGN] if by_sign else p[P_T_SS]
        state[S_FLANK] = new_flank
    # (6): rate of the model error along the planned trajectory at constant torque
    v_te = (
        table_te(te, x0, dx, torque0, dtorque, d_new, x_d_next, tq)
        - table_te(te, x0, dx, torque0, dtorque, d_new, x_d_n, tq)
    ) / t_sc
    # (7): exact discrete derivative of b·s(t/t_ss) over this cycle
    t0 = state[S_T_SINCE]
    tss = state[S_TSS]
    v_bl = state[S_B] * (smooth_step((t0 + t_sc) / tss) - smooth_step(t0 / tss)) / t_sc
    v = v_te + v_bl
    vmax = p[P_V_MAX]
    if v > vmax:
        v = vmax
    elif v < -vmax:
        v = -vmax
    state[S_T_SINCE] = t0 + t_sc
    state[S_T_LAST] = tq
    state[S_INIT] = 1.0
    state[S_TE_HAT] += v * t_sc
    return v, v_te, v_bl


@njit(cache=True)
def compensate_run(state, te, x0, dx, torque0, dtorque, p, x_d, torque_m, omega_m, alpha_m):
    """Run the compensator over a sequence of cycles (chunks give the result of one run).

    ``x_d`` holds the set positions at the cycle instants plus one look-ahead value
    (length n + 1); the other inputs have length n. Returns (state, v_c, v_c,TE, v_c,BL).

    Parameters
    ----------
    state : numpy.ndarray
        Compensator state (:func:`init_state`), modified in place.
    te, x0, dx, torque0, dtorque
        The arrays of a :class:`~drivelash.te.runtime.table.TETable`: TE [m] (2, n_x,
        n_torque), first position and step [m], first torque and step per flank [N·m].
    p : numpy.ndarray
        :meth:`CompensatorParams.as_array`.
    x_d : numpy.ndarray
        Set positions [m], n + 1.
    torque_m : numpy.ndarray
        Motor torque [N·m], n.
    omega_m : numpy.ndarray
        Motor speed [rad/s], n.
    alpha_m : numpy.ndarray
        Motor acceleration [rad/s²], n.

    Returns
    -------
    state : numpy.ndarray
        The same array, after the last cycle.
    v_c, v_te, v_bl : numpy.ndarray
        Velocity correction and its TE and backlash parts [m/s], n each.
    """
    n = torque_m.size
    v = np.empty(n)
    vte = np.empty(n)
    vbl = np.empty(n)
    for k in range(n):
        v[k], vte[k], vbl[k] = compensation_cycle(
            state, te, x0, dx, torque0, dtorque, p, x_d[k], x_d[k + 1], torque_m[k], omega_m[k], alpha_m[k]
        )
    return state, v, vte, vbl


class Compensator:
    """Runtime compensator: a :class:`TETable` plus state, one call per t_s,c.

    Parameters
    ----------
    table : TETable
        Sampled error model.
    params : CompensatorParams
        Compensation settings.
    flank : int
        Flank in contact at start: +1 or −1 (else a one-line
        :class:`~drivelash.errors.ParameterError`; 0 and NaN started silently on a flank).
    """

    def __init__(self, table: TETable, params: CompensatorParams, flank: int = 1) -> None:
        self.table = table
        self.params = params
        self._p = params.as_array()
        self.state = init_state(float(check_direction(flank, "Compensator", "flank")))

    def reset(self, flank: int = 1) -> None:
        """Forget the history; start on ``flank``.

        Parameters
        ----------
        flank : int
            Flank in contact at start: +1 or −1 [-].

        Raises
        ------
        ParameterError
            ``flank`` is not +1 or −1 (one line); the state is unchanged then.
        """
        self.state = init_state(float(check_direction(flank, "Compensator", "flank")))

    @property
    def flank(self) -> int:
        """Flank currently in contact (±1)."""
        return int(self.state[S_FLANK])

    @property
    def cycles_outside(self) -> int:
        """Cycles since the last reset whose set positions left the table's grid [-].

        There the table's edge value was held (no extrapolation, v_c,TE = 0): the motion
        ran uncompensated for the TE's change along the position.
        """
        return int(self.state[S_OUTSIDE])

    def step(
        self, x_d_n: float, x_d_next: float, torque_m: float, omega_m: float, alpha_m: float
    ) -> tuple[float, float, float]:
        """One cycle; returns (v_c, v_c,TE, v_c,BL) [m/s]. See :func:`compensation_cycle`.

        Parameters
        ----------
        x_d_n : float
            Set position of this cycle [m].
        x_d_next : float
            Set position of the next cycle [m] (look-ahead).
        torque_m : float
            Motor torque [N·m].
        omega_m : float
            Motor speed [rad/s].
        alpha_m : float
            Motor acceleration [rad/s²].

        Returns
        -------
        tuple of float
            (v_c, v_c,TE, v_c,BL) [m/s]: the velocity correction and its TE and backlash parts.

        Raises
        ------
        DataError
            An input is not finite (NaN or ±inf): one line naming it; the state is unchanged
            (a NaN would be returned as the velocity command and stay in the state).
        """
        t = self.table
        args = (float(x_d_n), float(x_d_next), float(torque_m), float(omega_m), float(alpha_m))
        for name, v in zip(_STEP_INPUTS, args, strict=True):
            if not math.isfinite(v):
                raise DataError(f"Compensator.step: {name} is {v}; {_FINITE}")
        return compensation_cycle(self.state, t.te, t.x0, t.dx, t.torque0, t.dtorque, self._p, *args)

    def run(
        self, x_d: np.ndarray, torque_m: np.ndarray, omega_m: np.ndarray, alpha_m: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Many cycles at once (``x_d`` one longer: look-ahead); returns (v_c, v_c,TE, v_c,BL).

        Parameters
        ----------
        x_d : numpy.ndarray
            Set positions [m], n + 1 (the last one is the look-ahead of cycle n − 1).
        torque_m : numpy.ndarray
            Motor torque [N·m], n.
        omega_m : numpy.ndarray
            Motor speed [rad/s], n.
        alpha_m : numpy.ndarray
            Motor acceleration [rad/s²], n.

        Returns
        -------
        tuple of numpy.ndarray
            (v_c, v_c,TE, v_c,BL) [m/s], n each; the state is kept for the next call.

        Raises
        ------
        DataError
            Arrays that are not 1-D or of mismatched lengths, or a non-finite value (one line
            naming the array and the 0-based index of the first one); nothing is run then and
            the state is unchanged.
        """
        t = self.table
        a = [np.ascontiguousarray(np.asarray(z, dtype=np.float64)) for z in (x_d, torque_m, omega_m, alpha_m)]
        if any(z.ndim != 1 for z in a):
            shapes = ", ".join(f"{n} {z.shape}" for n, z in zip(_RUN_INPUTS, a, strict=True))
            raise DataError(f"Compensator.run: expected 1-D arrays, got {shapes}")
        if a[0].size != a[1].size + 1 or not (a[1].size == a[2].size == a[3].size):
            raise DataError("x_d needs one look-ahead sample more than torque_m/omega_m/alpha_m")
        for name, z in zip(_RUN_INPUTS, a, strict=True):
            finite = np.isfinite(z)
            if not finite.all():
                i = int(np.argmin(finite))
                raise DataError(f"Compensator.run: {name}[{i}] (0-based) is {z[i]}; {_FINITE}")
        self.state, v, vte, vbl = compensate_run(
            self.state, t.te, t.x0, t.dx, t.torque0, t.dtorque, self._p, *a
        )
        return v, vte, vbl


_STEP_INPUTS = ("x_d_n", "x_d_next", "torque_m", "omega_m", "alpha_m")
_RUN_INPUTS = ("x_d", "torque_m", "omega_m", "alpha_m")
_FINITE = (
    "set positions, torque, speed and acceleration must be finite (nothing was run, the state is unchanged)"
)
