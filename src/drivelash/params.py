"""Physical parameters and gains as frozen, validated dataclasses.

Symbols follow Papageorgiou et al. (2019), spec 01 §1, and the rack-and-pinion
paper, spec 02 §2. Every field carries its unit in the docstring. Objects are
immutable: an estimator never changes a plant's parameters — adapted values live
in estimator state. Use :func:`dataclasses.replace` to derive a variant.

Validation happens at construction and raises :class:`~drivelash.errors.ParameterError`
naming the class and the field.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import asdict, dataclass, fields
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from drivelash.errors import ParameterError

__all__ = [
    "BacklashParams",
    "CascadeGains",
    "DrivetrainParams",
    "EstimatorConfig",
    "SensorParams",
]

if TYPE_CHECKING:  # annotation only: params does not import the estimation layer
    from drivelash.estimation.motion import MotionSummary


def is_real_number(value: object) -> bool:
    """True for a real scalar — Python's or numpy's (``np.float32`` from a computed array),
    0-d arrays excluded — and not a bool."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)


#: Default projection bound δ_max of the online law [rad] (:meth:`EstimatorConfig.tuned`).
DELTA_MAX_DEFAULT = 2.0


def _delta1_unit_hint(delta1: float, axis: str | None = None) -> str:
    """What a δ1 slip most likely was: mrad written for rad, or µm written for m on a linear axis
    (session 34 tester G, G10: "if 10 is in mrad, write 0.01" sent a linear axis to 10 mm)."""
    if axis == "prismatic":
        return f"δ1 is in m — if {delta1:g} is in µm, write {delta1 / 1e6:g}; if in mm, {delta1 / 1e3:g}"
    return f"δ1 is in rad — if {delta1:g} is in mrad, write {delta1 / 1e3:g}"


def check_delta1_bound(owner: str, delta1: float, delta_max: float, axis: str | None = None) -> None:
    """Refuse an offset δ1 [rad] larger than the estimator's bound δ_max [rad].

    δ1 lies inside the gap (0 ≤ δ1 ≤ δ) and the online law keeps δ ≤ δ_max, so δ1 > δ_max is a
    contradiction — typically δ1 written in mrad (``delta1 = 93`` for 0.093 rad), which the
    estimator would otherwise run with and report as an unexcited recording. A δ1 below δ_max
    but still far off (``1.0`` for 1 mrad) is caught once the recording is seen:
    :func:`delta1_outside_range`.

    ``axis`` is the recording's axis kind when known ("prismatic": δ1 in m, the hint reads µm).

    Raises
    ------
    ParameterError
        Naming ``owner`` and ``delta1``, with δ1 read as mrad (µm on a prismatic axis).
    """
    if delta1 > delta_max:
        si = "m" if axis == "prismatic" else "rad"
        raise ParameterError(
            owner,
            "delta1",
            f"δ1 = {delta1:g} {si} exceeds δ_max = {delta_max:g} {si}, the largest gap the estimator "
            f"allows (0 ≤ δ1 ≤ δ ≤ δ_max); {_delta1_unit_hint(delta1, axis)}",
        )


#: :func:`delta1_outside_range`: the Δθ seen must span more than this multiple of the peak contact
#: deflection (the data crossed free play, not only a flank's elastic deflection) …
DELTA1_GAP_TRAVEL_FACTOR = 4.0
#: … and the configured lower contact (Δθ = −δ1) must lie further beyond that range than this
#: multiple of its width …
DELTA1_OUTSIDE_RANGE_FACTOR = 1.0
#: … and than this [rad] times the recording's angle scale σ (:func:`angle_scale_of`; unscaled
#: until session 34, when δ1 = 0.1 … 10 mm on a linear axis with a 50 µm Δθ range — 5× to 500× the
#: gap — was read as "one flank keeps the load", tester G, G10).
DELTA1_OUTSIDE_FLOOR = 0.05


