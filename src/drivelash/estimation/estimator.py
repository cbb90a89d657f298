"""User-facing online deadzone estimator: configuration, tuning rule, :class:`DeadzoneEstimator`.

The numerics live in :mod:`drivelash.estimation.deadzone` (one ``@njit`` kernel with
explicit state); this module chooses the gains, runs traces (whole or in chunks) and turns
the kernel outputs into an :class:`EstimationResult` with an excitation verdict.

Tuning rule (``EstimatorConfig.tuned``), every number in docs/assumptions.md
--------------------------------------------------------------------------
Inputs: J_l, K_S, T_C,l (estimator side), the sample time T_s and the excitation (motion
reversal) frequency f_r — ``estimate`` detects f_r from the recording
(:func:`excitation_frequency`). With ω_r = 2π f_r and ω_n = √(K_S/J_l):

* contact torque scale T_ref = max(T_C,l, 10⁻³ rad · K_S); contact threshold T_thr = T_ref/2;
  typical deflection θ_def = T_ref/K_S; model smoothness α = clip(20/θ_def, 10³, 10⁵) 1/rad;
* STSMO: ρ = (K_S/J_l) · ω_r · 1 rad (rate of change of φ in contact),
  k1 = 1.5 s √ρ, k2 = 1.1 s² ρ (Levant's rule; the chattering this leaves in φ̂ is removed
  by the default law's residual filter), s = min(1, 0.1/(ω_n T_s)) slows the observer when
  the sampling is coarse against the shaft resonance;
* paper law: γ = ω_n/16;
* default law: τ_f = max(2/ω_n, 4 T_s), P_max = 16 ω_r, λ = ω_r/25, ω_c = 10 ω_r,
  stiffness-scale gain q = 0.1; gain reset when the residual stays above 3 θ_def for
  2 τ_f in informative samples;
* excitation window max(2/f_r, 1 s); δ_max = 2 rad, ε_δ = 0.1, δ0 = 0.

Chosen on ``paper-sim`` and the 18 bench scenarios and checked, unchanged, on drives outside
them (N = 3 and 5, other inertias, stiffnesses, deadzones, offsets, encoders, trapezoidal
passes with dwell): tests/estimation/test_acceptance.py.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from typing import Any, Literal

import numpy as np
from numba import njit

from drivelash.errors import DataError, ParameterError
from drivelash.estimation import deadzone as dz
from drivelash.io.trace import Trace
from drivelash.params import BacklashParams, DrivetrainParams

Method = Literal["paper", "default"]
INPUT_COLUMNS = ("theta_m", "omega_m", "theta_l", "omega_l")
#: Least share of the excitation window in which the law must receive information
#: (∫σ dt / window ≥ ε_σ) for ``excitation_ok``.
SIGMA_FRACTION_MIN = 0.01
#: The joint δ/δ1 law replaces the anchored one only if its torque residual (RMS over the
#: last third of the run) is below this fraction of the anchored law's.
OFFSET_RESIDUAL_RATIO = 0.8


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x * x))) if x.size else float("nan")


@dataclass(frozen=True)
class EstimatorConfig:
    """Gains of the online deadzone estimator (never modified by the estimator).

    Parameters
    ----------
    k1 : float
        STSMO proportional gain [rad^½/s^{3/2}].
    k2 : float
        STSMO integral gain [rad/s³].
    gamma : float
        Adaptation rate of the paper's law [1/s] (``method="paper"``).
    delta_max : float
        Radius of the projection ball, upper bound of δ̂ [rad].
    eps_delta : float
        Boundary-layer width ε_δ of the projection [-].
    delta0 : float
        Initial estimate δ̂(t0) [rad] (0 or an underestimate).
    alpha : float
        Smoothness α of the model (11) used by the estimator [1/rad].
    method : {"paper", "default"}
        Plain gradient law of the paper, or the improved default law.
    omega_c : float
        Cut-off of the Δθ complementary filter [rad/s] (default method; 0 = off).
    tau_f : float
        Time constant of the residual/regressor low-pass [s] (default method; 0 = off).
    lam : float
        Leakage rate λ of the least-squares gain towards P0 [1/s] (default method).
    P_max : float
        Initial least-squares gain P0 of δ [1/s] (default method).
    omega_eps : float
        Regularisation velocity of the load-friction sign [rad/s] (default method; 0 = sgn).
    T_thr : float
        Shaft-torque threshold of a contact for the excitation monitor [N·m].
    window : float
        Length of the sliding excitation window [s].
    estimate_stiffness : bool
        Learn the stiffness scale κ = K_S,true/K_S (default method).
    estimate_offset : bool
        Learn δ1 jointly instead of taking it from the configuration (default method).
    q_offset : float
        Gain of δ1 relative to δ's [-] (``estimate_offset``).
    offset_check : bool
        Run the joint δ/δ1 law alongside in :meth:`DeadzoneEstimator.run` and switch to it
        when the data contradict δ1 (default method).
    offset_switch : float
        |δ̂1 − δ1| above which the check may switch [rad].
    theta_def : float
        Typical contact deflection [rad]: scales the initial gain of κ, P0 = q_aux P_max/θ_def².
    q_aux : float
        Gain of κ relative to δ's [-].
    reset_e : float
        Gain reset threshold on the filtered residual, in units of θ_def [-]; 0 = off.
    reset_t : float
        Time the residual must stay beyond it (in informative samples) [s].
    """

    k1: float
    k2: float
    gamma: float
    delta_max: float
    eps_delta: float = 0.1
    delta0: float = 0.0
    alpha: float = 1000.0
    method: Method = "default"
    omega_c: float = 0.0
    tau_f: float = 0.0
    lam: float = 0.5
    P_max: float = 10.0
    omega_eps: float = 0.0
    T_thr: float = 0.01
    window: float = 2.0
    estimate_stiffness: bool = True
    estimate_offset: bool = False
    q_offset: float = 1.0
    offset_check: bool = True
    offset_switch: float = 5e-3
    theta_def: float = 1e-3
    q_aux: float = 0.1
    reset_e: float = 0.0
    reset_t: float = 0.02

    def __post_init__(self) -> None:
        name = type(self).__name__
        for f in (
            "k1",
            "k2",
            "gamma",
            "delta_max",
            "eps_delta",
            "alpha",
            "lam",
            "P_max",
            "T_thr",
            "window",
            "q_offset",
            "offset_switch",
            "reset_t",
            "theta_def",
            "q_aux",
        ):
            v = getattr(self, f)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(name, f, f"must be finite and > 0, got {v!r}")
        for f in ("delta0", "omega_c", "tau_f", "omega_eps", "reset_e"):
            v = getattr(self, f)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ParameterError(name, f, f"must be finite and >= 0, got {v!r}")
        if self.delta0 > self.delta_max:
            raise ParameterError(
                name, "delta0", f"must be <= delta_max = {self.delta_max}, got {self.delta0}"
            )
        if self.method not in ("paper", "default"):
            raise ParameterError(name, "method", f"must be 'paper' or 'default', got {self.method!r}")

    @classmethod
    def tuned(
        cls,
        drivetrain: DrivetrainParams,
        T_s: float,
        f_exc: float = 0.5,
        method: Method = "default",
        delta_max: float | None = None,
        **overrides: Any,
    ) -> EstimatorConfig:
        """Default gains from the documented scaling rule (module docstring).

        Parameters
        ----------
        drivetrain : DrivetrainParams
            Drive-train parameters as known to the estimator.
        T_s : float
            Sample time [s].
        f_exc : float
            Excitation (motion reversal) frequency [Hz].
        method : {"paper", "default"}
            Law to tune.
        delta_max : float, optional
            Upper bound of δ [rad]; default 2 rad.
        **overrides
            Any field of :class:`EstimatorConfig` to set explicitly.
        """
        if not (T_s > 0 and math.isfinite(T_s)):
            raise ParameterError(cls.__name__, "T_s", f"sample time must be > 0, got {T_s!r}")
        if not (f_exc > 0 and math.isfinite(f_exc)):
            raise ParameterError(cls.__name__, "f_exc", f"must be > 0, got {f_exc!r}")
        J_l, K_S = drivetrain.J_l, drivetrain.K_S
        w_r = 2.0 * math.pi * f_exc
        w_n = math.sqrt(K_S / J_l)
        # contact torque scale: friction, or 1 mrad of shaft deflection if frictionless
        T_ref = max(drivetrain.T_Cl, 1e-3 * K_S)
        T_thr = 0.5 * T_ref
        rho = (K_S / J_l) * w_r * 1.0
        # slower observer when the sample time is coarse against the shaft resonance
        s_ts = min(1.0, 0.1 / (w_n * T_s))
        k2 = 1.1 * rho * s_ts * s_ts
        k1 = 1.5 * math.sqrt(rho) * s_ts
        theta_def = T_ref / K_S
        alpha = min(max(20.0 / theta_def, 1e3), 1e5)
        values: dict[str, Any] = dict(
            k1=k1,
            k2=k2,
            gamma=w_n / 16.0,
            delta_max=2.0 if delta_max is None else delta_max,
            eps_delta=0.1,
            delta0=0.0,
            alpha=alpha,
            method=method,
            omega_c=10.0 * w_r,
            tau_f=max(2.0 / w_n, 4.0 * T_s),
            lam=w_r / 25.0,
            P_max=16.0 * w_r,
            omega_eps=0.0,
            T_thr=T_thr,
            window=max(2.0 / f_exc, 1.0),
            theta_def=theta_def,
            reset_e=3.0,
            reset_t=max(2.0 * (2.0 / w_n), 4.0 * T_s),
        )
        values.update({k: v for k, v in overrides.items() if v is not None})
        return cls(**values)

    def to_dict(self) -> dict[str, Any]:
        """Plain dict of the fields (JSON output)."""
        return asdict(self)


def build_params(
    drivetrain: DrivetrainParams, backlash: BacklashParams | float, config: EstimatorConfig, T_s: float
) -> np.ndarray:
    """Parameter array of :func:`~drivelash.estimation.deadzone.deadzone_run`.

    Parameters
    ----------
    drivetrain : DrivetrainParams
        Estimator-side drive-train parameters.
    backlash : BacklashParams or float
        Known offset δ1 [rad] (a :class:`BacklashParams` contributes its ``delta1``; its
        ``delta`` is ignored — that is what is estimated).
    config : EstimatorConfig
        Gains.
    T_s : float
        Sample time [s].
    """
    delta1 = backlash.delta1 if isinstance(backlash, BacklashParams) else float(backlash)
    p = np.zeros(dz.N_PARAMS)
    p[dz.P_J_L] = drivetrain.J_l
    p[dz.P_N] = drivetrain.N
    p[dz.P_K_S] = drivetrain.K_S
    p[dz.P_D_S] = drivetrain.D_S
    p[dz.P_T_CL] = drivetrain.T_Cl
    p[dz.P_BETA_L] = drivetrain.beta_l
    p[dz.P_DELTA1] = delta1
    p[dz.P_ALPHA] = config.alpha
    p[dz.P_K1] = config.k1
    p[dz.P_K2] = config.k2
    p[dz.P_GAMMA] = config.gamma
    p[dz.P_DELTA_MAX] = config.delta_max
    p[dz.P_EPS_DELTA] = config.eps_delta
    p[dz.P_TS] = T_s
    p[dz.P_METHOD] = 1.0 if config.method == "default" else 0.0
    p[dz.P_OMEGA_C] = config.omega_c
    p[dz.P_TAU_F] = config.tau_f
    p[dz.P_LAMBDA] = config.lam
    p[dz.P_P_MAX] = config.P_max
    p[dz.P_OMEGA_EPS] = config.omega_eps
    p[dz.P_T_THR] = config.T_thr
    p[dz.P_WINDOW] = max(1, int(round(config.window / T_s)))
    p[dz.P_EST_K] = 1.0 if config.estimate_stiffness else 0.0
    p[dz.P_EST_D1] = 1.0 if config.estimate_offset else 0.0
    p[dz.P_Q_D1] = config.q_offset
    p[dz.P_THETA_DEF] = config.theta_def
    p[dz.P_Q_AUX] = config.q_aux
    p[dz.P_RESET_E] = config.reset_e
    p[dz.P_RESET_T] = config.reset_t
    return dz.derive_params(p)


@dataclass
class EstimationResult:
    """Outputs of a run and the excitation verdict.

    Attributes
    ----------
    t : numpy.ndarray
        Time [s].
    delta_hat : numpy.ndarray
        δ̂(t) [rad].
    phi_hat : numpy.ndarray
        φ̂(t) [rad/s²].
    omega_l_hat : numpy.ndarray
        ω̂_l(t) [rad/s].
    sigma_window : numpy.ndarray
        ∫σ dt over the sliding window ending at t [s].
    dtheta : numpy.ndarray
        Δθ used by the law (reconstructed in the default method) [rad].
    torque_hat : numpy.ndarray
        T_l(x, δ̂) of the estimator's model [N·m].
    torque_meas : numpy.ndarray
        J_l φ̂, the observed shaft torque [N·m].
    traversals : numpy.ndarray
        Running count of contact-side changes [-].
    excitation_ok : bool
        Enough excitation to trust the estimate.
    reason : str
        Plain-language explanation of the verdict.
    converged : bool
        ``excitation_ok`` and δ̂ settled over the last window.
    convergence_time_s : float or None
        First time after which δ̂ stays in the band around its final value (or the truth,
        when known) [s].
    band : float
        Band used for ``convergence_time_s`` [rad].
    config : EstimatorConfig
        Gains used.
    """

    t: np.ndarray
    delta_hat: np.ndarray
    phi_hat: np.ndarray
    omega_l_hat: np.ndarray
    sigma_window: np.ndarray
    dtheta: np.ndarray
    torque_hat: np.ndarray
    torque_meas: np.ndarray
    traversals: np.ndarray
    excitation_ok: bool
    reason: str
    converged: bool
    convergence_time_s: float | None
    band: float
    config: EstimatorConfig
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def delta(self) -> float:
        """Final estimate δ̂ [rad]."""
        return float(self.delta_hat[-1]) if self.delta_hat.size else float("nan")


@njit(cache=True)
def _reversals(x, h):
    """Schmitt-trigger reversal detector on a position signal.

    A reversal is counted when ``x`` retreats by more than ``h`` from its running extreme
    in the current direction. Returns (count, index of the first reversal's extreme,
    index of the last one's); −1 indices when there is none.
    """
    n = x.shape[0]
    if n == 0:
        return 0, -1, -1
    direction = 0  # +1 rising, −1 falling, 0 not yet known
    i_ext = 0
    x_ext = x[0]
    x_min = x[0]
    x_max = x[0]
    i_min = 0
    i_max = 0
    count = 0
    first = -1
    last = -1
    for i in range(1, n):
        v = x[i]
        if direction == 0:
            if v > x_max:
                x_max = v
                i_max = i
            if v < x_min:
                x_min = v
                i_min = i
            if x_max - x_min > h:
                if i_max > i_min:
                    direction = 1
                    x_ext = x_max
                    i_ext = i_max
                else:
                    direction = -1
                    x_ext = x_min
                    i_ext = i_min
            continue
        if direction > 0:
            if v > x_ext:
                x_ext = v
                i_ext = i
            elif x_ext - v > h:
                count += 1
                if first < 0:
                    first = i_ext
                last = i_ext
                direction = -1
                x_ext = v
                i_ext = i
        else:
            if v < x_ext:
                x_ext = v
                i_ext = i
            elif v - x_ext > h:
                count += 1
                if first < 0:
                    first = i_ext
                last = i_ext
                direction = 1
                x_ext = v
                i_ext = i
    return count, first, last


#: Hysteresis of the reversal detector, as a fraction of the motor's total travel.
REVERSAL_HYSTERESIS = 0.1


def excitation_frequency(trace: Trace, default: float = 0.5, N: float = 1.0) -> float:
    """Motion-reversal frequency of a recording [Hz], from the motor position.

    Reversals of θ_m are detected with a hysteresis of :data:`REVERSAL_HYSTERESIS` of its
    total travel (position, not velocity: noise at standstill does not count), and the
    frequency is (reversals − 1) / (2 · time between the first and the last). ``default``
    when fewer than three reversals are found.

    Parameters
    ----------
    trace : Trace
        Needs ``t`` and ``theta_m``.
    default : float
        Value returned for (nearly) unidirectional motion [Hz].
    N : float
        Gear ratio (the result does not depend on it; kept for symmetry with the estimator).
    """
    x = np.ascontiguousarray(trace["theta_m"], dtype=np.float64) / N
    t = trace["t"]
    if x.size < 3:
        return default
    h = REVERSAL_HYSTERESIS * float(np.ptp(x))
    if not h > 0:
        return default
    count, first, last = _reversals(x, h)
    if count < 3 or last <= first:
        return default
    return float((count - 1) / (2.0 * (t[last] - t[first])))


def _samples_from_trace(trace: Trace) -> np.ndarray:
    missing = [c for c in INPUT_COLUMNS if c not in trace]
    if missing:
        raise DataError(f"missing column(s) {', '.join(missing)} needed by the estimator", column=missing[0])
    data = np.column_stack([trace[c] for c in INPUT_COLUMNS])
    bad = ~np.isfinite(data)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise DataError("value is not finite (NaN or inf)", column=INPUT_COLUMNS[col], row=int(row))
    return np.ascontiguousarray(data)


class DeadzoneEstimator:
    """Online deadzone estimator: STSMO + adaptive law, chunk-able.

    Parameters
    ----------
    drivetrain : DrivetrainParams
        Drive-train parameters as known to the estimator.
    backlash : BacklashParams or float
        Known offset δ1 [rad] (``delta`` of a BacklashParams is not used).
    T_s : float
        Sample time [s].
    config : EstimatorConfig, optional
        Gains; default :meth:`EstimatorConfig.tuned` with ``f_exc``.
    f_exc : float
        Excitation frequency for the default tuning [Hz].

    Examples
    --------
    >>> est = DeadzoneEstimator(drivetrain, bl, T_s=125e-6)          # doctest: +SKIP
    >>> result = est.run(trace)                              # doctest: +SKIP
    >>> result.delta, result.excitation_ok                   # doctest: +SKIP
    """

    def __init__(
        self,
        drivetrain: DrivetrainParams,
        backlash: BacklashParams | float,
        T_s: float,
        config: EstimatorConfig | None = None,
        f_exc: float = 0.5,
    ) -> None:
        self.drivetrain = drivetrain
        self.delta1 = backlash.delta1 if isinstance(backlash, BacklashParams) else float(backlash)
        if not (math.isfinite(self.delta1) and self.delta1 >= 0):
            raise ParameterError("BacklashParams", "delta1", f"must be finite and >= 0, got {self.delta1!r}")
        self.T_s = float(T_s)
        self.config = config if config is not None else EstimatorConfig.tuned(drivetrain, T_s, f_exc)
        self.params = build_params(drivetrain, self.delta1, self.config, self.T_s)
        self.state = dz.initial_state(self.params, self.config.delta0)
        self._check_params: np.ndarray | None = None
        self._check_state: np.ndarray | None = None
        c = self.config
        if c.method == "default" and not c.estimate_offset and c.offset_check:
            self._check_params = build_params(
                drivetrain, self.delta1, replace(c, estimate_offset=True), self.T_s
            )
            self._check_state = dz.initial_state(self._check_params, c.delta0)
        self._row = np.empty((1, dz.N_OUT))

    def reset(self) -> None:
        """Back to δ̂ = δ0 and zero observer state."""
        self.state = dz.initial_state(self.params, self.config.delta0)
        if self._check_params is not None:
            self._check_state = dz.initial_state(self._check_params, self.config.delta0)

    def step(self, sample: np.ndarray | tuple[float, float, float, float]) -> np.ndarray:
        """Process one sample (θ_m, ω_m, θ_l, ω_l); returns the output row (see ``deadzone_run``)."""
        s = sample
        dz.deadzone_step(
            self.state, float(s[0]), float(s[1]), float(s[2]), float(s[3]), self.params, self._row, 0
        )
        return self._row[0].copy()

    def run_samples(self, samples: np.ndarray) -> np.ndarray:
        """Process a block of samples, shape (n, 4); returns outputs (n, 8) and keeps the state."""
        samples = np.ascontiguousarray(samples, dtype=np.float64)
        self.state, out = dz.deadzone_run(self.state, samples, self.params)
        return out

    def run(
        self, trace: Trace, chunk: int | None = None, delta_true: np.ndarray | None = None
    ) -> EstimationResult:
        """Estimate over a whole trace from the current state (chunked internally if asked).

        Parameters
        ----------
        trace : Trace
            Needs ``theta_m``, ``omega_m``, ``theta_l``, ``omega_l``; ``delta_true`` is used
            for the convergence time when present.
        chunk : int, optional
            Process in blocks of this many samples (same result as one block).
        delta_true : numpy.ndarray, optional
            True δ(t) [rad]; default the trace's ``delta_true`` column if any.
        """
        samples = _samples_from_trace(trace)
        t = trace["t"]
        if t.size >= 2 and not np.all(np.diff(t) > 0):
            row = int(np.argmax(~(np.diff(t) > 0))) + 1
            raise DataError("time is not strictly increasing", column="t", row=row)
        if chunk is None or chunk <= 0:
            out = self.run_samples(samples)
        else:
            out = np.concatenate(
                [self.run_samples(samples[i : i + chunk]) for i in range(0, len(samples), chunk)]
            )
        if delta_true is None and "delta_true" in trace:
            delta_true = trace["delta_true"]
        res = make_result(t, out, self.config, self.params, delta_true, samples=samples)
        if self.config.method == "default":
            res.extra["stiffness_scale"] = float(self.state[dz.S_TH + 1])
            if self.config.estimate_offset:
                res.extra["delta1_estimate"] = float(self.state[dz.S_TH + 2])
        if self._check_params is not None and self._check_state is not None:
            res = self._offset_check(res, samples, t, delta_true)
        return res

    def _offset_check(
        self, res: EstimationResult, samples: np.ndarray, t: np.ndarray, delta_true: np.ndarray | None
    ) -> EstimationResult:
        """Run the joint δ/δ1 law alongside; switch to it when the data disagree with δ1.

        The anchored law (δ1 from the configuration) is the more accurate one when δ1 is right
        (a friction or stiffness error shifts both contact points and the joint law follows);
        when δ1 is wrong — or the two encoders' zeros are offset — its δ̂ is off by the same
        amount. If the joint law's δ̂1 differs from the configured δ1 by more than
        ``offset_switch`` the result is the joint law's, with the reason saying so.
        """
        from scipy.ndimage import uniform_filter1d

        assert self._check_params is not None and self._check_state is not None
        self._check_state, out_j = dz.deadzone_run(self._check_state, samples, self._check_params)
        d1_joint = float(self._check_state[dz.S_TH + 2])
        diff = d1_joint - self.delta1
        res.extra["delta1_check"] = d1_joint
        if abs(diff) <= self.config.offset_switch:
            return res
        cfg_j = replace(self.config, estimate_offset=True)
        res_j = make_result(t, out_j, cfg_j, self._check_params, delta_true, samples=samples)
        # model selection: the joint law must also explain the shaft torque clearly better
        # over the last third (same observed torque, so the difference is the model's)
        k0 = 2 * len(t) // 3
        kap_a = float(self.state[dz.S_TH + 1])
        kap_j = float(self._check_state[dz.S_TH + 1])
        m = max(1, int(round(max(self.config.tau_f, 4 * self.T_s) / self.T_s)))  # chattering out
        r_a = _rms(uniform_filter1d(res.torque_meas[k0:] - kap_a * res.torque_hat[k0:], m))
        r_j = _rms(uniform_filter1d(res_j.torque_meas[k0:] - kap_j * res_j.torque_hat[k0:], m))
        res.extra["residual_rms_anchored"] = r_a
        res.extra["residual_rms_joint"] = r_j
        if not res_j.excitation_ok or not r_j < OFFSET_RESIDUAL_RATIO * r_a:
            return res
        res_j.extra.update(
            stiffness_scale=float(self._check_state[dz.S_TH + 1]),
            delta1_estimate=d1_joint,
            delta1_check=d1_joint,
            offset_switched=True,
            residual_rms_anchored=r_a,
            residual_rms_joint=r_j,
        )
        res_j.reason += (
            f"; the data put the lower contact {1e3 * diff:+.1f} mrad from the configured δ1 "
            "(wrong δ1 or an offset between the encoders), so δ and δ1 were estimated jointly"
        )
        return res_j


def _kinematics(samples: np.ndarray, N: float, T_s: float) -> dict[str, float]:
    """Load and motor travel (load-side units) and number of motor-velocity reversals."""
    th_m = samples[:, 0] / N
    th_l = samples[:, 2]
    w_m = samples[:, 1]
    motor_range = float(np.ptp(th_m)) if th_m.size else 0.0
    load_range = float(np.ptp(th_l)) if th_l.size else 0.0
    del w_m
    rev = 0
    if motor_range > 0:
        rev = int(_reversals(np.ascontiguousarray(th_m), REVERSAL_HYSTERESIS * motor_range)[0])
    return {"motor_range": motor_range, "load_range": load_range, "reversals": float(rev)}


def make_result(
    t: np.ndarray,
    out: np.ndarray,
    config: EstimatorConfig,
    params: np.ndarray,
    delta_true: np.ndarray | None = None,
    band: float | None = None,
    samples: np.ndarray | None = None,
) -> EstimationResult:
    """Wrap kernel outputs into an :class:`EstimationResult` with the excitation verdict."""
    from drivelash.metrics import convergence_time

    T_s = float(params[dz.P_TS])
    n = out.shape[0]
    delta_hat = out[:, dz.O_DELTA].copy()
    sigma_win = out[:, dz.O_SIGMA_WIN].copy()
    trav = out[:, dz.O_TRAV].copy()
    n_trav = int(trav[-1]) if n else 0
    win = config.window
    duration = n * T_s
    sigma_frac = float(sigma_win[-1] / win) if n else 0.0
    tq = out[:, dz.O_TORQUE_MEAS]
    peak_tq = float(np.max(np.abs(tq[n // 10 :]))) if n else 0.0
    kin = _kinematics(samples, float(params[dz.P_N]), T_s) if samples is not None else {}
    if n == 0 or duration < win:
        ok, reason = (
            False,
            f"recording of {duration:.3g} s is shorter than the excitation window of {win:.3g} s",
        )
    elif kin and kin["load_range"] < 0.1 * kin["motor_range"] and kin["motor_range"] > 0:
        ok = False
        reason = (
            f"no engagement: the load moved {kin['load_range']:.3g} rad while the motor moved "
            f"{kin['motor_range']:.3g} rad (load side) — the motion stays inside the deadzone"
        )
    elif kin and kin["reversals"] < 2:
        ok = False
        reason = (
            "the motion never reverses (unidirectional): only one contact side is seen, "
            "so the gap cannot be measured; a back-and-forth motion is needed"
        )
    elif n_trav < 2:
        if peak_tq < config.T_thr:
            reason = (
                "no engagement: the shaft torque never exceeded the contact threshold "
                f"({config.T_thr:.3g} N·m) — the motion seems to stay inside the deadzone"
            )
        else:
            reason = (
                "the motion never reverses through the deadzone (contact on one side only); "
                "a reversing motion is needed to see the gap"
            )
        ok = False
    elif sigma_frac < SIGMA_FRACTION_MIN:
        ok = False
        reason = (
            f"too little excitation in the last {win:.3g} s: the estimate received information "
            f"during {100 * sigma_frac:.1f} % of it (needs {100 * SIGMA_FRACTION_MIN:g} %)"
        )
    else:
        ok = True
        reason = (
            f"{n_trav} traversals of the deadzone; information during "
            f"{100 * sigma_frac:.0f} % of the last window"
        )
    if band is None:
        band = max(2e-3, 0.02 * float(np.max(delta_hat))) if n else 2e-3
    ref = delta_true if delta_true is not None else (np.full(n, delta_hat[-1]) if n else delta_hat)
    conv = convergence_time(t, delta_hat, ref, band) if n else None
    converged = False
    if ok and n:
        k = max(1, int(round(win / T_s)))
        recent = delta_hat[-k:]
        converged = bool(np.max(recent) - np.min(recent) <= band)
    if not ok:
        conv = None
    return EstimationResult(
        t=np.asarray(t),
        delta_hat=delta_hat,
        phi_hat=out[:, dz.O_PHI].copy(),
        omega_l_hat=out[:, dz.O_OMEGA_HAT].copy(),
        sigma_window=sigma_win,
        dtheta=out[:, dz.O_DTHETA].copy(),
        torque_hat=out[:, dz.O_TORQUE_HAT].copy(),
        torque_meas=tq.copy(),
        traversals=trav,
        excitation_ok=ok,
        reason=reason,
        converged=converged,
        convergence_time_s=conv,
        band=band,
        config=config,
        extra={"traversals": n_trav, "sigma_fraction": sigma_frac, **kin},
    )


def with_method(config: EstimatorConfig, method: Method) -> EstimatorConfig:
    """Copy of ``config`` with another ``method``."""
    return replace(config, method=method)
