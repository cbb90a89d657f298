"""User-facing online deadzone estimator: configuration, tuning rule, streaming run, verdict.

The numerics live in :mod:`drivelash.estimation.deadzone` (one ``@njit`` kernel with
explicit state); this module chooses the gains, runs recordings in blocks (whole traces and
files larger than memory alike) and turns the kernel's state and outputs into an
:class:`EstimationResult` with an excitation verdict, plausibility checks, a δ1 check and an
uncertainty. Every number is in docs/assumptions.md (backlash estimator).

:class:`~drivelash.params.EstimatorConfig` (the gains, re-exported here) lives in
:mod:`drivelash.params` with the other parameter dataclasses, so that the configuration
schema (:mod:`drivelash.io.config`, table ``[estimator]``) is generated from it.

Two passes (:func:`estimate_blocks`)
-----------------------------------
1. :class:`~drivelash.estimation.motion.MotionScanner` over θ_m, θ_l and the motor torque:
   reversal frequency f_r, travel, torque RMS (cheap; decimated by global sample index).
2. The kernel, block by block, twice in lockstep: the chosen law and the *δ1 check* (the
   default law with δ1 estimated jointly and the stiffness scale held at 1), each sample
   observed once for both when they observe alike (``deadzone_run2_into``). Everything the
   verdict needs is accumulated while streaming — kernel sums over the last third, Δθ range,
   traversal counters, per-block min/max of δ̂ (:data:`HISTORY_BLOCKS` blocks) — so a file
   read in chunks and the same data in memory give the same result.

Tuning rule (``EstimatorConfig.tuned``)
--------------------------------------
Inputs: J_l, K_S, T_C,l (estimator side), T_s, f_r and, when known, the recording's motion
(:class:`~drivelash.estimation.motion.MotionSummary`). With ω_r = 2π f_r, ω_n = √(K_S/J_l):

* shaft-torque source: the motor side (−N J_m φ̂_m from the recorded motor torque) when the
  recording has ``torque_m`` and the method is the default one, else the load observer J_l φ̂;
* contact torque scale T_ref = min(max(T_C,l, 10⁻³ rad · K_S), T_data), T_data = N · RMS(u)
  (motor source) or J_l a_typ + T_C,l + β_l v_typ from the motion (load source); contact
  threshold T_thr = T_ref/2; typical deflection θ_def = T_ref/K_S; α = clip(20/θ_def, 10³, 10⁵);
* STSMO: ρ = (K_S/J_l) · ω_r · 1 rad, k1 = 1.5 s √ρ, k2 = 1.1 s² ρ, s = min(1, 0.1/(ω_n T_s));
  motor side likewise with ρ_m = K_S ω_r/(N J_m), ω_n,m = √(K_S/(N² J_m));
* paper law: γ = ω_n/16;
* default law: τ_f = max(2/ω_n, 4 T_s), P_max = min(16 ω_r, ω_n), λ = ω_r/25, ω_c = 10 ω_r,
  stiffness-scale gain q = 0.1; gain reset when the residual stays above 3 θ_def for 2 τ_f
  in informative samples; gap offset learning at rate ω_r above 5 % of v_typ;
* excitation window max(2/f_r, 1 s); δ_max = 2 rad, ε_δ = 0.1, δ0 = 0;
* angle scale σ = min(1, Δθ range / 10 mrad) ≥ 10⁻⁴ (:func:`~drivelash.params.angle_scale_of`):
  every absolute angle above (10⁻³ rad in T_ref, α's bounds, the 1 rad of ρ) and in the
  verdict (2 mrad band and claim, 1 mrad δ1 floor, 50 mrad range excess) is multiplied by it,
  so a recording in m or of a precision gearbox is tuned as one in rad of a 10 mrad Δθ range;
  the verdict's band, claim and δ1 floor use σ capped by δ̂ / 10 mrad
  (:func:`~drivelash.params.verdict_scale`), so they stay within 20 % / 10 % of a small gap
  whose contact deflection widens the Δθ range.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np

from drivelash.errors import DataError, ParameterError
from drivelash.estimation import deadzone as dz
from drivelash.estimation.motion import (
    REVERSAL_HYSTERESIS,
    MotionScanner,
    MotionSummary,
    excitation_frequency,
    scan_trace,
)
from drivelash.io.trace import Trace
from drivelash.params import (
    ANGLE_SCALE_RANGE,
    OFFSET_FLOOR,
    BacklashParams,
    DrivetrainParams,
    EstimatorConfig,
    Method,
    check_delta1_bound,
    delta1_outside_range,
    delta1_tolerance,
    is_real_number,
    rounded_delta1,
    verdict_scale,
)
from drivelash.units import gap_unit

__all__ = [
    "INPUT_COLUMNS",
    "REVERSAL_HYSTERESIS",
    "DeadzoneEstimator",
    "Delta1Uncertainty",
    "EstimationResult",
    "EstimatorConfig",
    "MotionSummary",
    "build_params",
    "check_sample_period",
    "estimate_blocks",
    "excitation_frequency",
    "series_step",
    "trace_blocks",
]

INPUT_COLUMNS = ("theta_m", "omega_m", "theta_l", "omega_l")
#: Optional column: the recorded motor torque [N·m] (shaft torque from the motor side).
TORQUE_COLUMN = "torque_m"
#: Least information in the excitation window for ``excitation_ok``: ∫g² dt / window ≥ ε_σ,
#: g = ∂T_l/∂δ / K_S (≈ 1 in the upper contact, 0 in the gap, larger at the contact edges — so
#: the figure is no share of time and may exceed 1; it was printed as "% of the window" until
#: session 12).
SIGMA_FRACTION_MIN = 0.01

#: Δθ = θ_m/N − θ_l spanning less than this share of the motor's (load-side) range over the
#: whole run is "the same signal": the load position is the motor's own channel, or nothing
#: between the encoders moves (session 31 tester C, C14 d; a real drive's Δθ spans at least its
#: encoders' counts and deflection, ≥ 1e-4 of the range; rounding of θ_m/N − θ_l ≈ 1e-16).
DTH_SAME_SIGNAL = 1e-9
#: δ1 check: the joint law replaces the anchored one only if its residual (RMS of the filtered
#: torque residual over the last third) is below this fraction of the anchored law's.
OFFSET_RESIDUAL_RATIO = 0.8
#: δ1 check: … and exceed this multiple of the mean contact deflection (what a wrong torque
#: model can move a contact point by) …
OFFSET_DEFLECTION_FACTOR = 2.0
#: … and the anchored law's lower/upper residual ratio must exceed the joint law's by this
#: factor; a joint law whose own lower/upper ratio lies outside [1/this, this] cannot judge δ1.
OFFSET_BALANCE = 1.5
#: A joint law that cannot judge δ1 (balance outside the above) still bounds δ̂: when its δ1 lies
#: beyond the floor from the configured one, its δ widens the interval — if its own lower/upper
#: residual ratio lies within [1/this, this] (OFFSET_BALANCE²). Measured: bench-0B 10 s, seeds 3 and
#: 11, δ1 −5 … +5 mrad or a 10 mrad load-encoder zero: 1.57–1.87 (1.54 / 1.80 with the true δ1,
#: so this recording's own level); a random drive of test_generalisation (seed 1, case 10) with its
#: true δ1: 6.8, joint δ1 3.9 mrad off — no alternative (docs/assumptions.md).
OFFSET_BALANCE_ALTERNATIVE = OFFSET_BALANCE**2
#: δ̂ this close to δ_max (fraction) is at its projection bound.
BOUND_FRACTION = 0.98
#: Δθ can span at most the gap plus the two contact deflections: δ̂ is called too small when the
#: observed Δθ range exceeds δ̂ + 2 D_peak by more than this many peak deflections D_peak …
RANGE_EXCESS_FACTOR = 20.0
#: … and by more than this [rad]. On the 8 bench scenarios checked (full length and 4 s, both
#: laws) the excess was at most 12 mrad and 6.2 D_peak (start transients, noise peaks of the
#: fused Δθ); a wrong δ1 of bench-0B's 93 mrad on bench-0A gave 439 mrad (docs/assumptions.md).
RANGE_EXCESS_MIN = 0.05
#: κ this close to its bounds [¼, 4] is at its bound (the data disagree with the stated K_S).
KAPPA_LIMITS = (0.26, 3.9)
#: Resolution floor of the uncertainty, in units of the contact deflection θ_def.
UNCERTAINTY_FLOOR = 0.1
#: Number of blocks of the δ̂ min/max history (convergence time and settling, streaming).
HISTORY_BLOCKS = 4096
#: Rows kept of the output series when streaming (plots and reports).
SERIES_POINTS = 20000
#: Samples per block when a whole trace is run (the same blocks as a streamed file).
BLOCK = 1 << 16
#: Correlation of the motor torque with Δθ below −this is refused as swapped channels or a wrong
#: sign (:attr:`MotionSummary.torque_deflection_corr`; docs/assumptions.md).
SWAP_CORRELATION = 0.2
#: … judged only over a motion that reversed at least this often (one back-and-forth, the least
#: the excitation verdict needs to measure the gap): before its first reversal a correct
#: recording's start-up (the motor accelerating the load through the gap) correlates negatively
#: (bench-0B/2C/5B first 0.25–0.5 s: −0.46 … −0.50), after two reversals every correct bench
#: run checked is ≥ +0.38 and a swapped or sign-flipped one ≤ −0.38 (docs/assumptions.md).
SWAP_MIN_REVERSALS = 2
#: Lowest sample rate [Hz] at which the online 95 % interval was measured to hold the truth: the
#: 18 bench scenarios sliced to 2 kHz 18/18, to 1 kHz 14/18 (9/18 before session 36; δ̂
#: 0.27–0.57 mrad low on the small gaps;
#: tests/estimation/test_online_rate.py, docs/assumptions.md "Online estimate at 1 kHz"). Below
#: it the result carries a note (not blocking: δ̂ met the 1 mrad goal at 1 kHz with the true
#: parameters) that states no signed bias: with identified parameters bench-0B at 1 kHz ran
#: 1.04 mrad *high* (session 30, tester A M5).
ONLINE_VERIFIED_RATE_HZ = 2000.0
#: Below :data:`ONLINE_VERIFIED_RATE_HZ` an estimate is called converged only with at least this
#: excitation information (∫g² dt / window; 10× :data:`SIGMA_FRACTION_MIN`): the sampled sum of
#: g² under-resolves the contact-edge peak of g (width ~1/α), which a stated K_S too stiff makes
#: narrow and dominant. Measured (session 32 tester F, F6): bench-0B 10 s with K_S stated 6×,
#: information 0.0100 at 8 kHz, 0.0068 at 2 kHz (insufficient) but 0.0217 at 1 kHz ("converged"
#: 3.09 mrad off, ±0.75); the 18 bench scenarios with their true parameters at 500 Hz–2 kHz have
#: ≥ 0.254 (2.5× above), a mismatch scan (0A/0B/0C × 3 seeds × K_S ×¼…8, 1 kHz) has every other
#: converged run at ≥ 0.25 (docs/assumptions.md, "Online estimate at 1 kHz").
LOW_RATE_INFORMATION_MIN = 0.1
#: Smallest convergence band [rad] (× the verdict scale σ_δ, :func:`~drivelash.params.verdict_scale`:
#: the angle scale σ capped by δ̂ / 10 mrad): δ̂ settled when it varied by ≤ max(this σ_δ, 2 % of
#: δ̂) over the last window (issue 11).
BAND_FLOOR = 2e-3
#: The angle constants mismatch the recording when its Δθ range is below this fraction of the
#: range they were scaled for (ANGLE_SCALE_RANGE × σ): at the smallest σ, or with gains tuned
#: without the recording (a given configuration). A blocking warning names it (C8, session 31).
ANGLE_SCALE_MISMATCH = 0.5
#: Largest 95 % half-width [rad] (× σ_δ, as the band) with which an estimate may be called
#: converged: the accuracy the tool promises when it says "converged" (issue 11: |δ̂ − δ| ≤ 2 mrad
#: or flagged; at most 20 % of a δ̂ below 10 mrad × σ, session 35).
CLAIM_HALF_WIDTH = 2e-3
#: Model part of the uncertainty for the switched joint δ/δ1 law with the load-observer torque,
#: relative to the anchored law's D·|1 − 1/κ| (both contact points from the model, not one).
SWITCHED_MODEL_FACTOR = 2.0
#: How far the anchored default law's δ̂ can move per unit offset of Δθ (encoder reading
#: convention) when it learns the stiffness scale κ: once directly, up to once more through κ.
ENCODER_OFFSET_GAIN_KAPPA = 2.0
#: A constant load torque on the load is reported when the motor-side and load-side shaft
#: torques differ on average by more than this fraction of the mean contact torque.
LOAD_TORQUE_FRACTION = 0.2
#: Largest relative difference between an estimator's sample time T_s and a recording's sample
#: period (mean interval, the one :func:`estimate_blocks` tunes and integrates with) that still
#: counts as the same rate: a logger's nominal rate against its recorded stamps, e.g. the EMPS
#: logger (1 ms nominal, median interval 1.6e-5 below it); distinct rates (8 vs 10 kHz, 1 vs
#: 1.024 kHz) lie ≥ 2.4 % apart. docs/assumptions.md, "Estimator T_s against a recording".
T_S_RTOL = 1e-3


def check_sample_period(T_s: float, period: float, owner: str, median: float | None = None) -> None:
    """Refuse an estimator's sample time that is not the recording's sample period.

    Parameters
    ----------
    T_s : float
        The estimator's sample time [s] (what it was built for).
    period : float
        The recording's sample period [s] (mean interval, as :class:`MotionSummary` has it).
    owner : str
        Name for the message, e.g. ``"DeadzoneEstimator"``.
    median : float, optional
        The recording's median interval [s] (``Trace.T_s``, what the message tells users to
        build the estimator with): a ``T_s`` within :data:`T_S_RTOL` of it is taken as well.
        A recording whose intervals vary within the loader's jitter tolerance (e.g. every
        4th one 1 % long) has a mean 0.25 % above its median; built with ``T_s=trace.T_s``
        as told, it was refused.

    Raises
    ------
    ParameterError
        ``T_s`` within :data:`T_S_RTOL` (relative) of neither ``period`` nor ``median``: one
        line naming the periods.
    """
    if abs(T_s - period) <= T_S_RTOL * period:
        return
    if median is not None and abs(T_s - median) <= T_S_RTOL * median:
        return
    also = "" if median is None or median == period else f", median interval {median:.6g} s"
    raise ParameterError(
        owner,
        "T_s",
        f"{T_s:.6g} s differs from the trace's sample period {period:.6g} s (mean interval{also}) by"
        f" more than {T_S_RTOL:.1%}; build the estimator with T_s=trace.T_s",
    )


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x * x))) if x.size else float("nan")


def build_params(
    drivetrain: DrivetrainParams,
    backlash: BacklashParams | float,
    config: EstimatorConfig,
    T_s: float,
    k0: int = 0,
    axis: str | None = None,
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
    k0 : int
        First sample index of the verdict accumulators (the last third of a run).
    axis : {"rotary", "prismatic"}, optional
        The recording's axis kind: a δ1 beyond δ_max is named in m and read as µm on a prismatic one.
    """
    delta1 = backlash.delta1 if isinstance(backlash, BacklashParams) else float(backlash)
    check_delta1_bound("DeadzoneEstimator", delta1, config.delta_max, axis)
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
    p[dz.P_TSRC] = 1.0 if config.torque_source == "motor" else 0.0
    p[dz.P_J_M] = drivetrain.J_m
    p[dz.P_T_CM] = drivetrain.T_Cm
    p[dz.P_BETA_M] = drivetrain.beta_m
    p[dz.P_K1M] = config.k1_m
    p[dz.P_K2M] = config.k2_m
    p[dz.P_LAM_G] = config.lam_g
    p[dz.P_OMEGA_G] = config.omega_g
    p[dz.P_GAP_M] = config.gap_margin
    p[dz.P_K0] = float(k0)
    p[dz.P_BOUND] = 1.0 if config.contact_bound else 0.0
    return dz.derive_params(p)