def delta1_outside_range(
    delta1: float,
    dtheta_min: float,
    dtheta_max: float,
    deflection: float,
    angle_scale: float = 1.0,
    axis: str | None = None,
) -> str | None:
    """The second stage of :func:`check_delta1_bound`, with the recording seen: a δ1 whose lower
    contact lies far outside the motor–load offsets the recording shows; None when it does not.

    For a recording whose load moved back and forth with the shaft torque reversing, but in
    which the law saw no crossing of the gap (the caller's condition): if Δθ = θ_m/N − θ_l
    travelled more than :data:`DELTA1_GAP_TRAVEL_FACTOR` × the peak contact deflection, the
    drive crossed free play and sat on both contacts — on the lower one Δθ = −δ1 − deflection,
    so a correct δ1 has −δ1 at the lowest Δθ seen. (A load kept on one flank by gravity moves
    Δθ only by its deflection and is not judged.) A δ1 that puts −δ1 more than
    ``max(DELTA1_OUTSIDE_RANGE_FACTOR × (max − min), DELTA1_OUTSIDE_FLOOR)`` beyond the range is
    a wrong δ1 (a unit slip: ``1.0`` for 1 mrad), not a recording without excitation, which
    is what the estimator would otherwise report.

    Parameters
    ----------
    delta1 : float
        The configured δ1 [rad] (in the recorded frame).
    dtheta_min, dtheta_max : float
        The lowest and highest Δθ of the recording [rad].
    deflection : float
        The largest contact deflection [rad] (peak shaft torque / contact stiffness).
    angle_scale : float
        The recording's angle scale σ [-]: the floor :data:`DELTA1_OUTSIDE_FLOOR` is taken times σ.
    axis : {"rotary", "prismatic"}, optional
        The recording's axis kind: the message's unit (m on a prismatic axis).
    """
    width = dtheta_max - dtheta_min
    if not (math.isfinite(width) and width > DELTA1_GAP_TRAVEL_FACTOR * deflection):
        return None
    margin = max(DELTA1_OUTSIDE_RANGE_FACTOR * width, DELTA1_OUTSIDE_FLOOR * float(angle_scale))
    if dtheta_min - margin <= -delta1 <= dtheta_max + margin:
        return None
    si = "m" if axis == "prismatic" else "rad"
    head = (
        f"[backlash] delta1 = {delta1:.4g} {si} is outside the observed motor–load offset range "
        f"[{dtheta_min:.4g}, {dtheta_max:.4g}] {si} (Δθ = θ_m/N − θ_l, whose lower contact is at "
        f"−δ1) — "
    )
    if not dtheta_min - margin <= 0.0 <= dtheta_max + margin:
        # Δθ = 0 (motor and load at their zeros) is never near the gap: the encoders' zeros are
        # offset, whatever δ1's unit (session 30 tester A, M4: "wrong unit?" for a 200.6 rad offset)
        return head + (
            f"the encoders' zeros are offset: add offset = {dtheta_min + delta1:.6g} {si} to theta_l "
            "in [columns] to put the lower contact at −δ1 (or identify δ1 with --identify)"
        )
    return head + f"wrong unit? {_delta1_unit_hint(delta1, axis)}"


def require_finite(obj: object) -> None:
    """Raise :class:`ParameterError` naming the first non-finite numeric field of ``obj``."""
    for f in fields(obj):  # type: ignore[arg-type]
        v = getattr(obj, f.name)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            continue
        if not math.isfinite(v):
            raise ParameterError(type(obj).__name__, f.name, f"must be finite, got {v!r}")


#: A δ1 in [−DELTA1_ROUNDING, 0) [rad or m] is a computed zero's rounding (δ/2 − 0.5·δ in floating
#: point gave −8.5e-22: tester I's I7) and is read as 0; a picometre or picoradian lies far below
#: any encoder's count (a 2³² count encoder: 1.5e-9 rad). Anything more negative is refused.
DELTA1_ROUNDING = 1e-12


def rounded_delta1(delta1: float) -> float:
    """``delta1`` [rad or m], with a negative value within :data:`DELTA1_ROUNDING` of 0 read as 0."""
    return 0.0 if -DELTA1_ROUNDING <= delta1 <= 0.0 else delta1  # −0.0 too: "−0.000 mrad" said nothing


def require_positive(obj: object, *names: str) -> None:
    """Raise :class:`ParameterError` naming the first of ``names`` that is not > 0."""
    for n in names:
        v = getattr(obj, n)
        if not v > 0:
            raise ParameterError(type(obj).__name__, n, f"must be > 0, got {v!r}")


