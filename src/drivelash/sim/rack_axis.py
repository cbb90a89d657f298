"""Closed-loop rack-and-pinion axis, spec 02 §2: the virtual test bench.

Plant (motor side θ_M, ω_M; table x_T, v_T)::

    J_M ω̇_M = T_M − T_F,m(ω_M) − r F_c
    m_T v̇_T = F_c − F_F,T(v_T) − F_load tanh(v_d / v_ld)

with r = d_p/(2 i_PG), J_M = motor + gearbox + pinion/i_PG² and the mesh force F_c of
a compliant contact with backlash whose flank positions are the true transmission
error (see :mod:`drivelash.physics.rack_pinion`)::

    u = x_T − r θ_M                                   (the TE, eq (1))
    positive flank in contact if u < TE_s,+(x_T):  F_+ = p_+/c_+(x_T) + d ṗ_+,  p_+ = TE_s,+ − u  (F_+ ≥ 0)
    negative flank in contact if u > TE_s,−(x_T):  F_− = p_−/c_−(x_T) + d ṗ_−,  p_− = u − TE_s,−  (F_− ≥ 0)
    F_c = F_+ − F_−,   TE_s,d = S_d(x_T) + M_d(x_T) / (1 + F̄/F_h)

so at constant velocity u = TE(x_T, |F_c|, d) of the TE model exactly. F̄ is the mesh
force magnitude low-pass filtered with τ_F (the profile-modification effect is
quasi-static; filtering avoids an algebraic loop). The reaction torque on the motor
is r F_c (the work of dTE/dx ≈ 3e-3 is neglected).

Control (sampled at T_s = 125 µs, torque held by a zero-order hold, current loop ideal
so the measured motor torque ``torque_m`` equals the command)::

    ω_cmd = ( k_ff v_d + K_v (x_d − x_T) − v_c ) / r          x_T from the linear scale
    T_M   = K_p (ω_cmd − ω_M) + x_i,   clipped to ±torque_limit, back-calculation anti-windup

This is the one cascade controller of :mod:`drivelash.control.cascade` (kernels
``cascade_output`` / ``cascade_update``, tracking time constant T_n), with its position
loop on the linear scale [m] and r [m/rad] as the scale-to-motor factor.

**Correction velocity v_c** [m/s, table side] is *subtracted* from the velocity command,
with the paper's sign (eq (6): v_c = dTE/dt; the motor must slow down when the TE
grows). It enters only the velocity feed-forward path: the loop gains are unchanged.

The process load ``F_load`` [N, ≥ 0] is a force-controlled linear direct drive acting
*against the commanded direction of motion* (tanh of v_d / 1 mm/s).

Interfaces::

    sim = RackAxisSimulator(bench, te_model, gains=None, seed=0, n_sub=4)
    trace = sim.run(x_d, v_d, F_load, v_c=None)                   # -> Trace (measured signals)
    state = sim.initial_state(x0, direction)
    state, out = sim.step_chunk(state, x_d, v_d, F_load, v_c)    # out: dict of arrays

Running in chunks gives bit-identical results to one run (tested). Reference
trajectories: :func:`constant_velocity_pass`, :func:`sine_trajectory`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from drivelash.control.cascade import C_T_S, cascade_output, cascade_update, gains_array
from drivelash.errors import ParameterError
from drivelash.io.trace import Trace
from drivelash.params import CascadeGains
from drivelash.physics.friction import friction_scalar
from drivelash.physics.rack_pinion import RackPinionBench, TransmissionErrorModel

# state vector layout
S_THETA, S_OMEGA, S_X, S_V, S_XI, S_FBAR, S_DIR, S_K = range(8)
STATE_SIZE = 8

# output columns of the kernel (one row per sample, values at t_k)
OUT_NAMES = ("theta_m", "omega_m", "x_T", "v_T", "torque_m", "omega_cmd", "F_mesh", "direction")
O_THETA, O_OMEGA, O_X, O_V, O_TORQUE, O_WCMD, O_FMESH, O_DIR = range(8)

# parameter vector layout
(
    P_R,
    P_JM,
    P_MT,
    P_TCM,
    P_BM,
    P_WREG,
    P_FCT,
    P_BT,
    P_VREG,
    P_DMESH,
    P_NSUB,
    P_TAUF,
    P_FH,
    P_VLD,
    P_X0,
    P_DX,
    P_SX,
    P_STH,
    P_SW,
    P_STQ,
) = range(20)
PARAM_SIZE = 20

# counter-based Gaussian noise (SplitMix64 of seed, sample index and channel): the noise of
# sample k does not depend on how the run is chunked
_G = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)


@njit(cache=True, nogil=True, inline="always")
def _mix64(z):
    z = z + _G
    z = (z ^ (z >> np.uint64(30))) * _M1
    z = (z ^ (z >> np.uint64(27))) * _M2
    return z ^ (z >> np.uint64(31))


@njit(cache=True, nogil=True)
def counter_gauss(seed, k, channel):
    """Standard normal number for (seed ≥ 0, sample k ≥ 0, channel), Box–Muller of two
    SplitMix64 outputs; a pure function, so chunked runs see identical noise."""
    z = _mix64(_mix64(np.uint64(seed)) ^ (np.uint64(k) * np.uint64(8) + np.uint64(channel)))
    z2 = _mix64(z)
    u1 = ((z >> np.uint64(11)) + np.uint64(1)) * (1.0 / 9007199254740992.0)
    u2 = (z2 >> np.uint64(11)) * (1.0 / 9007199254740992.0)
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)


def bench_gains(torque_limit: float = 60.0) -> CascadeGains:
    """The bench tuning of spec 02 §2: K_v = 231 1/s, K_p = 12.4 N·m·s/rad, T_n = 3.05 ms.

    Parameters
    ----------
    torque_limit : float
        Motor torque limit [N·m] (1FT7-class peak torque, see docs/assumptions.md).
    """
    return CascadeGains(K_v=231.0, K_p=12.4, T_n=3.05e-3, torque_limit=torque_limit, k_ff=1.0, T_s=125e-6)


@njit(cache=True, nogil=True, inline="always")
def _lookup(table, x, x0, dx):
    """Linear interpolation of the 6 table rows at x (clamped at the ends), and the
    slopes dS/dx, dM/dx of both flanks (of the interpolant, 0 beyond the ends)."""
    n = table.shape[1]
    s = (x - x0) / dx
    g = 1.0 / dx
    if s <= 0.0:
        i = 0
        w = 0.0
        g = 0.0
    elif s >= n - 1:
        i = n - 2
        w = 1.0
        g = 0.0
    else:
        i = int(s)
        w = s - i
    a = 1.0 - w
    return (
        a * table[0, i] + w * table[0, i + 1],
        a * table[1, i] + w * table[1, i + 1],
        a * table[2, i] + w * table[2, i + 1],
        a * table[3, i] + w * table[3, i + 1],
        a * table[4, i] + w * table[4, i + 1],
        a * table[5, i] + w * table[5, i + 1],
        g * (table[0, i + 1] - table[0, i]),
        g * (table[1, i + 1] - table[1, i]),
        g * (table[3, i + 1] - table[3, i]),
        g * (table[4, i + 1] - table[4, i]),
    )


@njit(cache=True, nogil=True, inline="always")
def _mesh_force(theta, omega, x, v, Fbar, p, table):
    """Mesh force on the table F_c [N] (positive pushes the table towards +x)."""
    r = p[P_R]
    Sp, Mp, cp, Sm, Mm, cm, dSp, dMp, dSm, dMm = _lookup(table, x, p[P_X0], p[P_DX])
    lf = 1.0 / (1.0 + Fbar / p[P_FH])
    u = x - r * theta
    du = v - r * omega
    F = 0.0
    # penetration (elastic deflection) of each flank and its rate; the damper acts on the
    # deflection rate, not on the rate of the geometric error itself
    pen_p = Sp + Mp * lf - u
    if pen_p > 0.0:
        f = pen_p / cp + p[P_DMESH] * ((dSp + dMp * lf) * v - du)
        if f > 0.0:
            F += f
    pen_m = u - (Sm + Mm * lf)
    if pen_m > 0.0:
        f = pen_m / cm + p[P_DMESH] * (du - (dSm + dMm * lf) * v)
        if f > 0.0:
            F -= f
    return F


@njit(cache=True, nogil=True, inline="always")
def _rhs(theta, omega, x, v, T_M, F_ext, Fbar, p, table):
    Fc = _mesh_force(theta, omega, x, v, Fbar, p, table)
    T_fm = friction_scalar(omega, p[P_TCM], p[P_BM], 0.0, 1.0, p[P_WREG])
    F_fT = friction_scalar(v, p[P_FCT], p[P_BT], 0.0, 1.0, p[P_VREG])
    dw = (T_M - T_fm - p[P_R] * Fc) / p[P_JM]
    dv = (Fc - F_fT + F_ext) / p[P_MT]
    return omega, dw, v, dv


@njit(cache=True, nogil=True)
def axis_chunk(state, x_d, v_d, F_load, v_c, p, ctrl, table, out, seed):
    """Advance the closed-loop axis over ``x_d.size`` samples.

    Parameters
    ----------
    state : numpy.ndarray, shape (STATE_SIZE,)
        θ_M [rad], ω_M [rad/s], x_T [m], v_T [m/s], PI integrator [N·m], F̄ [N],
        last direction [±1], sample counter k (t = k T_s, exact). Not modified.
    x_d, v_d : numpy.ndarray
        Set position [m] and set velocity (feed-forward) [m/s] per sample.
    F_load : numpy.ndarray
        Process-load magnitude against the motion [N] per sample.
    v_c : numpy.ndarray
        Correction velocity [m/s] per sample (subtracted from the command).
    p : numpy.ndarray, shape (PARAM_SIZE,)
        Plant and numerical parameters (layout ``P_*``).
    ctrl : numpy.ndarray
        Cascade gains (layout :data:`drivelash.control.cascade.CTRL_FIELDS`).
    table : numpy.ndarray, shape (6, n)
        TE tables of :meth:`TransmissionErrorModel.tables`.
    out : numpy.ndarray, shape (n_samples, 8)
        Filled with the samples at t_k (layout ``O_*``): the *measured* θ_M, ω_M, x_T
        and torque (true values when the noise levels ``P_S*`` are 0).
    seed : int
        Seed of the sensor noise (≥ 0).

    Returns
    -------
    numpy.ndarray
        The state after the last sample.
    """
    th = state[S_THETA]
    w = state[S_OMEGA]
    x = state[S_X]
    v = state[S_V]
    xi = state[S_XI]
    Fbar = state[S_FBAR]
    dirm = state[S_DIR]
    kk = state[S_K]
    r = p[P_R]
    T_s = ctrl[C_T_S]
    nsub = int(p[P_NSUB])
    h = T_s / nsub
    a_f = 1.0 - math.exp(-T_s / p[P_TAUF])
    for k in range(x_d.size):
        # direction of travel from the set velocity (kept through standstill)
        if v_d[k] > 1e-9:
            dirm = 1.0
        elif v_d[k] < -1e-9:
            dirm = -1.0
        # cascade: P position on the linear scale, PI velocity on the motor encoder
        # sensors: linear scale, motor encoder (angle, velocity); white noise if configured
        x_m = x
        w_m = w
        th_m = th
        ks = int(kk)
        if p[P_SX] > 0.0:
            x_m = x + p[P_SX] * counter_gauss(seed, ks, 0)
        if p[P_STH] > 0.0:
            th_m = th + p[P_STH] * counter_gauss(seed, ks, 1)
        if p[P_SW] > 0.0:
            w_m = w + p[P_SW] * counter_gauss(seed, ks, 2)
        T_M, u_un, e_w, w_cmd = cascade_output(xi, x_d[k], v_d[k], x_m, w_m, v_c[k], r, ctrl)
        Fc0 = _mesh_force(th, w, x, v, Fbar, p, table)
        out[k, O_THETA] = th_m
        out[k, O_OMEGA] = w_m
        out[k, O_X] = x_m
        out[k, O_V] = v
        out[k, O_TORQUE] = T_M
        if p[P_STQ] > 0.0:
            out[k, O_TORQUE] = T_M + p[P_STQ] * counter_gauss(seed, ks, 3)
        out[k, O_WCMD] = w_cmd
        out[k, O_FMESH] = Fc0
        out[k, O_DIR] = dirm
        F_ext = -F_load[k] * math.tanh(v_d[k] / p[P_VLD])
        for _ in range(nsub):
            k1a, k1b, k1c, k1d = _rhs(th, w, x, v, T_M, F_ext, Fbar, p, table)
            k2a, k2b, k2c, k2d = _rhs(
                th + 0.5 * h * k1a, w + 0.5 * h * k1b, x + 0.5 * h * k1c, v + 0.5 * h * k1d,
                T_M, F_ext, Fbar, p, table,
            )  # fmt: skip
            k3a, k3b, k3c, k3d = _rhs(
                th + 0.5 * h * k2a, w + 0.5 * h * k2b, x + 0.5 * h * k2c, v + 0.5 * h * k2d,
                T_M, F_ext, Fbar, p, table,
            )  # fmt: skip
            k4a, k4b, k4c, k4d = _rhs(
                th + h * k3a, w + h * k3b, x + h * k3c, v + h * k3d, T_M, F_ext, Fbar, p, table
            )
            th += h / 6.0 * (k1a + 2.0 * k2a + 2.0 * k3a + k4a)
            w += h / 6.0 * (k1b + 2.0 * k2b + 2.0 * k3b + k4b)
            x += h / 6.0 * (k1c + 2.0 * k2c + 2.0 * k3c + k4c)
            v += h / 6.0 * (k1d + 2.0 * k2d + 2.0 * k3d + k4d)
        xi = cascade_update(xi, e_w, T_M, u_un, T_s, ctrl)
        Fc1 = _mesh_force(th, w, x, v, Fbar, p, table)
        Fbar += a_f * (abs(Fc1) - Fbar)
        kk += 1.0
    new = np.empty(STATE_SIZE)
    new[S_THETA] = th
    new[S_OMEGA] = w
    new[S_X] = x
    new[S_V] = v
    new[S_XI] = xi
    new[S_FBAR] = Fbar
    new[S_DIR] = dirm
    new[S_K] = kk
    return new


@dataclass(frozen=True)
class AxisSimConfig:
    """Numerical settings of the axis engine.

    Parameters
    ----------
    n_sub : int
        RK4 substeps per control period [-].
    tau_F : float
        Time constant of the mesh-force filter F̄ that sets the mesh amplitude [s].
    v_reg : float
        Friction regularisation velocity of the table [m/s] (motor: v_reg / r).
    v_load : float
        Velocity scale of the load direction, tanh(v_d / v_load) [m/s].
    table_dx : float
        Grid step of the TE tables [m].
    sigma_x : float
        Std of white noise of the linear scale [m] (0: ideal; the controller sees it).
    sigma_theta : float
        Std of white noise of the motor encoder angle [rad] (recorded only).
    sigma_omega : float
        Std of white noise of the motor velocity [rad/s] (the velocity loop sees it).
    sigma_torque : float
        Std of white noise of the *recorded* motor torque [N·m] (the control is not affected).

    Raises
    ------
    ParameterError
        A field outside its valid range (one line naming the class and the field).
    """

    n_sub: int = 4
    tau_F: float = 5e-3
    v_reg: float = 1e-4
    v_load: float = 1e-3
    table_dx: float = 10e-6
    sigma_x: float = 0.0
    sigma_theta: float = 0.0
    sigma_omega: float = 0.0
    sigma_torque: float = 0.0

    def __post_init__(self) -> None:
        for n in ("n_sub", "tau_F", "v_reg", "v_load", "table_dx"):
            v = getattr(self, n)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(type(self).__name__, n, f"must be finite and > 0, got {v!r}")
        if int(self.n_sub) != self.n_sub:
            raise ParameterError(type(self).__name__, "n_sub", "must be a whole number")
        for n in ("sigma_x", "sigma_theta", "sigma_omega", "sigma_torque"):
            v = getattr(self, n)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ParameterError(type(self).__name__, n, f"must be finite and >= 0, got {v!r}")


class RackAxisSimulator:
    """The closed-loop virtual rack-and-pinion bench (see module docstring).

    Parameters
    ----------
    bench : RackPinionBench
        Mechanics (inertias, friction, ratio).
    te_model : TransmissionErrorModel
        True transmission error, backlash and compliance.
    gains : CascadeGains, optional
        Cascade tuning; default :func:`bench_gains` (spec 02 §2).
    seed : int
        Seed of the sensor noise (≥ 0; only used when ``config`` sets noise levels).
    config : AxisSimConfig, optional
        Numerical settings.

    Raises
    ------
    ParameterError
        ``seed`` < 0.
    """

    def __init__(
        self,
        bench: RackPinionBench,
        te_model: TransmissionErrorModel,
        gains: CascadeGains | None = None,
        seed: int = 0,
        config: AxisSimConfig | None = None,
    ) -> None:
        self.bench = bench
        self.te_model = te_model
        self.gains = gains if gains is not None else bench_gains()
        self.seed = int(seed)
        if self.seed < 0:
            raise ParameterError("RackAxisSimulator", "seed", f"must be >= 0, got {seed!r}")
        self.config = config if config is not None else AxisSimConfig()
        self.T_s = self.gains.T_s
        x0, dx, table = te_model.tables(dx=self.config.table_dx)
        self._table = table
        c_mean = float(np.mean(te_model.c))
        b, g, c = bench, self.gains, self.config
        p = np.zeros(PARAM_SIZE)
        p[P_R] = b.r_eff
        p[P_JM] = b.J_M
        p[P_MT] = b.m_T
        p[P_TCM] = b.T_Cm
        p[P_BM] = b.beta_m
        p[P_WREG] = c.v_reg / b.r_eff
        p[P_FCT] = b.F_CT
        p[P_BT] = b.beta_T
        p[P_VREG] = c.v_reg
        p[P_DMESH] = b.d_mesh(c_mean)
        p[P_NSUB] = c.n_sub
        p[P_TAUF] = c.tau_F
        p[P_FH] = te_model.params.F_h
        p[P_VLD] = c.v_load
        p[P_X0] = x0
        p[P_DX] = dx
        p[P_SX] = c.sigma_x
        p[P_STH] = c.sigma_theta
        p[P_SW] = c.sigma_omega
        p[P_STQ] = c.sigma_torque
        self._p = p
        self._ctrl = gains_array(g)

    def initial_state(self, x0: float, direction: int = 1, F0: float = 0.0) -> np.ndarray:
        """State at rest at table position ``x0`` [m], flank ``direction`` in contact.

        Parameters
        ----------
        x0 : float
            Table position [m].
        direction : int
            Flank in contact, +1 or −1.
        F0 : float
            Initial mesh force magnitude [N] (contact pre-deflection).

        Raises
        ------
        ParameterError
            ``direction`` is not +1 or −1.
        """
        if direction not in (1, -1):
            raise ParameterError("RackAxisSimulator", "direction", "must be +1 or -1")
        te0 = float(self.te_model.te(x0, F0, direction))
        s = np.zeros(STATE_SIZE)
        s[S_THETA] = (x0 - te0) / self.bench.r_eff
        s[S_X] = x0
        s[S_FBAR] = F0
        s[S_DIR] = direction
        return s

    def step_chunk(
        self,
        state: np.ndarray,
        x_d: np.ndarray,
        v_d: np.ndarray,
        F_load: np.ndarray | float = 0.0,
        v_c: np.ndarray | float | None = None,
    ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Advance over a chunk of samples (e.g. 40 samples = one 5 ms compensation cycle).

        Parameters
        ----------
        state : numpy.ndarray
            From :meth:`initial_state` or a previous call (not modified).
        x_d, v_d : numpy.ndarray
            Set position [m] and set velocity [m/s], one value per sample.
        F_load : array_like
            Process-load magnitude [N] (scalar or per sample).
        v_c : array_like, optional
            Correction velocity [m/s, table side], subtracted from the velocity command.

        Returns
        -------
        state : numpy.ndarray
            New state.
        outputs : dict of numpy.ndarray
            ``t`` [s], ``theta_m`` [rad], ``omega_m`` [rad/s], ``x_T`` [m], ``v_T`` [m/s],
            ``torque_m`` [N·m] (measured = commanded), ``omega_cmd`` [rad/s], ``F_mesh`` [N],
            ``direction`` [±1], all at the sample instants t_k (before the update).

        Raises
        ------
        ParameterError
            ``v_d`` not of the shape of ``x_d``.
        """
        # writable C-contiguous float64 whatever the caller passes: a read-only input (a
        # broadcast scalar, an Arrow-backed column) would otherwise be another numba type and
        # compile axis_chunk once more (≈ 10 s each; three signatures were compiled before)
        x_d = np.require(x_d, np.float64, ("C", "W"))
        n = x_d.size
        v_d = np.require(v_d, np.float64, ("C", "W"))
        if v_d.shape != x_d.shape:
            raise ParameterError("RackAxisSimulator", "v_d", "must have the shape of x_d")
        F = np.require(np.broadcast_to(np.asarray(F_load, dtype=np.float64), (n,)), np.float64, ("C", "W"))
        vc = np.zeros(n) if v_c is None else np.broadcast_to(np.asarray(v_c, dtype=np.float64), (n,))
        vc = np.require(vc, np.float64, ("C", "W"))
        out = np.empty((n, len(OUT_NAMES)))
        k0 = float(state[S_K])
        new = axis_chunk(
            np.asarray(state, dtype=np.float64),
            x_d,
            v_d,
            F,
            vc,
            self._p,
            self._ctrl,
            self._table,
            out,
            self.seed,
        )
        outputs = {"t": (k0 + np.arange(n)) * self.T_s}
        for j, name in enumerate(OUT_NAMES):
            outputs[name] = out[:, j].copy()
        return new, outputs

    def run(
        self,
        x_d: np.ndarray,
        v_d: np.ndarray,
        F_load: np.ndarray | float = 0.0,
        v_c: np.ndarray | float | None = None,
        state: np.ndarray | None = None,
        decimate: int = 1,
        meta: dict | None = None,
    ) -> Trace:
        """Simulate a whole trajectory and return a :class:`Trace`.

        Parameters
        ----------
        x_d, v_d, F_load, v_c
            As in :meth:`step_chunk`.
        state : numpy.ndarray, optional
            Initial state; default at rest at x_d[0] on the flank of the first
            non-zero set velocity.
        decimate : int
            Keep every ``decimate``-th sample (e.g. 8 ⇒ 1 kHz).
        meta : dict, optional
            Extra provenance for ``Trace.meta``.

        Returns
        -------
        Trace
            Columns t, x_d, v_d, x_T, v_T, theta_m, omega_m, torque_m, omega_cmd,
            F_load, F_mesh, v_c, direction.
        """
        x_d = np.asarray(x_d, dtype=np.float64)
        v_d = np.asarray(v_d, dtype=np.float64)
        if state is None:
            nz = np.flatnonzero(np.abs(v_d) > 1e-9)
            d0 = int(np.sign(v_d[nz[0]])) if nz.size else 1
            state = self.initial_state(float(x_d[0]), d0)
        n = x_d.size
        F = np.broadcast_to(np.asarray(F_load, dtype=np.float64), (n,))
        vc = np.zeros(n) if v_c is None else np.broadcast_to(np.asarray(v_c, dtype=np.float64), (n,))
        _, out = self.step_chunk(state, x_d, v_d, F, vc)
        cols = {
            "t": out["t"],
            "x_d": x_d,
            "v_d": v_d,
            "x_T": out["x_T"],
            "v_T": out["v_T"],
            "theta_m": out["theta_m"],
            "omega_m": out["omega_m"],
            "torque_m": out["torque_m"],
            "omega_cmd": out["omega_cmd"],
            "F_load": F,
            "F_mesh": out["F_mesh"],
            "v_c": vc,
            "direction": out["direction"],
        }
        sl = slice(None, None, int(decimate))
        m = {"engine": "rack_axis", "T_s": self.T_s * int(decimate), "seed": self.seed}
        if meta:
            m.update(meta)
        return Trace({k: np.asarray(v)[sl] for k, v in cols.items()}, m)