@dataclass(frozen=True)
class Delta1Uncertainty:
    """An uncertain δ1 given to the online law, and δ̂ at δ1 shifted by its standard error.

    ``estimate --identify`` supplies δ1 from the offline identification when ``[backlash]
    delta1`` is absent; the anchored law does not correct a δ1 offset, so δ̂ moves with δ1
    (geared drive at 250 Hz: about 1.9 mrad per mrad below the identified δ1, 0.9 above). The
    sensitivity is measured, not assumed: the caller reruns the online law with δ1 + ``std`` and
    δ1 − ``std`` (not below 0) and passes the two δ̂; :func:`_verdict` takes the larger of the two
    one-sided changes per unit shift as ∂δ̂/∂δ1 (the response is not symmetric) and adds
    |∂δ̂/∂δ1|·``std`` to δ̂'s standard uncertainty in quadrature (docs/assumptions.md).

    Attributes
    ----------
    std : float
        Standard uncertainty of δ1 [rad] (the identification's standard error).
    shifted : tuple of (float, float)
        ``(shift, delta)`` pairs: the δ1 shift [rad] of a rerun and its final δ̂ [rad] (NaN when
        the rerun gave none). Pairs with a zero shift or a NaN δ̂ are not used.
    source : str
        Where δ1 came from, for the warning (``"the identification"``).
    """

    std: float
    shifted: tuple[tuple[float, float], ...] = ()
    source: str = "the identification"

    def effect(self, final: float) -> tuple[float, float, bool]:
        """The part of δ̂'s standard uncertainty due to δ1.

        Parameters
        ----------
        final : float
            δ̂ [rad] at the given δ1 (the reported one).

        Returns
        -------
        (float, float, bool)
            The propagated standard uncertainty [rad], the sensitivity ∂δ̂/∂δ1 used
            (dimensionless, ≥ 0), and whether it was measured; without a usable rerun the
            anchored law's one-for-one response (sensitivity 1) is used and ``False`` returned.
        """
        slopes = [
            abs(d - final) / abs(h)
            for h, d in self.shifted
            if h != 0.0 and math.isfinite(d) and math.isfinite(final)
        ]
        measured = bool(slopes)
        k = max(slopes) if measured else 1.0
        return k * self.std, k, measured