def require_non_negative(obj: object, *names: str) -> None:
    """Raise :class:`ParameterError` naming the first of ``names`` that is not >= 0."""
    for n in names:
        v = getattr(obj, n)
        if not v >= 0:
            raise ParameterError(type(obj).__name__, n, f"must be >= 0, got {v!r}")


@dataclass(frozen=True)
class DrivetrainParams:
    """Two-mass drive train, eqs (1)–(7) of spec 01.

    Parameters
    ----------
    J_m : float
        Motor-side inertia [kg·m²].
    J_l : float
        Load-side inertia [kg·m²].
    N : float
        Gear ratio θ_m / θ_l [-] (1 for a direct coupling).
    K_S : float
        Shaft stiffness [N·m/rad].
    D_S : float
        Shaft damping [N·m·s/rad].
    T_Cm, T_Cl : float
        Coulomb friction torque, motor / load side [N·m].
    beta_m, beta_l : float
        Viscous friction coefficient, motor / load side [N·m·s/rad].
    T_Sm, T_Sl : float
        Static (breakaway) friction torque, motor / load side [N·m]; 0 means none.
        When non-zero it must be ≥ the Coulomb torque of that side.
    omega_s : float
        Stribeck velocity of the static-friction decay [rad/s].

    Raises
    ------
    ParameterError
        A field outside its valid range (one line naming the class and the field).
    """

    J_m: float
    J_l: float
    N: float
    K_S: float
    D_S: float
    T_Cm: float = 0.0
    T_Cl: float = 0.0
    beta_m: float = 0.0
    beta_l: float = 0.0
    T_Sm: float = 0.0
    T_Sl: float = 0.0
    omega_s: float = 0.01

    def __post_init__(self) -> None:
        require_finite(self)
        require_positive(self, "J_m", "J_l", "N", "K_S", "omega_s")
        require_non_negative(self, "D_S", "T_Cm", "T_Cl", "beta_m", "beta_l", "T_Sm", "T_Sl")
        for s, c in (("T_Sm", "T_Cm"), ("T_Sl", "T_Cl")):
            if getattr(self, s) and getattr(self, s) < getattr(self, c):
                raise ParameterError(type(self).__name__, s, f"static friction must be 0 or >= {c}")

    def as_array(self) -> np.ndarray:
        """Parameters as a float64 array in field order (for numba kernels)."""
        return np.array([getattr(self, f.name) for f in fields(self)], dtype=np.float64)

    def to_dict(self) -> dict[str, float]:
        """Plain dict of the fields (e.g. for TOML/JSON output)."""
        return asdict(self)


@dataclass(frozen=True)
class BacklashParams:
    """Deadzone of the coupling, eq (10)–(12) of spec 01.

    Parameters
    ----------
    delta : float
        Total deadzone (gap) angle δ [rad], load-side coordinates.
    delta1 : float
        Initial offset δ1 [rad], 0 ≤ δ1 ≤ δ: the shafts are disengaged for
        −δ1 ≤ Δθ ≤ δ − δ1.
    alpha : float
        Smoothness of the varying-stiffness model (11) [1/rad]; the smooth model
        tends to the deadzone model as α → ∞.

    Raises
    ------
    ParameterError
        A field outside its valid range (one line naming the class and the field).
    """

    delta: float
    delta1: float
    alpha: float = 1000.0

    def __post_init__(self) -> None:
        require_finite(self)
        require_non_negative(self, "delta")
        require_positive(self, "alpha")
        if not 0.0 <= self.delta1 <= self.delta:
            raise ParameterError(
                type(self).__name__,
                "delta1",
                f"must lie in [0, delta] = [0, {self.delta}], got {self.delta1!r}",
            )