# -- reference trajectories ----------------------------------------------------------------
def constant_velocity_pass(
    x_start: float,
    x_end: float,
    v: float,
    T_s: float = 125e-6,
    a_max: float = 0.5,
    dwell: float = 0.1,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A pass from ``x_start`` to ``x_end`` at constant speed with sin² velocity ramps.

    Parameters
    ----------
    x_start, x_end : float
        Start and end position [m].
    v : float
        Travel speed [m/s] (> 0; the sign follows x_end − x_start).
    T_s : float
        Sample period [s].
    a_max : float
        Peak acceleration of the ramps [m/s²] (ramp time max(π v/(2 a_max), 50 ms)).
    dwell : float
        Standstill before and after the motion [s].

    Returns
    -------
    t, x_d, v_d : numpy.ndarray
        Time [s], set position [m], set velocity [m/s].
    """
    if not v > 0:
        raise ParameterError("constant_velocity_pass", "v", f"must be > 0, got {v!r}")
    D = abs(x_end - x_start)
    sgn = 1.0 if x_end >= x_start else -1.0
    t_a = max(math.pi * v / (2 * a_max), 0.05)
    if D < v * t_a:
        raise ParameterError("constant_velocity_pass", "x_end", "pass too short for the ramps")
    t_c = D / v - t_a
    T = dwell + 2 * t_a + t_c + dwell
    t = T_s * np.arange(int(math.ceil(T / T_s)) + 1)
    tau = np.clip(t - dwell, 0.0, 2 * t_a + t_c)

    def ramp(s: np.ndarray) -> np.ndarray:
        return 0.5 * v * (s - t_a / math.pi * np.sin(math.pi * s / t_a))

    s = np.where(
        tau <= t_a,
        ramp(np.minimum(tau, t_a)),
        np.where(
            tau <= t_a + t_c,
            0.5 * v * t_a + v * (tau - t_a),
            0.5 * v * t_a + v * t_c + v * (tau - t_a - t_c) - ramp(np.clip(tau - t_a - t_c, 0, t_a)),
        ),
    )
    vel = np.where(
        tau <= t_a,
        v * np.sin(0.5 * math.pi * tau / t_a) ** 2,
        np.where(
            tau <= t_a + t_c, v, v * np.cos(0.5 * math.pi * np.clip(tau - t_a - t_c, 0, t_a) / t_a) ** 2
        ),
    )
    vel = np.where((t < dwell) | (t > dwell + 2 * t_a + t_c), 0.0, vel)
    return t, x_start + sgn * s, sgn * vel


def sine_trajectory(
    x_center: float,
    amplitude: float,
    frequency: float,
    periods: float = 2.0,
    T_s: float = 125e-6,
    dwell: float = 0.1,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x_d = x_c − A cos(2π f t): starts and ends at rest, reverses every half period.

    Parameters
    ----------
    x_center : float
        Centre [m]. amplitude : float — A [m]. frequency : float — f [Hz].
    periods : float
        Number of periods [-]. T_s : float — sample period [s]. dwell : float — rest before/after [s].

    Returns
    -------
    t, x_d, v_d : numpy.ndarray
    """
    if not (amplitude > 0 and frequency > 0 and periods > 0):
        raise ParameterError("sine_trajectory", "amplitude", "amplitude, frequency, periods must be > 0")
    T = 2 * dwell + periods / frequency
    t = T_s * np.arange(int(math.ceil(T / T_s)) + 1)
    tau = np.clip(t - dwell, 0.0, periods / frequency)
    w = 2 * math.pi * frequency
    x = x_center - amplitude * np.cos(w * tau)
    v = amplitude * w * np.sin(w * tau)
    v = np.where((t < dwell) | (t > dwell + periods / frequency), 0.0, v)
    return t, x, v