@dataclass
class EstimationResult:
    """Outputs of a run, the excitation verdict, plausibility checks and the uncertainty.

    Attributes
    ----------
    t : numpy.ndarray
        Time [s] (every sample of an in-memory run; a decimated series when streamed).
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
        The shaft torque seen by the law (J_l φ̂, or the motor-side estimate) [N·m].
    traversals : numpy.ndarray
        Running count of gap crossings [-].
    excitation_ok : bool
        Enough excitation to trust the estimate.
    reason : str
        Plain-language explanation of the verdict.
    converged : bool
        ``excitation_ok``, δ̂ settled over the last window, no plausibility check failed, and
        the 95 % interval no wider than ±:data:`CLAIM_HALF_WIDTH` (or the band, if smaller).
    convergence_time_s : float or None
        First time after which δ̂ stays in the band around its final value (or the truth,
        when known) [s]; None when not converged.
    band : float
        Band used for ``convergence_time_s`` and the settling check [rad].
    config : EstimatorConfig
        Gains used.
    delta_std : float
        Standard uncertainty of the final δ̂ [rad] (see :func:`_uncertainty`); NaN when the
        excitation is insufficient (δ̂ is then no measurement).
    warnings : list of str
        Every plausibility problem found (each also keeps ``converged`` false, except
        those marked "note:").
    extra : dict
        Figures behind the verdict (stiffness scale, δ1 check, Δθ range, torques, …).
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
    delta_std: float = float("nan")
    warnings: list[str] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def delta(self) -> float:
        """Final estimate δ̂ [rad]."""
        v = self.extra.get("delta_final")
        if v is not None:
            return float(v)
        return float(self.delta_hat[-1]) if self.delta_hat.size else float("nan")

    @property
    def delta_interval(self) -> tuple[float, float]:
        """95 % interval of δ [rad]: δ̂ ± 1.96 ``delta_std``."""
        return (self.delta - 1.96 * self.delta_std, self.delta + 1.96 * self.delta_std)


# ----------------------------------------------------------------------------------
# blocks: one interface for in-memory traces and files read in chunks
# ----------------------------------------------------------------------------------
Block = Mapping[str, np.ndarray]


def trace_blocks(trace: Trace, block: int = BLOCK) -> Callable[[], Iterator[Block]]:
    """A re-iterable source of ``block``-row slices of ``trace`` (for :func:`estimate_blocks`)."""
    names = [c for c in ("t", *INPUT_COLUMNS, TORQUE_COLUMN, "delta_true") if c in trace]

    def gen() -> Iterator[Block]:
        n = len(trace)
        for a in range(0, n, block):
            yield {c: trace[c][a : a + block] for c in names}

    return gen


def _readonly_f64(x: np.ndarray) -> np.ndarray:
    """``x`` as a C-contiguous float64 array behind a read-only view (no copy when it is one already).

    The compiled :func:`~drivelash.estimation.deadzone.stack_finite` indexes its tuple of columns
    with a runtime index, which numba compiles only for a tuple of one array type. A recording's
    columns come as read-only buffers (zero-copy Parquet/Arrow) and as writable arrays (any column
    the loader converted: a unit, offset or scale, an int column) side by side; a read-only view of
    every column gives them one type without copying any.
    """
    a = np.ascontiguousarray(x, dtype=np.float64).view()
    a.flags.writeable = False
    return a


def _block_samples(blk: Block, row0: int, use_torque: bool) -> np.ndarray:
    missing = [c for c in INPUT_COLUMNS if c not in blk]
    if missing:
        raise DataError(f"missing column(s) {', '.join(missing)} needed by the estimator", column=missing[0])
    cols = list(INPUT_COLUMNS) + ([TORQUE_COLUMN] if use_torque else [])
    src = tuple(_readonly_f64(blk[c]) for c in cols)
    n = src[0].shape[0]
    if any(a.ndim != 1 or a.shape[0] != n for a in src):
        raise ValueError("the estimator's input columns must be 1-D and of equal length")
    data = np.empty((n, len(cols)))
    row, col = dz.stack_finite(src, data)  # one compiled pass: copy, first bad value row-major
    if row >= 0:
        raise DataError("value is not finite (NaN or inf)", column=cols[col], row=int(row0 + row))
    return data


def scan_blocks(blocks: Callable[[], Iterable[Block]], N: float) -> MotionSummary:
    """Pass 1 over a block source: :class:`MotionSummary`; also checks that time increases and
    that the positions do not contradict the gear ratio ``N`` (:meth:`MotionScanner.check_gear_ratio`)."""
    sc = MotionScanner(N)
    t_prev = -math.inf
    row = 0
    for blk in blocks():
        t = np.asarray(blk["t"], dtype=np.float64)
        if t.size:
            d = np.diff(t, prepend=t_prev)  # first entry +inf at the start
            bad = ~(d > 0)
            if bad.any():
                raise DataError("time is not strictly increasing", column="t", row=row + int(np.argmax(bad)))
            t_prev = float(t[-1])
        for c in ("theta_m", "theta_l"):
            if c not in blk:
                raise DataError(f"missing column {c} needed by the estimator", column=c)
        sc.feed(
            t, blk["theta_m"], blk["theta_l"], blk.get(TORQUE_COLUMN), blk.get("omega_m"), blk.get("omega_l")
        )
        row += t.size
    summary = sc.summary()
    sc.check_gear_ratio()  # a wrong N is named, not blamed on excitation or δ1 (B6)
    return summary


# ----------------------------------------------------------------------------------
# the streaming session
# ----------------------------------------------------------------------------------
def series_step(n_total: int) -> int:
    """Decimation step of the output series kept when streaming (``keep="decimated"``).

    The series keeps the samples whose global index is a multiple of the step, so any
    column of the recording decimated the same way lines up with it row for row.
    """
    return max(1, -(-n_total // SERIES_POINTS))


class _Track:
    """Per-law outputs while streaming: block min/max history of δ̂ (and its error) and the series.

    ``error_since``: start times [s] of the intervals over which max |δ* − δ̂| is accumulated
    (the MAEE and steady-state peak of a recording with the true δ, without keeping δ̂(t)).
    """

    def __init__(
        self, n_total: int, keep_full: bool, has_truth: bool, error_since: tuple[float, ...] = ()
    ) -> None:
        self.Bh = max(1, -(-n_total // HISTORY_BLOCKS))
        nb = -(-n_total // self.Bh) if n_total else 0
        self.dmin = np.full(nb, np.inf)
        self.dmax = np.full(nb, -np.inf)
        self.emin = np.full(nb, np.inf) if has_truth else None
        self.emax = np.full(nb, -np.inf) if has_truth else None
        self.keep_full = keep_full
        self.step = 1 if keep_full else series_step(n_total)
        self.rows: list[np.ndarray] = []
        self.times: list[np.ndarray] = []
        self.last: np.ndarray | None = None
        self.error_since = error_since if has_truth else ()
        self.err_max = [-math.inf] * len(self.error_since)
        self.truth_last = math.nan

    def add(self, row0: int, t: np.ndarray, out: np.ndarray, truth: np.ndarray | None) -> None:
        n = out.shape[0]
        d = out[:, dz.O_DELTA]
        if n:
            # min/max of δ̂ per history block, one compiled pass over the block's rows
            dz.block_minmax(out, row0, self.Bh, self.dmin, self.dmax)
            if truth is not None and self.emin is not None and self.emax is not None:
                b0, b1 = row0 // self.Bh, (row0 + n - 1) // self.Bh + 1
                starts = np.arange(b0, b1) * self.Bh - row0
                starts[0] = 0
                blk = slice(b0, b1)
                e = d - truth
                np.minimum(self.emin[blk], np.minimum.reduceat(e, starts), out=self.emin[blk])
                np.maximum(self.emax[blk], np.maximum.reduceat(e, starts), out=self.emax[blk])
                self.truth_last = float(truth[-1])
                for i, t_from in enumerate(self.error_since):
                    m = t >= t_from
                    if m.any():  # |δ* − δ̂| as metrics.maee computes it: max is exact in any order
                        self.err_max[i] = max(self.err_max[i], float(np.max(np.abs(truth[m] - d[m]))))
        if self.keep_full:
            self.rows.append(out.copy())
            self.times.append(np.asarray(t, dtype=np.float64).copy())
        else:
            start = (-row0) % self.step
            self.rows.append(out[start :: self.step].copy())
            self.times.append(np.asarray(t[start :: self.step], dtype=np.float64).copy())
        if n:
            self.last = out[-1].copy()

    def series(self) -> tuple[np.ndarray, np.ndarray]:
        if not self.rows:
            return np.zeros(0), np.zeros((0, dz.N_OUT))
        return np.concatenate(self.times), np.concatenate(self.rows)


class _Law:
    """One kernel instance (parameters, state, output buffer, track)."""

    def __init__(self, params: np.ndarray, delta0: float, track: _Track) -> None:
        self.params = params
        self.state = dz.initial_state(params, delta0)
        self.track = track
        self._buf = np.empty((0, dz.N_OUT))

    def _out(self, n: int) -> np.ndarray:
        if self._buf.shape[0] < n:
            self._buf = np.empty((n, dz.N_OUT))
        return self._buf[:n]

    def feed(self, row0: int, x: np.ndarray, t: np.ndarray, truth: np.ndarray | None) -> None:
        out = self._out(x.shape[0])
        self.state = dz.deadzone_run_into(self.state, x, self.params, out)
        self.track.add(row0, t, out, truth)

    def feed_with(
        self, other: _Law, row0: int, x: np.ndarray, t: np.ndarray, truth: np.ndarray | None
    ) -> None:
        """Feed this law and ``other`` together, observing the block once when they observe it
        alike (:func:`~drivelash.estimation.deadzone.observe_shared`: the chosen law and the δ1
        check of the default method); the results are those of two :meth:`feed` calls, bit for bit."""
        if not dz.observe_shared(self.state, other.state, self.params, other.params):
            self.feed(row0, x, t, truth)
            other.feed(row0, x, t, truth)
            return
        n = x.shape[0]
        out_a, out_b = self._out(n), other._out(n)
        self.state, other.state = dz.deadzone_run2_into(
            self.state, other.state, x, self.params, other.params, out_a, out_b
        )
        self.track.add(row0, t, out_a, truth)
        other.track.add(row0, t, out_b, truth)

    def acc(self) -> dict[str, float]:
        s = self.state
        n = s[dz.S_ACC_N]
        d_mean = s[dz.S_ACC_D] / n if n else math.nan
        var = max(s[dz.S_ACC_D2] / n - d_mean * d_mean, 0.0) if n else math.nan
        nc = s[dz.S_CON_N]
        return {
            "n": n,
            "residual_rms": math.sqrt(s[dz.S_ACC_E2] / n) if n else math.nan,
            "delta_mean": s[dz.S_ACC_REF] + d_mean if n else math.nan,
            "delta_spread": math.sqrt(var) if n else math.nan,
            "contact_fraction": nc / n if n else 0.0,
            "contact_torque": s[dz.S_CON_T] / nc if nc else 0.0,
            "contact_torque_rms": math.sqrt(s[dz.S_CON_T2] / nc) if nc else 0.0,
            "residual_rms_lower": math.sqrt(s[dz.S_E2_LO] / s[dz.S_N_LO]) if s[dz.S_N_LO] else math.nan,
            "residual_rms_upper": math.sqrt(s[dz.S_E2_HI] / s[dz.S_N_HI]) if s[dz.S_N_HI] else math.nan,
        }


@dataclass
class _Setup:
    drivetrain: DrivetrainParams
    delta1: float
    T_s: float
    config: EstimatorConfig
    check_config: EstimatorConfig | None
    motion: MotionSummary
    encoder_reading: str = "unknown"
    cross_config: EstimatorConfig | None = None
    delta1_uncertainty: Delta1Uncertainty | None = None
    axis: str = "rotary"  # Trace.meta["axis"]: the messages' unit (drivelash.units.gap_unit)


def _check_config(config: EstimatorConfig, default_cfg: EstimatorConfig) -> EstimatorConfig:
    """The δ1 check: the default law with δ1 estimated jointly and κ held at 1."""
    return replace(
        default_cfg,
        method="default",
        estimate_offset=True,
        estimate_stiffness=False,
        offset_check=False,
        delta0=config.delta0,
        delta_max=config.delta_max,
    )


def estimate_blocks(
    drivetrain: DrivetrainParams,
    delta1: float,
    blocks: Callable[[], Iterable[Block]],
    *,
    method: Method = "default",
    config: EstimatorConfig | None = None,
    overrides: Mapping[str, Any] | None = None,
    f_exc: float | None = None,
    keep: Literal["full", "decimated"] = "full",
    motion: MotionSummary | None = None,
    error_since: tuple[float, ...] = (),
    encoder_reading: str | None = None,
    delta1_uncertainty: Delta1Uncertainty | None = None,
    axis: str | None = None,
) -> EstimationResult:
    """Run the online estimator over a block source in two passes (module docstring).

    Parameters
    ----------
    drivetrain : DrivetrainParams
        Drive-train parameters as known to the estimator.
    delta1 : float
        Configured offset δ1 [rad].
    blocks : callable
        Returns a fresh iterator of blocks (mappings of column → array: ``t``, θ_m, ω_m, θ_l,
        ω_l, optionally ``torque_m`` and ``delta_true``) each time it is called.
    method : {"paper", "default"}
        Law.
    config : EstimatorConfig, optional
        Gains to use as they are (no tuning); its ``method`` wins over ``method``.
    overrides : mapping, optional
        Fields of :class:`EstimatorConfig` overriding the tuning rule.
    f_exc : float, optional
        Excitation frequency [Hz] instead of the one detected in pass 1.
    keep : {"full", "decimated"}
        Keep every output row, or a series of about :data:`SERIES_POINTS` rows (files larger
        than memory). The verdict and every figure are the same either way.
    motion : MotionSummary, optional
        Pass-1 result when the caller already has it.
    error_since : tuple of float
        With the true δ in the blocks: start times [s] of intervals to the end over which
        max |δ* − δ̂| is accumulated while streaming (``extra["max_abs_error_since"]``, one
        per start, and ``extra["delta_true_last"]``), e.g. the MAEE and steady-state peak of
        a recording too long to keep δ̂(t).
    encoder_reading : {"nearest", "truncate"}, optional
        The recording's own statement of its encoders' reading convention (``Trace.meta``);
        used when the configuration leaves ``encoder_reading`` "unknown".
    delta1_uncertainty : Delta1Uncertainty, optional
        ``delta1`` is itself uncertain (identified, not configured): its standard uncertainty
        [rad] and δ̂ of reruns at shifted δ1, propagated into ``delta_std`` and the verdict.
    axis : {"rotary", "prismatic"}, optional
        The recording's axis kind (``Trace.meta["axis"]``): the warnings write gaps in mrad on
        a rotary axis, in µm on a prismatic one (positions in m). The numbers stay SI.

    Returns
    -------
    EstimationResult
    """
    delta1 = rounded_delta1(delta1)
    if not (math.isfinite(delta1) and delta1 >= 0):
        raise ParameterError("BacklashParams", "delta1", f"must be finite and >= 0, got {delta1!r}")
    if motion is None:
        motion = scan_blocks(blocks, drivetrain.N)
    if motion.n < 2:
        raise DataError("fewer than two samples: no sample time", column="t")
    if f_exc is not None:
        motion = replace(motion, f_exc=float(f_exc))
    T_s = motion.T_s
    over = dict(overrides or {})
    if config is None:
        config = EstimatorConfig.tuned(drivetrain, T_s, method=method, motion=motion, **over)
    # the configuration's statement wins; else the recording's own metadata (the config is kept
    # as given, so the reported gains do not depend on where the recording came from)
    reading = config.encoder_reading
    if reading == "unknown" and encoder_reading in ("nearest", "truncate"):
        reading = encoder_reading
    if reading == "truncate":
        # truncating encoders put Δθ above the true relative angle by the signed offset; the
        # lower contact then reads at −δ1 + offset, i.e. δ1 − offset in the recorded frame
        delta1 = delta1 - _encoder_offset(motion, drivetrain.N)
    base = config
    cross_cfg = None
    if config.method != "default":
        over_d = {k: v for k, v in over.items() if k not in ("gamma",)}
        base = EstimatorConfig.tuned(drivetrain, T_s, method="default", motion=motion, **over_d)
        # the paper law's cross-check: the default law (stiffness scale learnt) on the same data
        cross_cfg = replace(
            base, offset_check=False, delta0=config.delta0, delta_max=config.delta_max,
        )  # fmt: skip
    check_cfg = None
    if config.offset_check and not config.estimate_offset:
        check_cfg = _check_config(config, base)
    setup = _Setup(
        drivetrain, float(delta1), T_s, config, check_cfg, motion, reading, cross_cfg, delta1_uncertainty,
        axis or "rotary",
    )  # fmt: skip
    return _run_session(setup, blocks, keep, tuple(float(x) for x in error_since))


def _encoder_offset(mo: MotionSummary, N: float) -> float:
    """Signed offset of Δθ = θ_m/N − θ_l when both encoders truncate, q_l/2 − q_m/(2N) [rad]."""
    return 0.5 * (mo.count_l - mo.count_m / N)


def _run_session(
    setup: _Setup, blocks: Callable[[], Iterable[Block]], keep: str, error_since: tuple[float, ...] = ()
) -> EstimationResult:
    n = setup.motion.n
    k0 = (2 * n) // 3
    has_torque = setup.motion.torque_rms is not None
    first = True
    has_truth = False
    main: _Law | None = None
    check: _Law | None = None
    cross: _Law | None = None
    row = 0
    for blk in blocks():
        if first:
            has_truth = "delta_true" in blk
            main = _Law(
                build_params(setup.drivetrain, setup.delta1, setup.config, setup.T_s, k0, setup.axis),
                setup.config.delta0,
                _Track(n, keep == "full", has_truth, error_since),
            )
            if setup.check_config is not None:
                check = _Law(
                    build_params(setup.drivetrain, setup.delta1, setup.check_config, setup.T_s, k0),
                    setup.check_config.delta0,
                    _Track(n, keep == "full", has_truth, error_since),
                )
            if setup.cross_config is not None:
                cross = _Law(
                    build_params(setup.drivetrain, setup.delta1, setup.cross_config, setup.T_s, k0),
                    setup.cross_config.delta0,
                    _Track(n, False, False),
                )
            first = False
        assert main is not None
        x = _block_samples(blk, row, has_torque)
        t = np.asarray(blk["t"], dtype=np.float64)
        truth = np.asarray(blk["delta_true"], dtype=np.float64) if has_truth else None
        if check is not None:
            main.feed_with(check, row, x, t, truth)
        else:
            main.feed(row, x, t, truth)
        if cross is not None:
            cross.feed(row, x, t, None)
        row += x.shape[0]
    if main is None or row != n:
        raise DataError(f"the recording changed between passes ({n} then {row} rows)", column="t")
    return _verdict(setup, main, check, has_truth, cross)


# ----------------------------------------------------------------------------------
# verdict
# ----------------------------------------------------------------------------------
def _window_movement(track: _Track, n: int, k_win: int) -> float:
    """How far δ̂ moved [rad] (max − min) over the blocks covering the last ``k_win`` samples."""
    b0 = max(0, (n - k_win) // track.Bh)
    return float(np.max(track.dmax[b0:])) - float(np.min(track.dmin[b0:]))


def _convergence_time(
    track: _Track, t0: float, T_s: float, n: int, band: float, final: float
) -> float | None:
    """First block boundary after which |δ̂ − ref| ≤ band to the end (ref: truth, or the final δ̂)."""
    if track.emin is not None and track.emax is not None:
        lo, hi = track.emin, track.emax
    else:
        lo, hi = track.dmin - final, track.dmax - final
    bad = np.nonzero((hi > band) | (lo < -band))[0]
    if bad.size == 0:
        return 0.0
    k = int(bad[-1]) + 1
    if k >= lo.size:
        return None
    return float(k * track.Bh * T_s)


def _kappa(law: _Law) -> float:
    return float(law.state[dz.S_TH + 1])


def _verdict(
    setup: _Setup, main: _Law, check: _Law | None, has_truth: bool, cross: _Law | None = None
) -> EstimationResult:
    cfg, mo = setup.config, setup.motion
    T_s, n = setup.T_s, mo.n
    st = main.state
    default = cfg.method == "default"
    extra: dict[str, Any] = {"delta1_outside_range": False}
    warnings: list[str] = []
    # the recording's angle scale: the absolute angle constants of the verdict (2 mrad band and
    # claim, 1 mrad δ1 floor, 50 mrad range excess) follow a small Δθ range as the gains do
    sigma = cfg.angle_scale
    extra["angle_scale"] = sigma
    u = gap_unit(setup.axis)  # mrad, or µm on a prismatic axis (the numbers stay SI)

    n_trav = int(st[dz.S_TRAV])
    raw_trav = int(st[dz.S_RAW_TRAV])
    win = cfg.window
    duration = n * T_s
    sigma_frac = float(st[dz.S_SIGSUM] * T_s / win)
    peak_tq = float(st[dz.S_PEAK_TQ])
    # --- excitation -------------------------------------------------------------
    if duration < win:
        ok, reason = (
            False,
            f"recording of {duration:.3g} s is shorter than the excitation window of {win:.3g} s",
        )
    elif mo.motor_range > 0 and mo.load_range < 0.1 * mo.motor_range:
        ok = False
        reason = (
            f"no engagement: the load moved {mo.load_range:.3g} {u.si} while the motor moved "
            f"{mo.motor_range:.3g} {u.si} (load side) — the motion stays inside the deadzone (gap)"
        )
    elif mo.reversals < 2:
        ok = False
        reason = (
            (
                "the motion never reverses (unidirectional): only one contact side is seen, "
                "so the gap cannot be measured; a back-and-forth motion is needed"
            )
            if mo.reversals == 0
            else (
                "the motion reverses only once: the gap is crossed once, too few to judge the "
                "estimate; a back-and-forth motion (at least 2 reversals) is needed"
            )
        )
    elif n_trav < 2:
        ok = False
        dth_span = float(st[dz.S_DTH_MAX]) - float(st[dz.S_DTH_MIN])
        if dth_span <= DTH_SAME_SIGNAL * max(mo.motor_range, 1e-300):
            reason = (
                f"Δθ = θ_m/N − θ_l stays at {float(st[dz.S_DTH_MAX]):.6g} {u.si} at every sample while the "
                f"motor moved {mo.motor_range:.3g} {u.si}: the load position is the motor's own signal "
                "(one channel mapped twice?) or nothing between the encoders moves — no gap to see"
            )
        elif peak_tq < cfg.T_thr:
            reason = (
                "no engagement: the shaft torque never exceeded the contact threshold "
                f"({cfg.T_thr:.3g} {u.torque}) — the motion seems to stay inside the deadzone (gap)"
            )
        elif raw_trav >= 2:
            # the load moved back and forth with the shaft torque reversing: unless one flank
            # kept it (gravity), the drive sat on its lower contact, Δθ = −δ1 − deflection; a
            # configured δ1 far outside the Δθ seen is a wrong δ1 (a unit slip below δ_max)
            deflection = peak_tq / (min(_kappa(main) if default else 1.0, 1.0) * setup.drivetrain.K_S)
            d1_outside = delta1_outside_range(
                setup.delta1, float(st[dz.S_DTH_MIN]), float(st[dz.S_DTH_MAX]), deflection, sigma, setup.axis
            )
            extra["delta1_outside_range"] = d1_outside is not None
            reason = d1_outside or (
                f"the shaft torque reversed {raw_trav} times but the gap was never crossed: one "
                "flank keeps the load (a constant load torque such as gravity, or a preload), "
                "so the gap cannot be seen"
            )
        else:
            reason = (
                "the motion never reverses through the gap (contact on one side only); "
                "a reversing motion is needed to see the gap"
            )
    elif sigma_frac < SIGMA_FRACTION_MIN:
        ok = False
        reason = (
            f"too little excitation in the last {win:.3g} s: its information (∫g² dt / window, g the "
            f"shaft torque's sensitivity to δ per K_S) is {sigma_frac:.3g}, needs {SIGMA_FRACTION_MIN:g}"
        )
    else:
        ok = True
        reason = (
            f"{n_trav} crossings of the gap; information {sigma_frac:.2f} in the last window "
            f"(∫g² dt / window, needs {SIGMA_FRACTION_MIN:g})"
        )

    # --- δ1 check and the law reported -------------------------------------------
    chosen = main
    delta1_used = setup.delta1
    a_main = main.acc()
    kappa = _kappa(main) if default else 1.0
    extra.update(
        traversals=n_trav,
        torque_reversals=raw_trav,
        sigma_fraction=sigma_frac,
        motor_range=mo.motor_range,
        load_range=mo.load_range,
        reversals=float(mo.reversals),
        torque_source=cfg.torque_source,
        contact_threshold=cfg.T_thr,
    )
    if default:
        extra["stiffness_scale"] = kappa
    D = a_main["contact_torque"] / (max(kappa, 1e-12) * setup.drivetrain.K_S)  # contact deflection
    extra["contact_deflection"] = D
    # the largest contact deflection of the last third, with the softer of the stated and the
    # learnt stiffness: how far a wrong torque model can move a contact point
    D_peak = float(st[dz.S_PEAK_TQ]) / (min(kappa, 1.0) * setup.drivetrain.K_S)
    extra["contact_deflection_peak"] = D_peak
    offset_state = "not run"
    # the check could not judge δ1 (its joint law fits its two contacts unequally) although that
    # law puts the lower contact beyond the floor from the configured δ1: the data's δ1 is an
    # alternative the interval must reach, as for an inconsistent δ1 (H3 of session 30)
    d1_unjudged = False
    by_ratio = False  # "consistent" because the joint law fits the torque clearly worse
    # the accuracy constants' scale for the anchored δ̂ (verdict_scale: σ capped by δ̂ / 10 mrad)
    sigma_anchor = verdict_scale(sigma, float(main.state[dz.S_DELTA]))
    if check is not None:
        a_chk = check.acc()
        d1_j = float(check.state[dz.S_TH + 2])
        diff = d1_j - setup.delta1
        extra.update(
            delta1_check=d1_j,
            delta1_check_delta=float(check.state[dz.S_DELTA]),
            delta_anchored=float(main.state[dz.S_DELTA]),
            residual_rms_anchored_lower=a_main["residual_rms_lower"],
            residual_rms_anchored_upper=a_main["residual_rms_upper"],
            residual_rms_joint_lower=a_chk["residual_rms_lower"],
            residual_rms_joint_upper=a_chk["residual_rms_upper"],
            residual_rms_anchored=a_main["residual_rms"],
            residual_rms_joint=a_chk["residual_rms"],
        )
        # the floor is capped by the anchored δ̂ (verdict_scale): a compliant drive's Δθ range is
        # several gaps wide and σ alone made the floor 37 % of a 20 µm gap (session 35); an
        # offset_switch set in [estimator] (not the tuned OFFSET_FLOOR σ) is kept
        tuned_switch = cfg.offset_switch == OFFSET_FLOOR * sigma
        floor = delta1_tolerance(0.0 if tuned_switch else cfg.offset_switch, sigma_anchor)
        ratio = a_chk["residual_rms"] / a_main["residual_rms"] if a_main["residual_rms"] > 0 else math.nan
        # per contact side: a wrong δ1 spoils the anchored law's fit in the *lower* contact
        # (where δ1 anchors it) and not the joint law's; a wrong torque model spoils both sides
        j_bal = a_chk["residual_rms_lower"] / a_chk["residual_rms_upper"]
        a_bal = a_main["residual_rms_lower"] / a_main["residual_rms_upper"]
        asym = a_bal / j_bal if j_bal > 0 else math.nan
        extra.update(delta1_check_ratio=ratio, delta1_check_asymmetry=asym, delta1_check_balance=j_bal)
        # the joint law judges δ1 only once it has settled as δ̂ must, or when it ended where the
        # anchored law did: it adapts δ and δ1 together and settles far later than the anchored law
        # (bench scenarios, δ1 ±10 mrad off: on 6 s its δ still moved 12–270 mrad over the last
        # window, on 10 s 47–84 mrad for the 1.027 rad gaps) — until then its δ1 and its residuals
        # say nothing about the configured δ1 (session 34: 49 of 54 such 6 s runs were "converged"
        # with δ̂ 3–10 mrad off). Ending within the δ1 floor of the anchored δ̂ is itself agreement
        # (the true δ1 on 6 s of bench-0C: moved 13 mrad, ended 0.15 mrad from δ̂).
        track_j = check.track
        band_j = (
            max(BAND_FLOOR * sigma_anchor, 0.02 * float(np.max(track_j.dmax)))
            if track_j.dmax.size
            else BAND_FLOOR * sigma_anchor
        )
        k_win_j = max(1, int(round(win / T_s)))
        move_j = _window_movement(track_j, n, k_win_j) if n else math.inf
        settled_j = move_j <= band_j
        apart_j = abs(float(check.state[dz.S_DELTA]) - float(main.state[dz.S_DELTA]))
        extra.update(delta1_check_movement=move_j, delta1_check_band=band_j, delta1_check_apart=apart_j)
        if not ok:
            # without a verdict of sufficient excitation neither law saw the gap: no judgement
            offset_state = "inconclusive"
        elif abs(diff) <= floor:
            offset_state = "consistent"
        elif not (1.0 / OFFSET_BALANCE < j_bal < OFFSET_BALANCE):
            # the joint law does not fit its own two contacts alike: it cannot judge δ1 — but the
            # lower contact it measured lies beyond the floor from the configured δ1, and the
            # anchored δ̂ moves one-for-one with δ1 (bench-0B, 10 s: δ1 −5/+2/+5 mrad gave δ̂
            # −5.4/+2.0/+5.0 mrad off, "converged", while this law's δ1 was right to 0.02 mrad)
            offset_state = "inconclusive"
            # … provided that law is still a credible alternative: it saw both its contacts in the
            # last third with a balance within [1/OFFSET_BALANCE_ALTERNATIVE, OFFSET_BALANCE_ALTERNATIVE]
            # (4 s of bench-0A with its true δ1: one side unseen, joint δ1 65 mrad off; a random
            # drive of test_generalisation with its true δ1: balance 6.8, joint δ1 3.9 mrad off)
            # and it settled as δ̂ must
            d1_unjudged = 1.0 / OFFSET_BALANCE_ALTERNATIVE < j_bal < OFFSET_BALANCE_ALTERNATIVE and settled_j
        elif (
            default
            and ratio < OFFSET_RESIDUAL_RATIO
            and asym > OFFSET_BALANCE
            and abs(diff) > OFFSET_DEFLECTION_FACTOR * D
        ):
            offset_state = "switched"
        elif default and ratio * OFFSET_RESIDUAL_RATIO > 1.0 and not asym > OFFSET_BALANCE:
            # the joint law explains the shaft torque clearly worse, and the anchored law fits its
            # lower contact (where δ1 anchors it) no worse than the joint law does: the joint law's
            # offset is an artefact. With the lower contact fitted worse the torque ratio proves
            # nothing (the joint law holds κ at 1: bench-1B 10 s, δ1 +10 mrad, ratio 1.29, asymmetry
            # 4.0 was "consistent" with δ̂ 9.9 mrad off; the true δ1's asymmetries 0.5–1.3)
            offset_state = "consistent"
            by_ratio = True
        else:
            offset_state = "inconsistent"
        if (
            ok
            and not settled_j
            and not apart_j <= floor
            and offset_state in ("consistent", "switched", "inconclusive")
            and not d1_unjudged
            and not by_ratio
        ):
            # an unsettled joint law that ended away from δ̂ judges nothing: neither "consistent"
            # (its δ1 near the configured one only says it has not moved yet) nor a switch to it.
            # Its evidence stands where it has some: "inconsistent", and "consistent" because it
            # fits the torque clearly worse with the lower contact no better (a random drive of
            # test_generalisation, seed 3 case 8, 40 s: ratio 26.8, asymmetry 0.68, the joint law
            # wandering 92 mrad over the window — the anchored δ̂ 0.1 mrad from the truth)
            offset_state = "not settled"
        extra["delta1_check_result"] = offset_state
        # "consistent" because the joint law fits the torque clearly worse: its δ1 is no evidence
        extra["delta1_check_by_ratio"] = by_ratio
        if d1_unjudged:
            warnings.append(
                f"the δ1 check cannot decide (its joint δ/δ1 law fits the lower and upper contact "
                f"unequally, residual ratio {j_bal:.2f}) but puts the lower contact at δ1 ≈ "
                f"{u.f(d1_j, '.2f')}, {u.f(diff, '+.1f')} from the configured δ1 = "
                f"{u.f(setup.delta1, '.2f')}, and δ̂ moves with δ1 — check [backlash] delta1 "
                "and the load encoder's zero"
            )
        if offset_state == "switched":
            chosen = check
            delta1_used = d1_j
            reason += (
                f"; the data put the lower contact {u.f(diff, '+.1f')} from the configured δ1 "
                "(wrong δ1 or an offset between the encoders), so δ and δ1 were estimated jointly"
            )
        elif offset_state == "inconsistent":
            what = (
                "use --method default, which estimates δ1 when the data demand it"
                if not default
                else "the data do not decide between a wrong δ1 and wrong drive parameters"
            )
            warnings.append(
                f"δ1 is inconsistent with the data: the joint δ/δ1 law puts the lower contact "
                f"{u.f(diff, '+.1f')} from the configured δ1 = {u.f(setup.delta1, '.1f')}; {what}"
            )
    extra["offset_switched"] = offset_state == "switched"
    extra["delta1_used"] = delta1_used
    a = chosen.acc()
    final = float(chosen.state[dz.S_DELTA])
    extra["delta_final"] = final
    if chosen is check:
        extra["delta1_estimate"] = delta1_used
        extra["stiffness_scale_joint"] = 1.0

    # --- plausibility (both methods) ------------------------------------------------
    dth_range = float(main.state[dz.S_DTH_MAX] - main.state[dz.S_DTH_MIN])
    extra["dtheta_range"] = dth_range
    at_bound = final >= BOUND_FRACTION * cfg.delta_max
    if at_bound:
        warnings.append(
            f"δ̂ = {u.f(final, '.1f')} sits at its upper bound δ_max = {u.f(cfg.delta_max, '.0f')}: "
            f"the true gap is larger or the data are not in {u.si} / {u.velocity} (check the units)"
        )
    if ok and final > dth_range:
        warnings.append(
            f"δ̂ = {u.f(final, '.1f')} exceeds the whole Δθ range observed ({u.f(dth_range, '.1f')}): "
            "the gap was never crossed, the estimate is not a measurement"
        )
        if offset_state in ("consistent", "not settled") and check is not None and abs(diff) > floor:
            # the anchored law left the recording's range: its better torque fit is no evidence
            # for the configured δ1; a joint law that stays inside the range is evidence against it
            # (and its δ then widens the interval below, as for any inconsistent δ1)
            d_joint = float(extra["delta1_check_delta"])
            if d_joint <= dth_range:
                offset_state = "inconsistent"
                warnings.append(
                    f"δ1 is inconsistent with the data: with δ1 = {u.f(setup.delta1, '.1f')} the "
                    f"estimate leaves the observed Δθ range, while the joint δ/δ1 law puts the lower "
                    f"contact {u.f(diff, '+.1f')} from it (δ1 ≈ {u.f(float(extra['delta1_check']), '.1f')}, "
                    f"δ ≈ {u.f(d_joint, '.1f')})"
                )
            else:
                offset_state = "inconclusive"
            extra["delta1_check_result"] = offset_state
    # the other side: Δθ spans at most δ + the two contact deflections, so a Δθ range far beyond
    # δ̂ + 2 D_peak says δ̂ is too small (a wrong δ1 the check could not judge moves the anchored
    # δ̂ one-for-one: bench-0A for 4 s with bench-0B's δ1 settled at 606.6 ± 1.0 mrad for 1027)
    range_gap = 0.0
    excess = dth_range - final - 2.0 * D_peak
    if ok and not at_bound and excess > max(RANGE_EXCESS_FACTOR * D_peak, RANGE_EXCESS_MIN * sigma):
        range_gap = excess
        d1_note = (
            f" (the data's δ1 check gives {u.f(float(extra['delta1_check']), '.1f')})"
            if "delta1_check" in extra
            else ""
        )
        warnings.append(
            f"δ̂ = {u.f(final, '.1f')} is too small for the data: Δθ spanned {u.f(dth_range, '.1f')}, "
            f"{u.f(excess, '.1f')} more than δ̂ and the two contact deflections — check [backlash] "
            f"delta1 = {u.f(setup.delta1, '.1f')}{d1_note}"
        )
    extra["delta_range_gap"] = range_gap
    if default and not (KAPPA_LIMITS[0] < kappa < KAPPA_LIMITS[1]):
        warnings.append(
            f"the data disagree with the stated drive: the contact stiffness is {kappa:.2f}× the "
            "stated K_S (at the limit of what the law corrects) — check K_S and the units"
        )
    # constant load torque on the load (gravity): motor-side and load-side torques disagree
    if default and cfg.torque_source == "motor":
        s = main.state
        nd = s[dz.S_DIS_N]
        if nd > 10:
            A = np.array([[nd, s[dz.S_DIS_S]], [s[dz.S_DIS_S], s[dz.S_DIS_SS]]])
            b = np.array([s[dz.S_DIS_D], s[dz.S_DIS_DS]])
            try:
                c0, c1 = np.linalg.solve(A, b)
            except np.linalg.LinAlgError:
                c0, c1 = s[dz.S_DIS_D] / nd, 0.0
            extra["load_torque_constant"] = float(c0)
            extra["load_friction_error"] = float(c1)
            tc = a_main["contact_torque"]
            if tc > 0 and abs(c0) > LOAD_TORQUE_FRACTION * tc:
                warnings.append(
                    f"note: the motor torque and the load observer disagree by a constant "
                    f"{c0:+.3g} {u.torque} (a load torque such as gravity, or a wrong load friction or "
                    "inertia); the shaft torque was taken from the motor side, which includes it"
                )
    # the angle constants assume a Δθ scale the recording does not have: the smallest angle
    # scale (ANGLE_SCALE_MIN) or a configuration's own gains (tuned without the recording) leave
    # the α cap, the 1 mrad contact term, the observers' ρ and the 2 mrad band far above it
    r_dth = mo.dtheta_range
    extra["dtheta_range_recorded"] = r_dth
    if math.isfinite(r_dth) and r_dth < ANGLE_SCALE_MISMATCH * ANGLE_SCALE_RANGE * sigma:
        size = (
            f"({r_dth:.3g} {u.si}) is {ANGLE_SCALE_RANGE * sigma / r_dth:.3g}× smaller than"
            if r_dth > 0
            else "is zero (θ_l follows θ_m exactly), below"
        )
        warnings.append(
            f"the recording's Δθ range {size} the scale the estimator's angle constants assume "
            f"({ANGLE_SCALE_RANGE * sigma:.3g} {u.si}: α ≤ {1e5 / sigma:.3g} 1/{u.si}, band ≥ "
            f"{BAND_FLOOR * sigma:.3g} {u.si}): δ̂ is biased and its interval unreliable — check the "
            "position units (rad, m) and the load encoder, or let the tuning rule set the gains "
            "([estimator] angle_scale)"
        )
    # --- encoder reading convention ---------------------------------------------------
    # δ1 anchors δ̂ to the recorded Δθ = θ_m/N − θ_l. An encoder reading stands for an
    # interval one count wide; whether it reports the interval's start (truncation), centre or
    # end is the encoder's convention, invisible in the data. With the same convention on both
    # encoders the offsets cancel except for the difference of the two counts seen on the load
    # side, so Δθ (hence δ̂) carries an unknown systematic offset of up to half that difference.
    # The anchored law's δ̂ takes such an offset once directly and, when the stiffness scale κ
    # is learnt, up to once more: κ absorbs the misplaced lower contact as a stiffness change
    # of about offset/D, which moves the upper contact by D·offset/D (measured 1.55× and 1.8× on
    # the independent drives ind0.1/ind0.5, paper law 1.07×). A law that estimates δ1 (the
    # switched δ1 check) measures the lower contact in the recorded frame: no offset.
    c_m, c_l = mo.count_m, mo.count_l
    enc_offset = abs(_encoder_offset(mo, setup.drivetrain.N))
    if setup.encoder_reading != "unknown" or chosen is check:
        # a stated convention: no offset ("nearest") or corrected in δ1 ("truncate")
        enc_gain = 0.0
    elif default and cfg.estimate_stiffness:
        enc_gain = ENCODER_OFFSET_GAIN_KAPPA
    else:
        enc_gain = 1.0
    enc_bound = enc_gain * enc_offset
    extra.update(
        encoder_reading=setup.encoder_reading,
        # where the applied convention came from (B7: the config said "unknown" in both runs of
        # the same samples, one "converged" because the file's metadata said "nearest")
        encoder_reading_from=(
            "configuration"
            if cfg.encoder_reading != "unknown"
            else ("recording metadata" if setup.encoder_reading != "unknown" else "none")
        ),
        encoder_count_motor=c_m,
        encoder_count_load=c_l,
        encoder_offset=enc_offset,
        encoder_offset_bound=enc_bound,
    )
    # --- settling, convergence, uncertainty -----------------------------------------
    delta_max_seen = float(np.max(chosen.track.dmax)) if chosen.track.dmax.size else 0.0
    # band and claim scale with the reported δ̂ as well as with the Δθ range (verdict_scale)
    sigma_final = verdict_scale(sigma, final)
    extra["verdict_scale"] = sigma_final
    band = max(BAND_FLOOR * sigma_final, 0.02 * delta_max_seen)
    k_win = max(1, int(round(win / T_s)))
    # how far δ̂ moved over the last window: settled within the band (a wear trend widens an
    # unsettled estimate's σ by it: wear.estimate.unconverged_cause; session 32 tester F, F5)
    window_move = _window_movement(chosen.track, n, k_win) if n else math.nan
    settled = bool(window_move <= band) if n else False
    # the uncertainty of a measurement; without sufficient excitation δ̂ is none (NaN → null)
    # the paper law against the default law on the same data: the paper law has no stiffness
    # scale, so a wrong K_S (or friction, inertia) moves its contact points unseen; where the
    # default law, which learns κ, puts δ elsewhere, the interval must reach it
    disagreement = 0.0
    if cross is not None:
        d_def = float(cross.state[dz.S_DELTA])
        disagreement = abs(final - d_def)
        extra.update(delta_default_law=d_def, law_disagreement=disagreement)
    # δ1 inconsistent with the data (not switched): the joint δ/δ1 law's δ is what the data give
    # without the configured δ1, so the interval must reach it too (a bounded alternative, added
    # linearly like the disagreement above) — else the interval is conditional on a δ1 the data
    # contradict (bench-0A with bench-0B's δ1, --method paper: ±1.9 mrad around a 419 mrad error);
    # likewise when the check could not judge a δ1 its joint law puts beyond the floor
    d1_gap = 0.0
    if offset_state in ("inconsistent", "not settled") or d1_unjudged:
        # "not settled": the joint law is still on its way (it approaches the data's δ from its
        # start); where it ended bounds how far an unverified δ1 may have moved δ̂ (6 s bench runs,
        # δ1 ±10 mrad off: the truth lay between δ̂ and it in every case)
        d1_gap = abs(final - extra["delta1_check_delta"])
        extra["delta1_check_gap"] = d1_gap
    # δ1 "consistent" within the check's floor is not δ1 verified to zero: the joint law puts the
    # lower contact |diff| from the configured δ1, and the anchored δ̂ moves with a δ1 error once
    # directly and, with κ learnt, up to once more (κ absorbs the misplaced contact as a stiffness
    # change, as for the encoder offset above). Tester I (session 35): δ1 off 3–11 % of a 3–30 mrad
    # gap was "consistent", δ̂ moved 1.6–1.9× the δ1 error and 42 of 162 runs were converged with
    # the truth outside an interval that counted half the difference in quadrature. A bounded
    # alternative like the others; the joint law's δ1 when it was judged an artefact (by_ratio) is
    # not evidence and keeps the old half-difference (_uncertainty). A δ1 given with its own
    # uncertainty (estimate --identify) has its error counted already, through the measured
    # ∂δ̂/∂δ1 (s_d1 below): the identification's interval, not the check's difference, stands for it
    d1_bound = 0.0
    if (
        offset_state == "consistent"
        and not by_ratio
        and check is not None
        and chosen is main
        and setup.delta1_uncertainty is None
    ):
        d1_gain = ENCODER_OFFSET_GAIN_KAPPA if default and cfg.estimate_stiffness else 1.0
        d1_bound = d1_gain * abs(diff)
    extra["delta1_check_bound"] = d1_bound
    # the largest of the bounded alternatives for δ (each says where the data put it)
    alt_gap = max(d1_gap, range_gap, d1_bound)
    # at its projection bound δ̂ is the bound, not a measurement: no uncertainty either (a wear
    # history takes an unconverged estimate only with a stated one)
    # δ1 given with an uncertainty of its own (estimate --identify: the identified δ1): the
    # anchored law does not correct a δ1 offset, so δ1's standard error reaches δ̂ through the
    # measured sensitivity — a standard uncertainty like the others, added in quadrature
    s_d1 = 0.0
    d1u = setup.delta1_uncertainty
    if d1u is not None:
        s_d1, k_d1, k_measured = d1u.effect(final)
        extra.update(
            delta1_std=d1u.std,
            delta1_sensitivity=k_d1,
            delta1_sensitivity_measured=k_measured,
            delta1_propagated_std=s_d1,
        )
    std_base = (
        _uncertainty(a, extra, cfg.theta_def, enc_bound + disagreement + alt_gap, angle_scale=sigma_anchor)
        if ok and not at_bound
        else math.nan
    )
    std = (
        _uncertainty(a, extra, cfg.theta_def, enc_bound + disagreement + alt_gap, s_d1, sigma_anchor)
        if ok and not at_bound
        else math.nan
    )
    claim = min(band, CLAIM_HALF_WIDTH * sigma_final)
    if ok and 1.96 * std > claim:
        # every bounded alternative that widens the interval is named; the rest (spread, δ1
        # check, model part, floor) is "the data disagree with the stated drive parameters"
        why_parts = []
        if d1_gap > 0.0 and offset_state == "not settled":
            why_parts.append(
                f"the δ1 check did not settle — its joint δ/δ1 law still moved {u.f(move_j, '.3g')} "
                f"over the last {win:.3g} s (band {u.f(band_j, '.2g')}) and ended at δ "
                f"{u.f(extra['delta1_check_delta'], '.2f')}, {u.f(d1_gap, '.2f')} from δ̂, with δ1 at "
                f"{u.f(d1_j, '.2f')}: δ̂ rests on the configured δ1 = {u.f(setup.delta1, '.2f')} "
                "unverified and moves one-for-one with it — record longer, or set [estimator] "
                "offset_check = false when δ1 is known"
            )
        elif d1_gap > 0.0:
            why_parts.append(
                f"with δ1 estimated from the data the joint law puts δ at "
                f"{u.f(extra['delta1_check_delta'], '.2f')}, {u.f(d1_gap, '.2f')} from δ̂"
            )
        if d1_bound > 0.0 and d1_bound >= max(d1_gap, range_gap) and 1.96 * std_base - d1_bound <= claim:
            why_parts.append(
                f"the δ1 check puts the lower contact at {u.f(d1_j, '.3g')}, "
                f"{u.f(d1_j - setup.delta1, '+.2g')} from the configured δ1 = {u.f(setup.delta1, '.3g')} "
                "(within its tolerance "
                f"±{u.f(floor, '.2g')}, so δ1 is kept) and δ̂ moves up to "
                f"{d1_bound / abs(d1_j - setup.delta1):.2g}× a δ1 error: up to {u.f(d1_bound, '.2g')} — "
                "check [backlash] delta1 and the encoders' zeros"
            )
        if range_gap > max(d1_gap, d1_bound):
            why_parts.append(
                f"the observed Δθ range less the two contact deflections lies {u.f(range_gap, '.1f')} above δ̂"
            )
        if d1u is not None and (1.96 * std_base <= claim or 1.96 * s_d1 > claim):
            how = "measured at δ1 ± its standard error" if k_measured else "assumed one-for-one"
            why_parts.append(
                f"δ1 from {d1u.source} is uncertain by ±{u.f(1.96 * d1u.std, '.2f')} (95 %); "
                f"δ̂ moves ~{k_d1:.2g} {u} per {u} of δ1 ({how}), ±{u.f(1.96 * s_d1, '.2f')} "
                "of δ̂ — the online law does not correct δ1: give [backlash] delta1 or a recording "
                "that determines it"
            )
        if disagreement > 0.0 and 1.96 * std_base - disagreement - alt_gap <= claim:
            why_parts.append(
                f"the paper law and the default law (which learns the contact stiffness) disagree by "
                f"{u.f(disagreement, '.2f')}: the stated drive parameters do not fit the data "
                "(use --method default)"
            )
        if enc_bound > 0.0 and 1.96 * std_base - enc_bound - alt_gap <= claim:
            why_parts.append(
                f"the encoders' counts ({u.f(c_m, '.3g')} motor, {u.f(c_l, '.3g')} load) leave "
                f"Δθ offset by up to {u.f(enc_offset, '.2f')} depending on how they round "
                f"(δ̂ by up to {u.f(enc_bound, '.2f')}) — neither the configuration nor the "
                'recording states the convention: set [estimator] encoder_reading = "nearest" or '
                '"truncate"'
            )
        # the resolution floor alone beyond the claim: a gap small against the contact deflection
        # (the 5 µm gap of the session-35 linear axis: ±1.03 µm floor, 0.997 µm claim, δ̂ within
        # 0.3 %) — named as such, not as drive parameters the data disagree with
        s_floor = UNCERTAINTY_FLOOR * cfg.theta_def
        random_part = max(std_base - (alt_gap + disagreement + enc_bound) / 1.96, 0.0)
        if 1.96 * s_floor > claim:
            why_parts.append(
                f"the estimator resolves δ only to ±{u.per_si * 1.96 * s_floor:.3g} {u} here "
                f"({UNCERTAINTY_FLOOR:g} of the contact deflection θ_def = {u.f(cfg.theta_def, '.3g')} its "
                f"torque model smooths over), and on a gap this small against its Δθ range of "
                f"{u.f(dth_range, '.3g')} the claim is {100 * claim / max(final, 1e-300):.0f} % of δ̂: δ̂ "
                "and its interval are what the recording resolves (a longer one does not lower the floor)"
            )
            random_part = math.sqrt(max(random_part * random_part - s_floor * s_floor, 0.0))
        if 1.96 * random_part > claim or not why_parts:
            why_parts.append(
                "the data disagree with the stated drive parameters "
                + (f"(contact stiffness {kappa:.2f}× the stated model's)" if default else "")
            )
        why = "; ".join(why_parts)
        half, need = u.small(1.96 * std), u.small(claim)
        if half == need:  # "±1.0 µm, more than the 1.0 µm" read as a contradiction
            half, need = f"{u.per_si * 1.96 * std:.3g}", f"{u.per_si * claim:.3g}"
        warnings.append(
            f"the estimate is uncertain by ±{half} {u} (95 %), more than the "
            f"{need} {u} a converged estimate must meet: {why}"
        )
        # the one blocking warning whose interval states the doubt itself (a wear trend may take
        # such an estimate with its σ; every other blocking warning keeps it out)
        extra["uncertainty_warning"] = warnings[-1]
    rho = mo.torque_deflection_corr
    if rho is not None and rho < -SWAP_CORRELATION and mo.reversals >= SWAP_MIN_REVERSALS:
        # in contact the shaft torque follows the deflection and the motor pushes the load through
        # the contact it is on: the motor torque rises with Δθ (bench scenarios +0.44 … +0.92);
        # swapped motor/load channels turn Δθ around (B2: −0.78, "converged" 4–7 σ off)
        warnings.append(
            f"the motor torque falls as Δθ = θ_m/N − θ_l grows (correlation {rho:+.2f}; a motor driving "
            "its load gives a positive one): the motor and load channels are swapped, or the sign of "
            "one position or of the torque is wrong — check the [columns] mapping"
        )
    if ok and not at_bound and 1.0 / T_s < 0.99 * ONLINE_VERIFIED_RATE_HZ:
        warnings.append(
            f"note: the sample rate {1.0 / T_s:.4g} Hz is below the {ONLINE_VERIFIED_RATE_HZ:.4g} Hz down to"
            " which the 95 % interval is verified: below it the interval may miss the true δ, by an error"
            " of either sign depending on the drive and its parameters (with the bench's true parameters"
            " δ̂ met the 1 mrad goal at 1 kHz; docs/assumptions.md, 'Online estimate at 1 kHz')"
        )
    low_rate = 1.0 / T_s < 0.99 * ONLINE_VERIFIED_RATE_HZ
    if ok and not at_bound and low_rate and sigma_frac < LOW_RATE_INFORMATION_MIN:
        warnings.append(
            f"at {1.0 / T_s:.4g} Hz the excitation information {sigma_frac:.3g} is below "
            f"{LOW_RATE_INFORMATION_MIN:g} "
            f"({LOW_RATE_INFORMATION_MIN / SIGMA_FRACTION_MIN:.0f}× the minimum): at this rate it depends "
            "on where the samples hit the contact edge — estimate at "
            f"≥ {ONLINE_VERIFIED_RATE_HZ:.4g} Hz, and check K_S (a stated shaft too stiff sharpens the edge)"
        )
    if ok and not at_bound and n and not settled:
        # "not converged" with no warning said nothing (session 36, tester J's J5: bench-0C, 4 s,
        # δ̂ within its band of the truth): the settling test is named. A note, not a blocking
        # warning: unsettled is already not converged, and a wear trend takes such an estimate
        # with its σ widened by the movement (wear.estimate.unconverged_cause)
        warnings.append(
            f"note: δ̂ has not settled: it moved {u.f(window_move, '.3g')} over the last {win:.3g} s, "
            f"more than the {u.f(band, '.3g')} band a converged estimate must stay within — a longer "
            "recording (more reversals) lets it settle"
        )
    blocking = [w for w in warnings if not w.startswith("note:")]
    converged = bool(ok and settled and not blocking)
    conv = _convergence_time(chosen.track, mo.t0, T_s, n, band, final) if ok else None
    extra["delta_spread"] = a["delta_spread"]
    extra["settled"] = settled
    extra["window_movement"] = window_move
    if chosen.track.error_since:
        extra["max_abs_error_since"] = [v if v > -math.inf else None for v in chosen.track.err_max]
        extra["delta_true_last"] = chosen.track.truth_last
    t, rows = chosen.track.series()
    return EstimationResult(
        t=t,
        delta_hat=rows[:, dz.O_DELTA].copy(),
        phi_hat=rows[:, dz.O_PHI].copy(),
        omega_l_hat=rows[:, dz.O_OMEGA_HAT].copy(),
        sigma_window=rows[:, dz.O_SIGMA_WIN].copy(),
        dtheta=rows[:, dz.O_DTHETA].copy(),
        torque_hat=rows[:, dz.O_TORQUE_HAT].copy(),
        torque_meas=rows[:, dz.O_TORQUE_MEAS].copy(),
        traversals=rows[:, dz.O_TRAV].copy(),
        excitation_ok=ok,
        reason=reason,
        converged=converged,
        convergence_time_s=conv if converged else None,
        band=band,
        config=setup.check_config if chosen is check and setup.check_config is not None else cfg,
        delta_std=std,
        warnings=warnings,
        extra=extra,
    )


def _uncertainty(
    a: dict[str, float],
    extra: dict[str, Any],
    theta_def: float,
    enc_bound: float = 0.0,
    s_delta1: float = 0.0,
    angle_scale: float = 1.0,
) -> float:
    """Standard uncertainty of δ̂ [rad], from the estimator's own statistics.

    Four parts (five with ``s_delta1``) added in quadrature, plus a systematic bound added
    linearly:

    * the spread (standard deviation) of δ̂ over the last third of the run — how far the
      estimate wanders under noise;
    * the δ1 check: δ̂ of the anchored law moves one-for-one with δ1, and the joint δ/δ1 law
      only resolves δ1 to within the difference it found when that difference is below the
      floor or the check is inconclusive — half of it counts;
    * with the load observer as torque source, the model part: the stiffness scale κ
      absorbs a wrong K_S exactly but a wrong load friction or inertia only in part, so up to
      D·|1 − 1/κ| of the contact deflection D may be misread as gap (with the motor-side
      torque κ only carries the stiffness, and this part is 0); twice that
      (:data:`SWITCHED_MODEL_FACTOR`) when the switched joint δ/δ1 law is reported, which
      places both contact points with the stated model (κ held at 1);
    * a resolution floor of :data:`UNCERTAINTY_FLOOR` θ_def (smoothing of the model (11) and
      the sub-count reconstruction leave a bias of that order on the bench, measured);
    * ``enc_bound`` [rad], what the encoder reading-convention offset of Δθ (half the
      difference of the load-side counts of the two encoders) can do to δ̂ (:func:`_verdict`;
      :data:`ENCODER_OFFSET_GAIN_KAPPA` times the offset when κ is learnt): a bounded systematic error,
      not a random one, so it is added to the 95 % half-width (σ += enc_bound/1.96) rather
      than in quadrature — the interval then covers it whichever way the encoders round.
      The caller adds the other bounded alternatives the same way: the paper law's disagreement
      with the default law and, when the δ1 check is "inconsistent" or "not settled" (or
      "inconclusive" with the joint law's δ1 beyond the floor from the configured one), the
      distance to the joint δ/δ1 law's δ.
    * ``s_delta1`` [rad], an uncertain δ1 (``estimate --identify`` without ``[backlash]
      delta1``) propagated through the measured ∂δ̂/∂δ1 (:class:`Delta1Uncertainty`): the
      identification's standard error is a standard uncertainty, not a bound, so it is added in
      quadrature. A configured δ1 has none (0).

    ``angle_scale`` [-] is the recording's angle scale σ (:attr:`EstimatorConfig.angle_scale`):
    the cap of the δ1 check's part, :data:`~drivelash.params.OFFSET_FLOOR`, is taken times σ.

    Coverage of δ̂ ± 1.96 σ against the truth is measured in tests/estimation/test_robustness.py.
    """
    s_stat = a["delta_spread"] if math.isfinite(a["delta_spread"]) else 0.0
    s_d1 = 0.0
    state = extra.get("delta1_check_result")
    if (
        state == "inconclusive" or (state == "consistent" and not extra.get("delta1_check_bound"))
    ) and "delta1_check" in extra:
        s_d1 = 0.5 * min(abs(extra["delta1_check"] - extra["delta1_used"]), OFFSET_FLOOR * angle_scale)
    s_mod = 0.0
    kappa = extra.get("stiffness_scale")
    if kappa is not None and extra.get("torque_source") == "load":
        s_mod = extra["contact_deflection"] * abs(1.0 - 1.0 / max(kappa, 1e-12))
        if extra.get("offset_switched"):
            # the switched joint δ/δ1 law places *both* contact points with the stated torque
            # model (κ held at 1), the anchored law only the upper one: twice the model part
            s_mod *= SWITCHED_MODEL_FACTOR
    s_res = UNCERTAINTY_FLOOR * theta_def
    s = math.sqrt(s_stat * s_stat + s_d1 * s_d1 + s_mod * s_mod + s_res * s_res + s_delta1 * s_delta1)
    return float(s + enc_bound / 1.96)


# ----------------------------------------------------------------------------------
# the class the README shows
# ----------------------------------------------------------------------------------
class DeadzoneEstimator:
    """Online deadzone estimator: STSMO + adaptive law, chunk-able.

    Parameters
    ----------
    drivetrain : DrivetrainParams
        Drive-train parameters as known to the estimator.
    backlash : BacklashParams or float
        Known offset δ1 [rad] (``delta`` of a BacklashParams is not used).
    T_s : float
        Sample time [s] of the samples given to :meth:`step` and :meth:`run_samples`. :meth:`run`
        tunes and integrates with the recording's own period and refuses a trace whose period
        differs from ``T_s`` by more than :data:`T_S_RTOL` (relative): build the estimator with
        ``T_s=trace.T_s``.
    config : EstimatorConfig, optional
        Gains used as they are. Default: tuned by :meth:`run` from the recording (detected
        reversal frequency and torque), exactly as ``drivelash estimate`` does.
    f_exc : float, optional
        Excitation frequency [Hz] to tune for instead of the detected one.
    method : {"paper", "default"}
        Law (when ``config`` is not given).
    **overrides
        Fields of :class:`EstimatorConfig` overriding the tuning rule.

    Raises
    ------
    ParameterError
        ``drivetrain`` is not a DrivetrainParams, ``backlash`` neither a BacklashParams nor a
        number, δ1 not finite ≥ 0 [rad], or ``T_s`` not a finite number > 0 [s].

    Examples
    --------
    >>> from drivelash.sim.scenarios import get_scenario
    >>> sc = get_scenario("bench-0C")                          # true δ = 105 mrad
    >>> trace = sc.simulate(duration=6.0, seed=1)
    >>> est = DeadzoneEstimator(sc.estimator_drivetrain, sc.estimator_backlash, T_s=trace.T_s)
    >>> result = est.run(trace)
    >>> round(1e3 * result.delta), result.converged           # δ̂ [mrad]
    (105, True)
    """

    def __init__(
        self,
        drivetrain: DrivetrainParams,
        backlash: BacklashParams | float,
        T_s: float,
        config: EstimatorConfig | None = None,
        f_exc: float | None = None,
        method: Method = "default",
        **overrides: Any,
    ) -> None:
        if not isinstance(drivetrain, DrivetrainParams):
            # was: AttributeError "'NoneType' object has no attribute 'J_l'" from the tuning rule
            raise ParameterError(
                "DeadzoneEstimator",
                "drivetrain",
                f"expected a DrivetrainParams, got {type(drivetrain).__name__}"
                + (
                    " (a configuration file's [drivetrain] table: pass "
                    "load_config(path).to_drivetrain_params())"
                    if hasattr(type(drivetrain), "__params__")
                    else ""
                ),
            )
        if not (isinstance(backlash, BacklashParams) or is_real_number(backlash)):
            raise ParameterError(
                "DeadzoneEstimator",
                "backlash",
                f"expected a BacklashParams or the offset δ1 [rad] as a number, got {backlash!r}"
                + (
                    " (a configuration file's [backlash] table: pass its offset, "
                    "load_config(path).backlash.delta1)"
                    if hasattr(type(backlash), "__params__")
                    else ""
                ),
            )
        if not is_real_number(T_s):
            raise ParameterError("DeadzoneEstimator", "T_s", f"sample time must be a number [s], got {T_s!r}")
        self.drivetrain = drivetrain
        d1 = backlash.delta1 if isinstance(backlash, BacklashParams) else float(backlash)
        self.delta1 = rounded_delta1(d1)
        if not (math.isfinite(self.delta1) and self.delta1 >= 0):
            raise ParameterError("BacklashParams", "delta1", f"must be finite and >= 0, got {self.delta1!r}")
        self.T_s = float(T_s)
        if not (math.isfinite(self.T_s) and self.T_s > 0):
            # checked here, not only by the tuning rule: a given config skips it (0 divided by
            # zero, NaN failed in int(), a negative or infinite T_s was taken)
            raise ParameterError(
                "DeadzoneEstimator", "T_s", f"sample time must be finite and > 0 s, got {T_s!r}"
            )
        self.f_exc = f_exc
        self.method: Method = config.method if config is not None else method
        self.overrides = overrides
        self._given = config
        self.config = (
            config
            if config is not None
            else EstimatorConfig.tuned(drivetrain, self.T_s, f_exc or 0.5, method=method, **overrides)
        )
        self.params = build_params(drivetrain, self.delta1, self.config, self.T_s)
        self.state = dz.initial_state(self.params, self.config.delta0)
        self._row = np.empty((1, dz.N_OUT))

    def reset(self) -> None:
        """Back to δ̂ = δ0 [rad] and zero observer state.

        Returns
        -------
        None
            :attr:`state` is replaced by a fresh one (the parameters, and so T_s, are kept).
        """
        self.state = dz.initial_state(self.params, self.config.delta0)

    @property
    def state(self) -> np.ndarray:
        """The explicit estimator state (see :func:`~drivelash.estimation.deadzone.initial_state`).

        A snapshot (``est.state.copy()``) may be assigned back, to this estimator or to one with
        the same parameters. Assigning checks the array: C-contiguous float64 of this
        estimator's exact state length (it depends on T_s through the σ window), else a one-line
        :class:`~drivelash.errors.ParameterError` naming the expected and the given shape.
        """
        return self._state

    @state.setter
    def state(self, value: np.ndarray) -> None:
        self._state = dz.check_state(value, self.params, "DeadzoneEstimator")

    def step(self, sample: np.ndarray | tuple[float, ...]) -> np.ndarray:
        """Process one sample (θ_m, ω_m, θ_l, ω_l[, u]); returns the output row (see ``deadzone_run``).

        Parameters
        ----------
        sample : array_like
            4 or 5 values: θ_m [rad], ω_m [rad/s], θ_l [rad], ω_l [rad/s][, motor torque u
            [N·m]], one sample period T_s [s] after the previous one.

        Returns
        -------
        numpy.ndarray
            The output row, shape (9,) (columns as ``deadzone_run``: δ̂ [rad] first); a copy.

        Raises
        ------
        DataError
            ``sample`` does not hold 4 or 5 values (one line naming the given shape), or θ_m,
            ω_m, θ_l or ω_l is not finite (one line naming the column and sample 0); the state
            is then unchanged. A NaN torque u is allowed (the shaft torque then comes from the
            load observer for that sample).
        """
        s = sample
        shape = np.shape(s)
        if shape not in ((dz.N_IN,), (dz.N_IN + 1,)):
            raise DataError(
                f"sample: expected 4 or 5 values θ_m, ω_m, θ_l, ω_l[, torque_m], got shape {shape}"
            )
        u = float(s[4]) if len(s) > 4 else math.nan
        x = (float(s[0]), float(s[1]), float(s[2]), float(s[3]))
        for c, v in enumerate(x):
            if not math.isfinite(v):
                raise DataError(dz.nonfinite_message(v, 0), column=dz.INPUT_COLUMNS[c])
        dz.deadzone_step(self._state, x[0], x[1], x[2], x[3], u, self.params, self._row, 0)
        return self._row[0].copy()

    def run_samples(self, samples: np.ndarray) -> np.ndarray:
        """Process a block of samples, shape (n, 4) or (n, 5); returns outputs (n, 9), keeps the state.

        ``samples`` is converted to a C-contiguous float64 array; columns θ_m, ω_m, θ_l, ω_l[, u]
        in that order (as :func:`samples_of`).

        Parameters
        ----------
        samples : array_like
            Shape (n, 4) or (n, 5): θ_m [rad], ω_m [rad/s], θ_l [rad], ω_l [rad/s][, motor
            torque u [N·m]], sampled at this estimator's T_s [s].

        Returns
        -------
        numpy.ndarray
            Outputs, shape (n, 9) (columns as ``deadzone_run``: δ̂ [rad] first).

        Raises
        ------
        DataError
            ``samples`` of another shape, e.g. (n, 3) or a transposed (5, n) block (one line
            naming the expected and the given shape), or a non-finite θ_m, ω_m, θ_l or ω_l (one
            line naming the column and the 0-based sample within this call: a NaN there would
            stay in the state and freeze δ̂ for good). Nothing of the block is run then and the
            state is unchanged. A NaN torque u is allowed (that sample's shaft torque comes from
            the load observer).
        """
        samples = np.ascontiguousarray(samples, dtype=np.float64)
        dz.check_samples(samples)
        self._state, out = dz.deadzone_run(self._state, samples, self.params)
        return out

    def run(
        self,
        trace: Trace,
        chunk: int | None = None,
        delta_true: np.ndarray | None = None,
        keep: Literal["full", "decimated"] = "full",
    ) -> EstimationResult:
        """Estimate over a whole trace with the verdict, plausibility checks and δ1 check.

        The same two-pass procedure as ``drivelash estimate`` (:func:`estimate_blocks`): the
        gains are tuned from the recording unless a ``config`` was given, and the kernel
        integrates with the recording's sample period, which must be this estimator's ``T_s``
        (within :data:`T_S_RTOL`, relative). Starts from δ̂ = δ0 (the state of
        :meth:`run_samples` is not used).

        Parameters
        ----------
        trace : Trace
            Needs ``theta_m``, ``omega_m``, ``theta_l``, ``omega_l``; ``torque_m`` is used
            when present; ``delta_true`` for the convergence time when present.
        chunk : int, optional
            Block length (the result does not depend on it).
        delta_true : numpy.ndarray, optional
            True δ(t) [rad]; default the trace's ``delta_true`` column if any.
        keep : {"full", "decimated"}
            Keep every output row or a decimated series.

        Returns
        -------
        EstimationResult
            δ̂(t) [rad], the estimate with its uncertainty [rad] and the verdict.

        Raises
        ------
        ParameterError
            The trace's sample period [s] differs from ``T_s`` by more than :data:`T_S_RTOL`
            (one line naming both periods): the estimator was built for another rate.
        DataError
            A missing or non-finite input column, or time not strictly increasing.
        """
        if delta_true is not None:
            trace = trace.with_columns({"delta_true": np.broadcast_to(delta_true, (len(trace),))})
        blocks = trace_blocks(trace, chunk if chunk and chunk > 0 else BLOCK)
        motion = scan_blocks(blocks, self.drivetrain.N)  # pass 1, as estimate_blocks would run it
        if motion.n >= 2:
            check_sample_period(self.T_s, motion.T_s, "DeadzoneEstimator", median=trace.T_s)
        return estimate_blocks(
            self.drivetrain,
            self.delta1,
            blocks,
            method=self.method,
            config=self._given,
            overrides=self.overrides,
            f_exc=self.f_exc,
            keep=keep,
            motion=motion,
            encoder_reading=trace.meta.get("encoder_reading"),
            axis=trace.meta.get("axis"),
        )


def with_method(config: EstimatorConfig, method: Method) -> EstimatorConfig:
    """Copy of ``config`` with another ``method``."""
    return replace(config, method=method)


def samples_of(trace: Trace) -> np.ndarray:
    """The kernel's input block of a trace: (n, 4), or (n, 5) with the motor torque."""
    return _block_samples(dict(trace.columns), 0, TORQUE_COLUMN in trace)


__all__ += ["scan_trace", "samples_of", "with_method"]