@dataclass(frozen=True)
class CascadeGains:
    """Discrete P position / PI velocity cascade on the motor (spec 01 §1, spec 02 §2).

    Parameters
    ----------
    K_v : float
        Position-loop proportional gain [1/s] (velocity command per position error).
    K_p : float
        Velocity-loop proportional gain [N·m·s/rad].
    T_n : float
        Velocity-loop integral (reset) time [s].
    torque_limit : float
        Symmetric limit of the commanded motor torque [N·m].
    k_ff : float
        Velocity feed-forward gain [-], 0 (off) … 1 (full).
    T_s : float
        Control period [s] (zero-order hold of the torque command).

    Raises
    ------
    ParameterError
        A field outside its valid range (one line naming the class and the field).
    """

    K_v: float
    K_p: float
    T_n: float
    torque_limit: float
    k_ff: float = 1.0
    T_s: float = 125e-6

    def __post_init__(self) -> None:
        require_finite(self)
        require_positive(self, "K_v", "K_p", "T_n", "torque_limit", "T_s")
        if not 0.0 <= self.k_ff <= 1.0:
            raise ParameterError(type(self).__name__, "k_ff", f"must lie in [0, 1], got {self.k_ff!r}")


@dataclass(frozen=True)
class SensorParams:
    """Sensor model: encoder quantisation and Gaussian noise.

    Parameters
    ----------
    counts_m, counts_l : int
        Encoder counts per revolution on the motor / load side; 0 means ideal
        (no quantisation).
    sigma_theta_m, sigma_theta_l : float
        Standard deviation of white position noise [rad].
    sigma_omega_m, sigma_omega_l : float
        Standard deviation of white velocity noise [rad/s].
    sigma_torque : float
        Standard deviation of white noise on the measured motor torque [N·m].
    velocity_source : {"measured", "differentiated"}
        ``"measured"``: velocity = true velocity + noise (as a drive reports it);
        ``"differentiated"``: backward difference of the quantised position.

    Raises
    ------
    ParameterError
        A field outside its valid range (one line naming the class and the field).
    """

    counts_m: int = 0
    counts_l: int = 0
    sigma_theta_m: float = 0.0
    sigma_theta_l: float = 0.0
    sigma_omega_m: float = 0.0
    sigma_omega_l: float = 0.0
    sigma_torque: float = 0.0
    velocity_source: Literal["measured", "differentiated"] = "measured"

    def __post_init__(self) -> None:
        require_finite(self)
        require_non_negative(
            self,
            "counts_m",
            "counts_l",
            "sigma_theta_m",
            "sigma_theta_l",
            "sigma_omega_m",
            "sigma_omega_l",
            "sigma_torque",
        )
        for n in ("counts_m", "counts_l"):
            if int(getattr(self, n)) != getattr(self, n):
                raise ParameterError(type(self).__name__, n, "must be a whole number of counts")
        if self.velocity_source not in ("measured", "differentiated"):
            raise ParameterError(
                type(self).__name__,
                "velocity_source",
                f"must be 'measured' or 'differentiated', got {self.velocity_source!r}",
            )


#: Law of the deadzone estimator: the paper's gradient law or the improved default law.
Method = Literal["paper", "default"]


#: δ1 check: a configured δ1 within this of the joint law's δ̂1 is consistent [rad].
OFFSET_FLOOR = 1e-3


def delta1_tolerance(offset_switch: float = OFFSET_FLOOR, angle_scale: float = 1.0) -> float:
    """Distance [rad] up to which a configured δ1 is consistent with the data's: ``offset_switch``
    (``[estimator]``), never below :data:`OFFSET_FLOOR` × ``angle_scale`` (the online δ1 check
    and, with ``estimate --identify``, the comparison with the identified δ1).

    ``angle_scale`` [-] is the recording's angle scale σ (:func:`angle_scale_of`, the online
    estimator's :attr:`EstimatorConfig.angle_scale`): 1 for a recording whose Δθ spans at least
    :data:`ANGLE_SCALE_RANGE`; the floor follows a smaller one (a linear axis in m, a precision
    gearbox), where a fixed 1 mrad is several times the gap (C8 of session 31).
    """
    return max(float(offset_switch), OFFSET_FLOOR * float(angle_scale))


