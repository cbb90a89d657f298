"""Stability of the position loop with the sampled TE compensator's torque path (spec 02 §5).

The compensator of spec 02 §5 is called "feed-forward", but its error models read the
*measured* motor torque: every t_s,c it forms the model torque
``T_model = mean(T_M over the last cycle) − J_model · α̂`` and outputs

    v_c = (TE(x_d,n+1, T_model) − TE(x_d,n, T_model)) / t_s,c                       (6)

which is subtracted from the velocity command. Linearised around an operating point,
``δv_c[k] = g_T · δT_model[k−1]`` with the **torque-path gain**

    g_T = (∂TE/∂T (x_d,n + Δ) − ∂TE/∂T (x_d,n)) / t_s,c,   Δ = x_d,n+1 − x_d,n = v t_s,c,

[(m/s)/(N·m)], i.e. ≈ v · ∂²TE/∂x∂T. A model whose torque sensitivity varies along the
travel therefore closes a loop T_M → v_c → ω_cmd → PI → T_M. This module analyses that
loop honestly:

* the axis is a linear two-mass model (motor J_M, table m_T, mesh stiffness and
  damping, viscous friction) or the rigid J_s model of eqs (2)–(3), discretised exactly
  (zero-order hold) at the control period T_s, with the discrete P/PI cascade of the
  bench (:mod:`drivelash.sim.rack_axis`: ``T = K_p e_ω + x_i``, forward-Euler
  integrator, measured x_T and ω_M at the sample instant);
* the multirate system (control at T_s, compensator at t_s,c = N T_s with a 5 ms mean of
  the torque, an end-minus-start estimate of α, a one-cycle delay and a hold) is
  **lifted** to the compensator period: an exact linear time-invariant model at t_s,c,
  so its eigenvalues decide stability exactly (for the linearised loop);
* python-control gives the loop transfer function of the torque path at t_s,c, its gain
  and phase margins, and the closed-loop poles with and without the path;
* :func:`table_torque_path_gains` evaluates g_T of a bilinear position × torque table
  (the runtime form of the compensator) exactly over every position, torque cell, flank
  and travel direction, so the worst case over the model's torque sensitivity is known.

What is *not* linearised: the flank detection (a discrete decision with hysteresis) and
the one-shot backlash step (7), whose torque dependence acts once per flank change,
not as a sustained feedback.

Conventions: ``v_c`` is subtracted from the velocity command (table units, m/s), so
with ``g_T > 0`` a torque increase lowers the command — a negative feedback through
the PI controller's direct term that the acceleration-torque subtraction ``J_model α̂``
largely cancels when J_model equals the axis inertia.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from drivelash.errors import ParameterError
from drivelash.params import CascadeGains

__all__ = [
    "AxisPlant",
    "LoopReport",
    "TorquePathLoop",
    "analyse_torque_path",
    "table_torque_path_gain_at",
    "table_torque_path_gains",
]


# ---------------------------------------------------------------------------
# the axis


@dataclass(frozen=True)
class AxisPlant:
    """Linear mechanics of a rack-and-pinion axis at the motor (torque in, ω_M and x_T out).

    Parameters
    ----------
    J_M : float
        Motor + gearbox + pinion inertia at the motor [kg·m²].
    m_T : float
        Table mass [kg].
    r : float
        Effective radius d_p / (2 i) [m] (table travel per motor radian).
    k_mesh : float or None
        Mesh stiffness [N/m] between r θ_M and x_T; None: rigid coupling (the combined
        inertia J_s = J_M + m_T r² of eqs (2)–(3)).
    d_mesh : float
        Mesh damping [N·s/m] (two-mass model only).
    beta_m : float
        Viscous friction of the motor side [N·m·s/rad].
    beta_T : float
        Viscous friction of the table [N·s/m].
    """

    J_M: float
    m_T: float
    r: float
    k_mesh: float | None = None
    d_mesh: float = 0.0
    beta_m: float = 0.0
    beta_T: float = 0.0

    def __post_init__(self) -> None:
        for n in ("J_M", "m_T", "r"):
            v = getattr(self, n)
            if not (math.isfinite(v) and v > 0):
                raise ParameterError(type(self).__name__, n, f"must be finite and > 0, got {v!r}")
        for n in ("d_mesh", "beta_m", "beta_T"):
            v = getattr(self, n)
            if not (math.isfinite(v) and v >= 0):
                raise ParameterError(type(self).__name__, n, f"must be finite and >= 0, got {v!r}")
        if self.k_mesh is not None and not (math.isfinite(self.k_mesh) and self.k_mesh > 0):
            raise ParameterError(type(self).__name__, "k_mesh", f"must be > 0 or None, got {self.k_mesh!r}")

    @property
    def J_s(self) -> float:
        """Combined inertia J_M + m_T r² [kg·m²]."""
        return self.J_M + self.m_T * self.r**2

    @classmethod
    def from_bench(cls, bench: Any, c_mesh: float | None = None, rigid: bool = False) -> AxisPlant:
        """The plant of a :class:`~drivelash.physics.rack_pinion.RackPinionBench`.

        Parameters
        ----------
        bench : RackPinionBench
            Inertias, friction, ratio.
        c_mesh : float, optional
            Mesh compliance [m/N] (the TE model's mean ``c``); required unless ``rigid``.
        rigid : bool
            Rigid coupling (J_s) instead of the two-mass model.
        """
        if rigid:
            return cls(bench.J_M, bench.m_T, bench.r_eff, None, 0.0, bench.beta_m, bench.beta_T)
        if c_mesh is None or not c_mesh > 0:
            raise ParameterError("AxisPlant.from_bench", "c_mesh", f"must be > 0, got {c_mesh!r}")
        return cls(
            bench.J_M, bench.m_T, bench.r_eff, 1.0 / c_mesh, bench.d_mesh(c_mesh), bench.beta_m, bench.beta_T
        )

    def continuous(self):  # noqa: ANN201 - control.StateSpace
        """Continuous state-space model: input ``T_M`` [N·m]; outputs ``omega_m`` [rad/s], ``x_T`` [m]."""
        import control as ct

        r = self.r
        if self.k_mesh is None:
            # states θ_M, ω_M; x_T = r θ_M; table friction reflected to the motor
            J = self.J_s
            beta = self.beta_m + self.beta_T * r**2
            A = [[0.0, 1.0], [0.0, -beta / J]]
            B = [[0.0], [1.0 / J]]
            C = [[0.0, 1.0], [r, 0.0]]
        else:
            # states θ_M, ω_M, x_T, v_T; F_c = k (r θ − x) + d (r ω − v) pushes the table
            k, d, Jm, m = self.k_mesh, self.d_mesh, self.J_M, self.m_T
            A = [
                [0.0, 1.0, 0.0, 0.0],
                [-r * k * r / Jm, -(self.beta_m + r * d * r) / Jm, r * k / Jm, r * d / Jm],
                [0.0, 0.0, 0.0, 1.0],
                [k * r / m, d * r / m, -k / m, -(d + self.beta_T) / m],
            ]
            B = [[0.0], [1.0 / Jm], [0.0], [0.0]]
            C = [[0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]]
        return ct.ss(A, B, C, [[0.0], [0.0]], inputs=["T_M"], outputs=["omega_m", "x_T"], name="axis")


def discrete_cascade(plant: AxisPlant, gains: CascadeGains):  # noqa: ANN201 - control.StateSpace
    """The sampled closed cascade of the bench at T_s (python-control, ``dt = T_s``).

    Controller (as in :func:`drivelash.sim.rack_axis.axis_chunk`)::

        ω_cmd[k] = (k_ff v_ff[k] + K_v (x_d[k] − x_T[k]) − v_c[k]) / r
        T_M[k]   = K_p (ω_cmd[k] − ω_M[k]) + x_i[k],   x_i[k+1] = x_i[k] + K_p T_s / T_n (ω_cmd[k] − ω_M[k])

    with T_M held over [t_k, t_k+1) (torque limit not active). Inputs ``x_d``, ``v_ff``,
    ``v_c``; outputs ``T_M`` [N·m], ``omega_m`` [rad/s], ``e`` = x_d − x_T [m].
    """
    import control as ct

    T_s = float(gains.T_s)
    r = plant.r
    axis = ct.sample_system(plant.continuous(), T_s, method="zoh", name="axis_d")
    Kp, Tn, Kv = gains.K_p, gains.T_n, gains.K_v
    pos = ct.ss([], [], [], [[gains.k_ff / r, Kv / r, -Kv / r, -1.0 / r]], dt=T_s,
                inputs=["v_ff", "x_d", "x_T", "v_c"], outputs=["w_cmd"], name="P")  # fmt: skip
    sum_w = ct.summing_junction(inputs=["w_cmd", "-omega_m"], output="e_w", dt=T_s, name="sum_w")
    pi = ct.tf([Kp, Kp * (T_s / Tn - 1.0)], [1.0, -1.0], dt=T_s, inputs="e_w", outputs="T_M", name="PI")
    err = ct.summing_junction(inputs=["x_d", "-x_T"], output="e", dt=T_s, name="sum_e")
    return ct.interconnect(
        [axis, pos, sum_w, ct.tf2ss(pi), err],
        inputs=["x_d", "v_ff", "v_c"],
        outputs=["T_M", "omega_m", "e"],
        name="cascade",
    )


def _cascade_vc_matrices(plant: AxisPlant, gains: CascadeGains, _cache: dict = {}):  # noqa: B006
    """State-space matrices of :func:`discrete_cascade` from ``v_c`` to (T_M, ω_M), in NumPy.

    The same loop as the python-control interconnection (tested equal), written out so
    that margins which rebuild the loop many times stay fast. States: the ZOH-sampled
    plant, then the PI integrator x_i.
    """
    key = (plant, float(gains.T_s))
    if key not in _cache:
        import control as ct

        pd = ct.sample_system(plant.continuous(), gains.T_s, method="zoh")
        _cache[key] = (np.asarray(pd.A, dtype=np.float64), np.asarray(pd.B, dtype=np.float64),
                       np.asarray(pd.C, dtype=np.float64))  # fmt: skip
    Ad, Bd, Cp = _cache[key]
    r, Kp, Kv = plant.r, gains.K_p, gains.K_v
    ki = Kp * gains.T_s / gains.T_n
    Ce = -(Kv / r) * Cp[1] - Cp[0]  # e_ω = Ce x − v_c / r  (x_d = v_ff = 0: perturbation)
    n = Ad.shape[0]
    A = np.zeros((n + 1, n + 1))
    A[:n, :n] = Ad + Kp * np.outer(Bd[:, 0], Ce)
    A[:n, n] = Bd[:, 0]
    A[n, :n] = ki * Ce
    A[n, n] = 1.0
    B = np.zeros((n + 1, 1))
    B[:n, 0] = -Bd[:, 0] * Kp / r
    B[n, 0] = -ki / r
    C = np.zeros((2, n + 1))
    C[0, :n] = Kp * Ce
    C[0, n] = 1.0
    C[1, :n] = Cp[0]
    D = np.array([[-Kp / r], [0.0]])
    return A, B, C, D


def _lift(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, N: int):
    """Lift a discrete system with a held scalar input to N samples per step.

    Returns ``A_N``, ``B_N`` and, for each output row, the matrices giving the output at
    every sample j = 0 … N−1 of the step: ``Y_x[j] = C A^j`` and ``Y_u[j] = C Σ_{i<j} A^i B + D``.
    """
    n = A.shape[0]
    Aj = np.eye(n)
    Sj = np.zeros((n, B.shape[1]))  # Σ_{i<j} A^i B
    Yx, Yu = [], []
    for _ in range(N):
        Yx.append(C @ Aj)
        Yu.append(C @ Sj + D)
        Sj = Sj + Aj @ B
        Aj = A @ Aj
    return Aj, Sj, np.array(Yx), np.array(Yu)


# ---------------------------------------------------------------------------
# the loop through the compensator's torque path


@dataclass
class TorquePathLoop:
    """The cascade lifted to the compensator period, with the linearised torque path.

    Parameters
    ----------
    plant : AxisPlant
        Mechanics.
    gains : CascadeGains
        Cascade tuning (``T_s``).
    t_sc : float
        Compensation period [s], a whole multiple N of T_s.
    J_model : float
        Inertia whose acceleration torque the compensator subtracts [kg·m²].

    Notes
    -----
    Per compensator cycle k (N control samples, v_c[k] held): the compensator reads the
    mean torque T̄[k] of the cycle and α̂[k] = (ω[last] − ω[first]) / ((N − 1) T_s), and
    outputs ``v_c[k+1] = g_T (T̄[k] − J_model α̂[k])``, exactly as
    :func:`drivelash.te.validate.run_pass` feeds :class:`~drivelash.te.compensation.Compensator`.
    """

    plant: AxisPlant
    gains: CascadeGains
    t_sc: float = 5e-3
    J_model: float = 0.0
    N: int = field(init=False)
    A: np.ndarray = field(init=False, repr=False)
    B: np.ndarray = field(init=False, repr=False)
    C: np.ndarray = field(init=False, repr=False)
    D: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        N = int(round(self.t_sc / self.gains.T_s))
        if N < 2 or abs(N * self.gains.T_s - self.t_sc) > 1e-9 * self.t_sc:
            raise ParameterError("TorquePathLoop", "t_sc", "must be a whole multiple (>= 2) of T_s")
        self.N = N
        A, B, C, D = _cascade_vc_matrices(self.plant, self.gains)
        AN, BN, Yx, Yu = _lift(A, B, C, D, N)
        # lifted outputs: T̄ (mean over the cycle) and α̂ (end minus start of ω)
        h = 1.0 / ((N - 1) * self.gains.T_s)
        Cb = np.vstack([Yx[:, 0, :].mean(axis=0), h * (Yx[-1, 1, :] - Yx[0, 1, :])])
        Db = np.vstack([Yu[:, 0, :].mean(axis=0), h * (Yu[-1, 1, :] - Yu[0, 1, :])])
        self.A, self.B, self.C, self.D = AN, BN, Cb, Db

    # -- lifted plant and loop -------------------------------------------------
    def lifted(self):  # noqa: ANN201 - control.StateSpace
        """Lifted cascade at t_s,c: input held ``v_c``; outputs ``T_mean``, ``alpha_hat``."""
        import control as ct

        return ct.ss(self.A, self.B, self.C, self.D, dt=self.t_sc, inputs=["v_c"],
                     outputs=["T_mean", "alpha_hat"], name="lifted")  # fmt: skip

    def model_torque_response(self):  # noqa: ANN201 - control.StateSpace
        """P(z) from v_c[k] to T_model[k] = T̄[k] − J_model α̂[k] (lifted, SISO)."""
        import control as ct

        w = np.array([[1.0, -self.J_model]])
        return ct.ss(self.A, self.B, w @ self.C, w @ self.D, dt=self.t_sc, name="P")

    def loop_transfer(self, g_T: float):  # noqa: ANN201 - control.StateSpace
        """Loop transfer function of the torque path in negative-feedback form, L = −g_T z⁻¹ P(z).

        Closing it (``1 + L = 0``) gives the compensated loop; python-control's
        ``stability_margins(L)`` gives the gain and phase margins of the torque path.
        """
        import control as ct

        delay = ct.tf([-float(g_T)], [1.0, 0.0], dt=self.t_sc)
        return ct.series(self.model_torque_response(), ct.tf2ss(delay))

    def peak_gain(self, n: int = 400) -> float:
        """max over ω of |P(e^{jω t_s,c})| [(N·m)/(m/s)] (|z⁻¹| = 1 on the unit circle)."""
        w = np.array([1.0, -self.J_model])
        c, d = w @ self.C, float(w @ self.D[:, 0])
        eye = np.eye(self.A.shape[0])
        zs = np.exp(1j * np.linspace(0.0, math.pi, n))
        return float(max(abs(c @ np.linalg.solve(z * eye - self.A, self.B[:, 0]) + d) for z in zs))

    def closed_loop_matrix(self, g_T: float) -> np.ndarray:
        """State matrix at t_s,c of the loop closed through v_c[k+1] = g_T T_model[k]."""
        w = np.array([1.0, -self.J_model])
        c = w @ self.C
        d = float(w @ self.D[:, 0])
        n = self.A.shape[0]
        # augmented state [x; v] with v = v_c held in the current cycle
        M = np.zeros((n + 1, n + 1))
        M[:n, :n] = self.A
        M[:n, n] = self.B[:, 0]
        M[n, :n] = g_T * c
        M[n, n] = g_T * d
        return M

    def poles(self, g_T: float) -> np.ndarray:
        """Closed-loop poles at t_s,c (z-plane) with the torque path of gain ``g_T``."""
        return np.linalg.eigvals(self.closed_loop_matrix(g_T))

    def spectral_radius(self, g_T: float) -> float:
        """Largest |pole| at t_s,c (< 1: stable)."""
        return float(np.max(np.abs(self.poles(g_T))))

    def critical_gains(self, g_max: float = 1.0) -> tuple[float, float]:
        """Smallest negative and positive g_T [(m/s)/(N·m)] at which the loop becomes unstable.

        Scanned on a logarithmic grid up to ``g_max`` in magnitude and refined by
        bisection; ``±inf`` when the loop stays stable up to ``±g_max``.
        """
        if self.spectral_radius(0.0) >= 1.0:
            return 0.0, 0.0
        out = []
        for sgn in (-1.0, 1.0):
            grid = np.logspace(-9, math.log10(g_max), 181)
            crit = math.inf
            prev = 0.0
            for g in grid:
                if self.spectral_radius(sgn * g) >= 1.0:
                    lo, hi = prev, g
                    for _ in range(60):
                        mid = 0.5 * (lo + hi)
                        if self.spectral_radius(sgn * mid) >= 1.0:
                            hi = mid
                        else:
                            lo = mid
                    crit = hi
                    break
                prev = g
            out.append(sgn * crit)
        return out[0], out[1]

    def gain_factor_margin(self, g_T: float, which: str = "K_v", factor_max: float = 100.0) -> float:
        """Factor on the cascade gain ``which`` (``"K_v"`` or ``"K_p"``) until the loop with the
        torque path ``g_T`` becomes unstable (the cascade's gain margin, with compensation)."""
        if which not in ("K_v", "K_p"):
            raise ParameterError("TorquePathLoop.gain_factor_margin", "which", f"K_v or K_p, got {which!r}")

        def rho(f: float) -> float:
            g = replace(self.gains, **{which: getattr(self.gains, which) * f})
            return TorquePathLoop(self.plant, g, self.t_sc, self.J_model).spectral_radius(g_T)

        if rho(1.0) >= 1.0:
            return 0.0
        lo, hi = 1.0, 1.0
        while rho(hi) < 1.0:
            lo, hi = hi, hi * 1.5
            if hi > factor_max:
                return math.inf
        for _ in range(16):  # bracket width below 1e-4 relative
            mid = 0.5 * (lo + hi)
            if rho(mid) >= 1.0:
                hi = mid
            else:
                lo = mid
        return hi


@dataclass(frozen=True)
class LoopReport:
    """Result of :func:`analyse_torque_path` (all gains in (m/s)/(N·m)).

    Attributes
    ----------
    g_T_max, g_T_min : float
        Largest and smallest torque-path gain of the model over the operating points.
    worst : dict
        Operating point of the largest |g_T| (position, torque, flank, velocity).
    g_crit_neg, g_crit_pos : float
        Critical gains of the lifted loop (instability beyond them).
    gain_margin : float
        Smallest of g_crit_pos / g_T_max and g_crit_neg / g_T_min (≥ 1: stable).
    phase_margin_deg : float
        Phase margin of the torque path at the worst gain [deg]: the smallest phase change
        (lag or lead) at a gain crossover that puts L on −1 (inf: |L| < 1 everywhere).
    spectral_radius_without, spectral_radius_with : float
        Largest |pole| at t_s,c without and with the worst-case torque path.
    decay_rate_without, decay_rate_with : float
        Decay rate of the slowest closed-loop mode, −ln(spectral radius) / t_s,c [1/s].
    K_v_margin_without, K_v_margin_with : float
        Factor on K_v until instability without and with the worst-case torque path.
    stable : bool
        Every operating point gives a stable loop.
    """

    g_T_max: float
    g_T_min: float
    worst: dict[str, float]
    g_crit_neg: float
    g_crit_pos: float
    gain_margin: float
    phase_margin_deg: float
    spectral_radius_without: float
    spectral_radius_with: float
    decay_rate_without: float
    decay_rate_with: float
    K_v_margin_without: float
    K_v_margin_with: float
    stable: bool

    def as_dict(self) -> dict[str, Any]:
        """Plain dict (JSON-ready)."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}

    def violations(
        self, min_gain_margin: float = 10.0, max_decay_loss: float = 0.05, max_kv_margin_loss: float = 0.05
    ) -> list[str]:
        """What the compensated loop misses of the stated margins (empty: all met).

        Parameters
        ----------
        min_gain_margin : float
            Smallest acceptable torque-path gain margin [-] (10 = 20 dB).
        max_decay_loss : float
            Largest acceptable relative loss of the slowest mode's decay rate [-].
        max_kv_margin_loss : float
            Largest acceptable relative loss of the cascade's K_v gain margin [-].
        """
        out = []
        if not self.stable:
            out.append(f"unstable: spectral radius {self.spectral_radius_with:.4f} >= 1 at t_s,c")
        if not self.gain_margin >= min_gain_margin:
            out.append(f"torque-path gain margin {self.gain_margin:.3g} < {min_gain_margin:g}")
        loss = 1.0 - self.decay_rate_with / self.decay_rate_without
        if not loss <= max_decay_loss:
            out.append(f"slowest mode decays {100 * loss:.1f} % slower (limit {100 * max_decay_loss:g} %)")
        kv_loss = 1.0 - self.K_v_margin_with / self.K_v_margin_without
        if not kv_loss <= max_kv_margin_loss:
            lim = 100 * max_kv_margin_loss
            out.append(f"K_v gain margin {100 * kv_loss:.1f} % smaller (limit {lim:g} %)")
        return out


def table_torque_path_gains(
    te: np.ndarray,
    x0: float,
    dx: float,
    torque0: np.ndarray,
    dtorque: np.ndarray,
    velocities: Sequence[float],
    t_sc: float = 5e-3,
) -> dict[str, Any]:
    """Torque-path gain g_T of a bilinear position × torque table at every operating point.

    The table is the compensator's runtime form (:class:`drivelash.te.compensation.TETable`:
    ``te[d, i, j]`` at x = x0 + i dx, T = torque0[d] + j dtorque[d], clamped beyond the
    grid). Within a torque cell ∂TE/∂T is constant in T and piecewise linear in x, so
    ``g_T(x) = (∂TE/∂T(x + Δ) − ∂TE/∂T(x)) / t_s,c`` takes its extremes where x or x + Δ
    is a grid node: those points are evaluated for every torque cell, both flanks and
    both signs of Δ = v t_s,c (a flank may be loaded while the table moves either way).

    Parameters
    ----------
    te, x0, dx, torque0, dtorque
        The table arrays [m], [m], [m], [N·m], [N·m].
    velocities : sequence of float
        Set velocities |v| [m/s] of the look-ahead.
    t_sc : float
        Compensation period [s].

    Returns
    -------
    dict
        ``g_max``, ``g_min`` [(m/s)/(N·m)] and the operating points ``at_max``/``at_min``
        (``x``, ``torque``, ``flank``, ``velocity``).
    """
    te = np.asarray(te, dtype=np.float64)
    n_x, n_t = te.shape[1], te.shape[2]
    xg = x0 + dx * np.arange(n_x)
    best = {"g_max": 0.0, "g_min": 0.0, "at_max": {}, "at_min": {}}
    if n_t < 2:
        return best  # no torque dependence: no torque path
    for d, flank in enumerate((1, -1)):
        S = np.diff(te[d], axis=1) / dtorque[d]  # (n_x, n_t − 1): ∂TE/∂T of each torque cell at the nodes
        tq = torque0[d] + dtorque[d] * (np.arange(n_t - 1) + 0.5)  # cell centres
        for v in velocities:
            for sgn in (1.0, -1.0):
                delta = sgn * abs(float(v)) * t_sc
                xs = np.unique(np.concatenate([xg, xg - delta]))
                xs = xs[(xs >= xg[0]) & (xs <= xg[-1])]
                a = _interp_cols(xs, xg, S)
                b = _interp_cols(xs + delta, xg, S)
                g = (b - a) / t_sc
                for key, fn, cmp in (("g_max", np.argmax, np.greater), ("g_min", np.argmin, np.less)):
                    i, j = np.unravel_index(fn(g), g.shape)
                    if cmp(g[i, j], best[key]):
                        best[key] = float(g[i, j])
                        best["at_max" if key == "g_max" else "at_min"] = {
                            "x": float(xs[i]),
                            "torque": float(tq[j]),
                            "flank": flank,
                            "velocity": float(delta / t_sc),
                        }
    return best


def table_torque_path_gain_at(
    te: np.ndarray,
    x0: float,
    dx: float,
    torque0: np.ndarray,
    dtorque: np.ndarray,
    x: float,
    torque: float,
    flank: int,
    delta: float,
    t_sc: float = 5e-3,
) -> float:
    """g_T [(m/s)/(N·m)] of the table at one operating point: position ``x`` [m], model torque
    ``torque`` [N·m] (inside a torque cell), flank ±1 and look-ahead step ``delta`` [m]."""
    te = np.asarray(te, dtype=np.float64)
    d = 0 if flank > 0 else 1
    n_t = te.shape[2]
    if n_t < 2:
        return 0.0
    u = (torque - torque0[d]) / dtorque[d]
    if u < 0.0 or u > n_t - 1:
        return 0.0  # clamped beyond the torque grid: no torque dependence
    j = min(int(u), n_t - 2)
    S = (te[d, :, j + 1] - te[d, :, j])[:, None] / dtorque[d]
    xg = x0 + dx * np.arange(te.shape[1])
    a, b = _interp_cols(np.array([x, x + delta]), xg, S)[:, 0]
    return float((b - a) / t_sc)


def _interp_cols(x: np.ndarray, xg: np.ndarray, S: np.ndarray) -> np.ndarray:
    """Linear interpolation of every column of S (rows at xg) at x, clamped at the ends."""
    i = np.clip(np.searchsorted(xg, x, side="right") - 1, 0, xg.size - 2)
    f = np.clip((x - xg[i]) / (xg[i + 1] - xg[i]), 0.0, 1.0)[:, None]
    return S[i] * (1.0 - f) + S[i + 1] * f


def analyse_torque_path(
    loop: TorquePathLoop,
    gains_over_model: dict[str, Any],
) -> LoopReport:
    """Close the loop at the model's extreme torque-path gains and report stability and margins.

    Parameters
    ----------
    loop : TorquePathLoop
        The lifted cascade (plant, tuning, t_s,c, J_model).
    gains_over_model : dict
        :func:`table_torque_path_gains` of the model (``g_max``, ``g_min``, ``at_*``).
    """
    import control as ct

    g_max, g_min = float(gains_over_model["g_max"]), float(gains_over_model["g_min"])
    worst_g = g_max if abs(g_max) >= abs(g_min) else g_min
    worst = gains_over_model["at_max" if worst_g == g_max else "at_min"]
    g_neg, g_pos = loop.critical_gains()
    gm = math.inf
    if g_max > 0:
        gm = min(gm, g_pos / g_max)
    if g_min < 0:
        gm = min(gm, g_neg / g_min)
    pm = math.inf
    if worst_g != 0.0:
        if abs(worst_g) * loop.peak_gain() >= 1.0:  # |L| reaches 1: a gain crossover exists
            # every gain crossover; the margin is the smallest phase change, lag or lead, that
            # puts L on −1 (python-control reports 180° + ∠L, which may wrap to a negative value)
            pms = np.atleast_1d(ct.stability_margins(loop.loop_transfer(worst_g), returnall=True,
                                                     method="frd")[1])  # fmt: skip
            pms = np.abs((pms + 180.0) % 360.0 - 180.0)
            pm = float(np.min(pms)) if pms.size else math.inf
    rho0 = loop.spectral_radius(0.0)
    rho_with = max(loop.spectral_radius(g_max), loop.spectral_radius(g_min))
    return LoopReport(
        g_T_max=g_max,
        g_T_min=g_min,
        worst=dict(worst, g_T=worst_g),
        g_crit_neg=float(g_neg),
        g_crit_pos=float(g_pos),
        gain_margin=float(gm),
        phase_margin_deg=pm,
        spectral_radius_without=rho0,
        spectral_radius_with=rho_with,
        decay_rate_without=-math.log(rho0) / loop.t_sc,
        decay_rate_with=-math.log(rho_with) / loop.t_sc if 0.0 < rho_with else math.inf,
        K_v_margin_without=loop.gain_factor_margin(0.0),
        K_v_margin_with=min(loop.gain_factor_margin(g_max), loop.gain_factor_margin(g_min)),
        stable=bool(rho_with < 1.0),
    )