def verdict_scale(angle_scale: float, delta_hat: float) -> float:
    """Scale σ_δ [-] of the verdict's accuracy constants (δ1 floor, convergence band and claim) for
    an estimate δ̂: the angle scale σ, capped by δ̂ / :data:`ANGLE_SCALE_RANGE`.

    σ follows the Δθ range, which is the gap plus the contact deflections on both sides. Where the
    deflection is as large as the gap (a compliant drive, a linear axis with µm of lost motion),
    σ makes the 1 mrad δ1 floor and the 2 mrad band and claim large fractions of δ itself —
    on tester G's 20 µm linear gap (Δθ range 73 µm) a δ1 floor of 7.3 µm, so a δ1 4 µm off was
    "consistent" and δ̂ 35 % low "converged" (session 35). The constants were validated on gaps
    of at least :data:`ANGLE_SCALE_RANGE` at σ = 1, i.e. as at most 10 % (floor) and 20 % (band,
    claim) of δ: the cap keeps those fractions for a smaller δ̂ and leaves every gap of 10 mrad ×
    σ or more as it was.

    Parameters
    ----------
    angle_scale : float
        The recording's angle scale σ (:func:`angle_scale_of`) [-].
    delta_hat : float
        The estimate judged [rad; m on a linear axis].

    Returns
    -------
    float
        min(σ, δ̂ / :data:`ANGLE_SCALE_RANGE`), never below :data:`ANGLE_SCALE_MIN`; σ when δ̂ is
        not finite.
    """
    if not math.isfinite(delta_hat):
        return float(angle_scale)
    return max(min(float(angle_scale), float(delta_hat) / ANGLE_SCALE_RANGE), ANGLE_SCALE_MIN)


#: Δθ range [rad] (:attr:`~drivelash.estimation.motion.MotionSummary.dtheta_range`) from which
#: down the online tuning rule's angle constants — 1 mrad of contact deflection in T_ref, the
#: bounds 10³ … 10⁵ 1/rad of α, the 1 rad of relative motion in the observers' ρ, the 2 mrad
#: convergence band and claim, the 1 mrad δ1 floor, the 50 mrad range-excess floor — are scaled
#: by σ = Δθ range / this. 10 mrad is the smallest gap the rule was validated on at σ = 1 (the
#: random drives of tests/estimation/test_generalisation.py, δ 10–500 mrad; the 18 bench
#: scenarios span ≥ 105 mrad, the acceptance fleet ≈ 45 mrad, so none of them changes). Bench-0B
#: rewritten in units s = 0.5 … 0.02 with the fixed constants stayed within 0.2 mrad·s of the
#: unscaled δ̂ (185.916 mrad; 185.85 … 185.72) while s = 1e-2 / 1e-3 / 1e-4 gave 185.61 / 182.22 /
#: 179.8 "converged" outside their intervals (session 31, tester C, C8; docs/assumptions.md).
ANGLE_SCALE_RANGE = 1e-2
#: Smallest angle scale σ [-]: a Δθ range below ANGLE_SCALE_RANGE × this (0.1 µrad … 1 µrad,
#: the resolution of a 24-bit encoder) is no measured relative motion; the constants stay at
#: this scale and the estimate is not called converged (a blocking warning names the cause).
ANGLE_SCALE_MIN = 1e-4


#: The Δθ reconstruction's velocity random walk may reach this fraction of θ_def before its
#: cut-off is raised (:func:`reconstruction_cutoff`): the estimator's resolution floor is 0.1 θ_def
#: (``estimator.UNCERTAINTY_FLOOR``); noise in Δθ beyond it biases κ low, as an error in the
#: regressor does (errors-in-variables), and δ̂ with it — uncounted by the interval.
VELOCITY_NOISE_FRACTION = 0.1
#: Largest cut-off of the reconstruction, × 1/T_s: c = 1 − exp(−20) — the recorded Δθ itself.
OMEGA_C_MAX_TS = 20.0


def reconstruction_cutoff(omega_c0: float, T_s: float, theta_def: float, N: float, motion: Any) -> float:
    """Cut-off ω_c [rad/s] of the default law's Δθ complementary filter.

    The filter integrates the measured Δω = ω_m/N − ω_l between encoder updates to resolve Δθ
    below a count; white velocity noise σ_Δω becomes a random walk the position pulls back,
    std σ_Δω √(T_s / (2 ω_c)). ``omega_c0`` (10 ω_r, the rule for encoders whose quantisation
    dominates) is kept while that walk stays below :data:`VELOCITY_NOISE_FRACTION` θ_def. Beyond
    it the cut-off balancing the two errors is taken: the walk's variance σ_Δω² T_s / (2 ω_c)
    plus the quantisation's σ_q² ω_c T_s / 2 (σ_q² = (q_m/N)² / 12 + q_l² / 12, a first-order
    low-pass of white quantisation noise) is smallest at ω_c = σ_Δω / σ_q — never below
    ``omega_c0`` and at most :data:`OMEGA_C_MAX_TS` / T_s (unquantised positions: the recorded Δθ).

    Session 36, tester I's I2: on a ball-screw axis (2e8 N/m, 2 µm gap, 10 nm counts, θ_def
    0.53 µm) white velocity noise of 3e-4 m/s on both channels made the walk 0.42 µm at
    ω_c0 = 63 rad/s: κ 0.46, δ̂ 20 % low and "converged" outside its interval; the bench's
    2048-count encoders with 0.032 rad/s noise balance at 36 rad/s, where 10 ω_r = 31 rad/s is
    kept (walk 2e-3 of θ_def).
    """
    s_dw = getattr(motion, "velocity_noise", math.nan) if motion is not None else math.nan
    if not (math.isfinite(s_dw) and s_dw > 0.0 and omega_c0 > 0.0 and theta_def > 0.0):
        return omega_c0
    if s_dw * math.sqrt(T_s / (2.0 * omega_c0)) <= VELOCITY_NOISE_FRACTION * theta_def:
        return omega_c0
    s_q = math.sqrt(((motion.count_m / N) ** 2 + motion.count_l**2) / 12.0)
    top = OMEGA_C_MAX_TS / T_s
    return max(omega_c0, min(s_dw / s_q if s_q > 0.0 else top, top))


def angle_scale_of(dtheta_range: float) -> float:
    """The recording's angle scale σ [-] for the tuning rule: min(1, Δθ range / 10 mrad).

    Parameters
    ----------
    dtheta_range : float
        max − min of the recorded Δθ = θ_m/N − θ_l [rad]; NaN when unknown (no recording seen).

    Returns
    -------
    float
        1 for a range of :data:`ANGLE_SCALE_RANGE` or more (and when unknown), else the range
        divided by it, never below :data:`ANGLE_SCALE_MIN`.
    """
    if not math.isfinite(dtheta_range):
        return 1.0
    return min(1.0, max(dtheta_range / ANGLE_SCALE_RANGE, ANGLE_SCALE_MIN))


#: The motor-side shaft torque is used when N T_C,m ≤ this × the expected shaft torque.
MOTOR_FRICTION_RATIO = 2.0
#: … and N² J_m ≤ this × J_l.
MOTOR_INERTIA_RATIO = 10.0


#: Encoder reading conventions (:attr:`EstimatorConfig.encoder_reading`).
ENCODER_READINGS = ("unknown", "nearest", "truncate")


@dataclass(frozen=True)
class EstimatorConfig:
    """Gains of the online deadzone estimator (never modified by the estimator).

    The tuning rule of :meth:`tuned` is documented in :mod:`drivelash.estimation.estimator`.

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
        Run the δ1 check alongside (both methods): the default law with δ1 estimated jointly.
    offset_switch : float
        |δ̂1 − δ1| up to which the configured δ1 is consistent with the data [rad].
    theta_def : float
        Typical contact deflection [rad]: scales the initial gain of κ, P0 = q_aux P_max/θ_def².
    q_aux : float
        Gain of κ relative to δ's [-].
    reset_e : float
        Gain reset threshold on the filtered residual, in units of θ_def [-]; 0 = off.
    reset_t : float
        Time the residual must stay beyond it (in informative samples) [s].
    torque_source : {"load", "motor"}
        Shaft torque from the load observer J_l φ̂ or from the motor side (recorded motor
        torque; default method only, falls back to the load observer without the column).
    k1_m, k2_m : float
        Gains of the motor-side observer [rad^½/s^{3/2}], [rad/s³].
    lam_g : float
        Rate of the torque-offset learning in the gap [1/s] (default method; 0 = off).
    omega_g : float
        Speed above which the gap offset is learnt, load side [rad/s].
    gap_margin : float
        Margin of the gap region used for it, fraction of the modelled gap [-].
    contact_bound : bool
        Data-consistency bounds of the default method: while a contact torque is confirmed,
        a flank no further out than the extreme Δθ seen, and the flank recovery
        (:mod:`drivelash.estimation.deadzone`, ``P_BOUND``).
    angle_scale : float
        Angle scale σ of the recording [-] (:func:`angle_scale_of`): the tuning rule's and the
        verdict's absolute angle constants (1 mrad of deflection, α's bounds, the 1 rad of ρ, the
        2 mrad band and claim, the 1 mrad δ1 floor, the 50 mrad range-excess floor) are
        multiplied by it; 1 unless the recording's Δθ spans less than 10 mrad.
    encoder_reading : {"unknown", "nearest", "truncate"}
        How both encoders turn an angle into a count: the nearest count, or the count below
        (truncation, as a counter reads). With a gear or unequal counts this offsets Δθ by up
        to half the difference of their load-side counts; "truncate" corrects it, "nearest"
        needs no correction, "unknown" widens the uncertainty by it (and a recording's own
        metadata ``encoder_reading``, e.g. the project's simulator, is used when present).

    Raises
    ------
    ParameterError
        A field outside its valid range (one line naming the class and the field).
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
    offset_switch: float = OFFSET_FLOOR
    theta_def: float = 1e-3
    q_aux: float = 0.1
    reset_e: float = 0.0
    reset_t: float = 0.02
    torque_source: Literal["load", "motor"] = "load"
    k1_m: float = 1.0
    k2_m: float = 1.0
    lam_g: float = 0.0
    omega_g: float = 0.1
    gap_margin: float = 0.15
    contact_bound: bool = True
    angle_scale: float = 1.0
    encoder_reading: Literal["unknown", "nearest", "truncate"] = "unknown"

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
            "k1_m",
            "k2_m",
            "omega_g",
            "angle_scale",
        ):
            v = getattr(self, f)
            if isinstance(v, bool) or not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(name, f, f"must be finite and > 0, got {v!r}")
        for f in ("delta0", "omega_c", "tau_f", "omega_eps", "reset_e", "lam_g", "gap_margin"):
            v = getattr(self, f)
            if isinstance(v, bool) or not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ParameterError(name, f, f"must be finite and >= 0, got {v!r}")
        if self.gap_margin >= 0.5:
            raise ParameterError(name, "gap_margin", f"must be < 0.5, got {self.gap_margin!r}")
        if self.delta0 > self.delta_max:
            raise ParameterError(
                name, "delta0", f"must be <= delta_max = {self.delta_max}, got {self.delta0}"
            )
        if self.method not in ("paper", "default"):
            raise ParameterError(name, "method", f"must be 'paper' or 'default', got {self.method!r}")
        if self.encoder_reading not in ENCODER_READINGS:
            raise ParameterError(
                name,
                "encoder_reading",
                f"must be one of {', '.join(ENCODER_READINGS)}, got {self.encoder_reading!r}",
            )
        if self.torque_source not in ("load", "motor"):
            raise ParameterError(
                name, "torque_source", f"must be 'load' or 'motor', got {self.torque_source!r}"
            )

    @classmethod
    def tuned(
        cls,
        drivetrain: DrivetrainParams,
        T_s: float,
        f_exc: float = 0.5,
        method: Method = "default",
        delta_max: float | None = None,
        motion: MotionSummary | None = None,
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
            Excitation (motion reversal) frequency [Hz]; ``motion.f_exc`` when ``motion`` is given.
        method : {"paper", "default"}
            Law to tune.
        delta_max : float, optional
            Upper bound of δ [rad]; default 2 rad.
        motion : MotionSummary, optional
            Pass-1 summary of the recording: scales the contact threshold with the torque it
            carries, chooses the motor-side torque source when it has a motor torque and sets
            the angle scale σ from its Δθ range (:func:`angle_scale_of`; 1 without ``motion``).
        **overrides
            Any field of :class:`EstimatorConfig` to set explicitly (``None`` values ignored).

        Raises
        ------
        ParameterError
            ``T_s`` or ``f_exc`` not a finite number > 0, or a field the tuning or an override gives
            that :class:`EstimatorConfig` refuses.
        """
        if motion is not None:
            f_exc = motion.f_exc
        if not (T_s > 0 and math.isfinite(T_s)):
            raise ParameterError(cls.__name__, "T_s", f"sample time must be > 0, got {T_s!r}")
        if not (f_exc > 0 and math.isfinite(f_exc)):
            raise ParameterError(cls.__name__, "f_exc", f"must be > 0, got {f_exc!r}")
        J_l, K_S, N, J_m = drivetrain.J_l, drivetrain.K_S, drivetrain.N, drivetrain.J_m
        w_r = 2.0 * math.pi * f_exc
        w_n = math.sqrt(K_S / J_l)
        motor = method == "default" and motion is not None and motion.torque_rms is not None
        if motor and motion is not None:
            # the motor side sees the shaft torque through its own friction: use it only when
            # that friction (load side, N T_C,m) is not much larger than the shaft torque
            T_shaft = J_l * motion.a_typ + drivetrain.T_Cl + drivetrain.beta_l * motion.v_typ
            motor = N * drivetrain.T_Cm <= MOTOR_FRICTION_RATIO * T_shaft
            # … and through its reflected inertia N² J_m: when it dwarfs J_l the shaft torque is
            # a small perturbation of the motor's own dynamics
            motor = motor and N * N * J_m <= MOTOR_INERTIA_RATIO * J_l
        # the recording's angle scale: every absolute angle constant below follows a Δθ range
        # smaller than ANGLE_SCALE_RANGE (a linear axis in m, a precision gearbox); 1 otherwise
        sigma = overrides.get("angle_scale")
        if sigma is None:
            sigma = angle_scale_of(motion.dtheta_range if motion is not None else math.nan)
        src = overrides.get("torque_source")
        if src is not None:
            motor = src == "motor"
        # contact torque scale: friction, or 1 mrad of shaft deflection if frictionless —
        # capped by the torque the recording carries (a stiff drive's contact torque can be
        # far below 1 mrad of deflection)
        T_ref = max(drivetrain.T_Cl, 1e-3 * sigma * K_S)
        if motion is not None:
            if motor and motion.torque_rms is not None:
                T_data = N * motion.torque_rms
            else:
                T_data = J_l * motion.a_typ + drivetrain.T_Cl + drivetrain.beta_l * motion.v_typ
            if T_data > 0:
                T_ref = min(T_ref, T_data)
        T_thr = 0.5 * T_ref
        rho = (K_S / J_l) * w_r * sigma  # relative speed ω_r · 1 rad (× σ)
        # slower observer when the sample time is coarse against the shaft resonance
        s_ts = min(1.0, 0.1 / (w_n * T_s))
        k2 = 1.1 * rho * s_ts * s_ts
        k1 = 1.5 * math.sqrt(rho) * s_ts
        rho_m = K_S * w_r / (N * J_m) * sigma
        w_nm = math.sqrt(K_S / (N * N * J_m))
        s_m = min(1.0, 0.1 / (max(w_nm, w_n) * T_s))
        theta_def = T_ref / K_S
        alpha = min(max(20.0 / theta_def, 1e3 / sigma), 1e5 / sigma)
        v_typ = motion.v_typ if motion is not None and motion.v_typ > 0 else math.pi * f_exc
        omega_c = reconstruction_cutoff(10.0 * w_r, T_s, theta_def, N, motion)
        values: dict[str, Any] = dict(
            k1=k1,
            k2=k2,
            gamma=w_n / 16.0,
            delta_max=DELTA_MAX_DEFAULT if delta_max is None else delta_max,
            eps_delta=0.1,
            delta0=0.0,
            alpha=alpha,
            method=method,
            omega_c=omega_c,
            tau_f=max(2.0 / w_n, 4.0 * T_s),
            lam=w_r / 25.0,
            P_max=min(16.0 * w_r, 1.0 * w_n),
            omega_eps=0.0,
            T_thr=T_thr,
            window=max(2.0 / f_exc, 1.0),
            theta_def=theta_def,
            reset_e=3.0,
            reset_t=max(2.0 * (2.0 / w_n), 4.0 * T_s),
            torque_source="motor" if motor else "load",
            k1_m=1.5 * math.sqrt(rho_m) * s_m,
            k2_m=1.1 * rho_m * s_m * s_m,
            lam_g=w_r,
            omega_g=0.05 * v_typ,
            offset_switch=OFFSET_FLOOR * sigma,
            angle_scale=sigma,
        )
        values.update({k: v for k, v in overrides.items() if v is not None})
        return cls(**values)

    def to_dict(self) -> dict[str, Any]:
        """Plain dict of the fields (JSON output)."""
        return asdict(self)
