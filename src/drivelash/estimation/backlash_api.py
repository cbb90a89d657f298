"""The one computation behind ``drivelash estimate`` and :func:`drivelash.estimate_backlash`.

``estimate`` (the command) and ``estimate_backlash`` (the notebook API) both call
:func:`estimate_from_config`: the same tuning (the excitation frequency is detected in the
data, ``[estimator]`` gains override the scaling rule), the same estimator run, the same
summary — so the two cannot give different numbers.

``DeadzoneEstimator(drivetrain, delta1, T_s).run(trace)`` (the chunk-able kernel wrapper)
tunes from the recording the same way and gives the same δ̂; the summary (verdict, δ1 check,
truth metrics, JSON) is this module's.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from drivelash.estimation.identify_result import IDENTIFY_NEEDS
from drivelash.io.outputs import jsonable
from drivelash.io.trace import Trace
from drivelash.units import gap_unit

__all__ = [
    "IDENTIFY_COLUMNS",
    "BacklashEstimate",
    "estimate_backlash",
    "estimate_from_config",
    "estimate_with_identification",
    "with_columns",
]


@dataclass
class BacklashEstimate:
    """Result of :func:`drivelash.estimate_backlash` and of ``drivelash estimate``.

    Attributes
    ----------
    delta : float
        Final estimate δ̂ [rad; m on a prismatic (linear) axis, ``summary["axis"]``] (NaN when
        ``identify`` could not run the online law).
    warnings : list of str
        The estimate's warnings (``summary["warnings"]``).
    summary : dict
        Exactly what ``drivelash estimate --json`` writes (without the ``trace``/``config``
        paths; plain JSON types, a non-finite number is None as the command's null): the axis
        kind (``axis``) and the unit of each length key (``units``), δ̂ and δ1 [rad, or m on a
        prismatic axis — the ``_rad`` key names are kept there], excitation verdict and reason,
        convergence, sample period ``T_s`` [s], detected excitation frequency [Hz], gains, and
        MAEE / steady-state peak [rad or m] when the
        recording carries the true δ.
    result : EstimationResult
        The estimator's time series (δ̂(t) [rad or m], φ̂, ω̂_l, Δθ, torques, traversals).
    trace : Trace
        The recording as the estimator saw it (SI units).
    gains : EstimatorConfig
        The tuning used.
    identification : DriveIdentification or None
        The offline identification when ``identify=True`` (``estimate --identify``), else None.
    """

    summary: dict[str, Any]
    result: Any
    trace: Trace
    gains: Any
    identification: Any = None

    @property
    def delta(self) -> float:
        """Final δ̂ [rad, or m on a prismatic axis]; NaN when the online law was not run
        (``identify=True`` and the recording could not give the drive: ``summary["reason"]`` says
        why)."""
        d = self.summary["delta"]
        return math.nan if d is None else float(d)

    @property
    def converged(self) -> bool:
        """True when the excitation sufficed and δ̂ settled."""
        return bool(self.summary["converged"])

    @property
    def excitation_ok(self) -> bool:
        """The excitation verdict."""
        return bool(self.summary["excitation_ok"])

    @property
    def warnings(self) -> list[str]:
        """The warnings of the estimate (``summary["warnings"]``; empty when there are none)."""
        return list(self.summary.get("warnings") or [])

    @property
    def method(self) -> str:
        """The adaptation law that ran: ``"default"`` or ``"paper"``."""
        return str(self.summary["method"])

    def __getitem__(self, key: str) -> Any:
        return self.summary[key]

    def __repr__(self) -> str:
        d = self.summary.get("delta")
        u = gap_unit(self.trace.meta.get("axis"))
        delta = "not run" if d is None else u.f(float(d), ".4g")
        return (
            f"BacklashEstimate(delta={delta}, converged={self.converged}, "
            f"excitation_ok={self.excitation_ok}, method={self.summary.get('method')!r}, "
            f"samples={self.summary.get('samples')}, warnings={len(self.warnings)})"
        )


#: Columns ``estimate --identify`` reads before the identification has spoken: what the two-mass
#: identification needs (ω_m, ω_l are differentiated from the positions when absent); the online
#: law's velocities are checked only when it runs (:func:`estimate_with_identification`).
IDENTIFY_COLUMNS = IDENTIFY_NEEDS["two-mass"]


def _check_delta1(delta1: Any) -> None:
    """The ``delta1`` argument: a finite number ≥ 0 [rad] (a ParameterError naming the argument,
    not the configuration file it replaces)."""
    from drivelash.errors import ParameterError
    from drivelash.params import is_real_number

    # any real scalar: Python's and numpy's (np.float32 from a computed array was refused)
    if not (is_real_number(delta1) and math.isfinite(delta1) and delta1 >= 0):
        raise ParameterError(
            "estimate_backlash", "delta1", f"the argument must be a finite number >= 0 [rad], got {delta1!r}"
        )


def _backlash_with_delta1(cfg: Any, delta1: Any) -> Any:
    """``cfg``'s ``[backlash]`` table (the keys the user set) with ``delta1`` [rad] replaced by the
    argument (checked: finite, ≥ 0)."""
    from drivelash.io.config import BacklashSection
    from drivelash.params import is_real_number, rounded_delta1

    if is_real_number(delta1):
        delta1 = rounded_delta1(float(delta1))
    _check_delta1(delta1)
    given = cfg.backlash.given() if cfg.backlash is not None else {}
    return BacklashSection(**{**given, "delta1": float(delta1)})


def estimate_from_config(
    trace: Trace,
    cfg: Any,
    *,
    method: str | None = "default",
    drivetrain: Any = None,
    delta1: float | None = None,
    delta1_uncertainty: Any = None,
) -> BacklashEstimate:
    """Run the online estimator on ``trace`` as ``drivelash estimate`` does
    (:func:`drivelash.estimation.pipeline.estimate_trace`) and build the command's summary.

    Parameters
    ----------
    trace : Trace
        θ_m, ω_m, θ_l, ω_l [rad, rad/s] (torque and the true δ optional).
    cfg : DriveConfig
        ``[drivetrain]``, ``[backlash] delta1``, optional ``[estimator]`` gains.
    method : {"default", "paper"} or None
        Adaptation law; None: the file's ``[estimator] method``, else "default".
    drivetrain : DrivetrainParams, optional
        Replaces ``[drivetrain]``.
    delta1 : float, optional
        Known offset δ1 [rad, or m on a prismatic axis]; replaces ``[backlash] delta1``.
    delta1_uncertainty : Delta1Uncertainty, optional
        δ1 is itself uncertain (identified): its standard uncertainty [rad] and δ̂ of reruns at
        shifted δ1, propagated into ``delta_std`` and the verdict
        (:class:`~drivelash.estimation.estimator.Delta1Uncertainty`).
    """
    from drivelash.errors import DrivelashError
    from drivelash.estimation.pipeline import (
        MAEE_FRACTION,
        SS_FRACTION,
        estimate_summary,
        estimate_trace,
        truth_windows,
    )
    from drivelash.io.config import DrivetrainSection
    from drivelash.metrics import maee, steady_state_peak

    if method not in (None, "paper", "default"):
        raise DrivelashError(f"--method: must be 'paper' or 'default', got {method!r}")
    update: dict[str, Any] = {}
    if drivetrain is not None:  # the same validation path as a [drivetrain] table
        update["drivetrain"] = DrivetrainSection(**asdict(drivetrain))
    if delta1 is not None:
        update["backlash"] = _backlash_with_delta1(cfg, delta1)
    if update:
        cfg = cfg.model_copy(update=update)
    res, motion = estimate_trace(cfg, trace, method, delta1_uncertainty=delta1_uncertainty)
    t = res.t
    summary = estimate_summary(cfg, res, motion, len(trace), trace.T_s)
    if "delta_true" in trace:
        truth = trace["delta_true"]
        T = float(t[-1] - t[0])
        summary["delta_true"] = float(truth[-1])
        summary["maee_rad"] = maee(t, res.delta_hat, truth, float(t[-1]) - MAEE_FRACTION * T)
        summary["steady_state_peak_rad"] = steady_state_peak(t, res.delta_hat, truth, SS_FRACTION * T)
        summary.update(truth_windows(T))
    # the command's JSON: non-finite numbers are null (the project's one JSON sanitiser)
    return BacklashEstimate(summary=jsonable(summary), result=res, trace=trace, gains=res.config)


def estimate_backlash(
    data: Any,
    drivetrain: Any = None,
    delta1: float | None = None,
    *,
    method: str | None = None,
    columns: Any = None,
    identify: bool = False,
) -> BacklashEstimate:
    """Estimate the deadzone (backlash) angle δ of a drive train from a recording.

    The same computation as ``drivelash estimate TRACE --config DRIVE.toml`` (same tuning,
    same numbers; the command's JSON is ``result.summary`` plus the two paths). Arguments
    play the command's options: ``method`` is ``--method``, ``identify`` is ``--identify``;
    left at their defaults, the configuration decides, as for the command.

    Parameters
    ----------
    data : Trace, pandas.DataFrame, str or Path
        The recording: θ_m, ω_m, θ_l, ω_l (motor side / load side, [rad], [rad/s]; [m], [m/s] with
        a force [N] on a linear axis mapped in length units) and time
        ``t`` [s]. A DataFrame is mapped and validated like a file (``columns``, or the
        configuration's ``[columns]`` table); a path is read with
        :func:`drivelash.load_trace`. A Trace is already mapped to SI: ``columns`` is refused
        with it.
    drivetrain : DriveConfig, str, Path or DrivetrainParams
        The drive: a configuration (``[drivetrain]``, ``[backlash] delta1``, optional
        ``[estimator]`` gains, ``[columns]`` and ``[sampling]``), its TOML path, or the
        parameters alone (then ``delta1`` is required).
    delta1 : float, optional
        Known offset δ1 [rad, or m on a prismatic axis] of the gap (replaces ``[backlash] delta1``;
        finite, ≥ 0).
    method : {"default", "paper"}, optional
        Adaptation law: ``"default"`` (the improved law) or ``"paper"`` (the paper's gradient
        law). None (default): ``[estimator] method`` of the configuration, else ``"default"``
        — as ``drivelash estimate`` without ``--method``.
    columns : dict, optional
        Column mapping for a DataFrame or a file, replacing the configuration's ``[columns]``
        only (its ``[sampling]`` is kept): *source column → Trace column*, each value the
        Trace column's name (``{"pos_load": "theta_l"}``, values in that column's SI unit) or
        a ``{"column": …, "unit": …}`` table as in ``[columns]``.
    identify : bool
        ``drivelash estimate --identify``: identify the drive offline first (two-mass model,
        95 % intervals); the drive-train values and δ1 the configuration does not set come from
        it (:func:`estimate_with_identification`; an identified δ1's uncertainty is carried into
        δ̂'s). Needs θ_m, θ_l and torque_m; ω_m, ω_l
        only when the online law runs.

    Returns
    -------
    BacklashEstimate
        ``.delta`` [rad, or m on a prismatic axis], ``.converged``, ``.excitation_ok``,
        ``.warnings``, ``.summary`` (the command's JSON), ``.result`` (time series; None when
        ``identify`` could not run the online law).

    Raises
    ------
    ParameterError
        A ``method`` other than ``"default"``, ``"paper"`` or None; ``drivetrain`` missing or of
        another type; DrivetrainParams without ``delta1``, or with ``identify=True``; a
        ``delta1`` that is not a finite number ≥ 0 [rad]; ``columns`` with a Trace.
    ConfigError
        The configuration file cannot be read or is invalid.
    DataError
        The recording cannot be read, mapped or validated (one line naming file, column, row).

    Examples
    --------
    >>> import drivelash as dl
    >>> from drivelash.sim.scenarios import get_scenario
    >>> run = get_scenario("bench-0C").simulate(duration=8.0, seed=1)
    >>> est = dl.estimate_backlash(run, "examples/drive_bench.toml", delta1=0.0525)
    >>> round(1e3 * est.delta)  # true δ of bench-0C: 105 mrad
    105
    """
    from drivelash.errors import ParameterError
    from drivelash.estimation.estimator import INPUT_COLUMNS
    from drivelash.estimation.identify_two_mass import as_trace
    from drivelash.io.config import DriveConfig, load_config
    from drivelash.params import DrivetrainParams

    if method not in (None, "paper", "default"):
        raise ParameterError(
            "estimate_backlash", "method", f"must be 'paper', 'default' or None, got {method!r}"
        )
    dt_params = None
    if isinstance(drivetrain, (str, Path)):
        cfg = load_config(drivetrain)
    elif isinstance(drivetrain, DriveConfig):
        cfg = drivetrain
    elif isinstance(drivetrain, DrivetrainParams):
        cfg = DriveConfig()
        dt_params = drivetrain
        if identify:
            raise ParameterError(
                "estimate_backlash",
                "identify",
                "needs a configuration (DriveConfig or path), not DrivetrainParams",
            )
        if delta1 is None:
            raise ParameterError(
                "estimate_backlash", "delta1", "required when drivetrain is a DrivetrainParams"
            )
    elif drivetrain is None:
        raise ParameterError(
            "estimate_backlash", "drivetrain", "required: a DriveConfig, a TOML path or DrivetrainParams"
        )
    else:
        raise ParameterError(
            "estimate_backlash",
            "drivetrain",
            f"must be a DriveConfig, a path or DrivetrainParams, got {type(drivetrain).__name__}",
        )
    if identify:
        if delta1 is not None:  # as [backlash] delta1 of the file: a configured δ1
            cfg = cfg.model_copy(update={"backlash": _backlash_with_delta1(cfg, delta1)})
        need = list(IDENTIFY_COLUMNS)
    else:
        need = list(INPUT_COLUMNS)
    trace = as_trace(data, with_columns(cfg, columns, data, "estimate_backlash"), need, "estimate_backlash")
    if identify:
        return estimate_with_identification(trace, cfg, method=method)
    return estimate_from_config(trace, cfg, method=method, drivetrain=dt_params, delta1=delta1)


def with_columns(cfg: Any, columns: Any, data: Any, caller: str) -> Any:
    """The mapping of ``data``: ``cfg`` with its ``[columns]`` replaced by ``columns`` (its
    ``[sampling]`` kept), or ``cfg`` when ``columns`` is None.

    ``columns`` with a :class:`~drivelash.io.trace.Trace` is a :class:`ParameterError`: a
    Trace is already mapped to SI units, a mapping cannot apply to it.
    """
    from drivelash.errors import ParameterError
    from drivelash.io.load import column_maps

    if columns is None:
        return cfg
    if isinstance(data, Trace):
        raise ParameterError(
            caller,
            "columns",
            "data is a Trace, already mapped to SI units, so a column mapping cannot apply: pass the "
            "DataFrame or the file with columns=, or the Trace without columns=",
        )
    if not isinstance(columns, Mapping):
        raise ParameterError(
            caller, "columns", f"must be a dict source column → Trace column, got {type(columns).__name__}"
        )
    return cfg.model_copy(update={"columns": column_maps(columns)})


def _needs_identification(cfg: Any) -> bool:
    dt = cfg.drivetrain
    return dt is None or any(getattr(dt, k) is None for k in ("J_m", "J_l", "K_S", "D_S"))


def estimate_with_identification(
    trace: Trace, cfg: Any, *, method: str | None = "default"
) -> BacklashEstimate:
    """``drivelash estimate --identify``: identify the drive offline, then run the online law.

    Drive-train values the configuration gives are kept; the ones it lacks (and δ1 when
    ``[backlash] delta1`` is absent) come from the two-mass identification
    (:func:`drivelash.identify_drive`). The summary carries both the offline δ with its 95 %
    interval (``identification``) and the online δ̂ with its uncertainty when the estimator
    reports one (``delta_std``; otherwise only the offline interval counts), and
    ``agreement`` says whether they differ beyond their intervals (a warning). A configured δ1
    that lies outside the identified δ1's 95 % interval and farther from it than the δ1 check's
    tolerance (``offset_switch``, at least 1 mrad) is replaced by the identified δ1, with a
    warning and ``delta1_configured`` in the summary. An identified δ1 is not exact: its standard
    error, times ∂δ̂/∂δ1 measured by rerunning the online law at δ1 ± that error
    (:func:`_delta1_uncertainty`), is part of ``delta_std`` (``delta1_std``,
    ``delta1_sensitivity``, ``delta1_propagated_std`` in the summary), so a δ1 the recording
    leaves uncertain withholds ``converged`` with a warning naming δ1. When the recording
    cannot give the drive (implausible fit, load side or backlash not seen), the online law
    is not run: ``online_run`` is false with the reason, ``excitation_ok`` false.
    """
    from drivelash.estimation.identify_two_mass import identify_from_config
    from drivelash.params import OFFSET_FLOOR, delta1_tolerance

    ident = identify_from_config(trace, cfg, model="two-mass")
    u = gap_unit(trace.meta.get("axis"))  # the warnings' unit: mrad, or µm on a prismatic axis
    off = {
        "delta": ident["delta"].as_dict(),
        "delta1": ident["delta1"].as_dict() if "delta1" in ident.parameters else None,
        "backlash_visible": ident.backlash_visible,
        "reason": ident.reason,
        "plausible": ident.plausible,
        "warnings": list(ident.warnings),
        "drivetrain": ident.to_config()["drivetrain"],
    }
    base = None
    if cfg.drivetrain is not None:  # only what the user set: a default (friction 0) is not a value
        base = {k: v for k, v in cfg.drivetrain.given().items() if v is not None}
    missing = [
        k for k in ("J_m", "J_l", "K_S", "D_S") if k not in (base or {}) and k not in off["drivetrain"]
    ]
    why = None
    if not ident.plausible:
        why = f"the identification is implausible ({ident.warnings[0].split(':')[0]})"
    elif missing:
        why = _undetermined(ident, missing)
    bl = cfg.backlash
    d1_cfg = bl.delta1 if bl is not None and "delta1" in bl.model_fields_set else None
    d1 = d1_cfg
    d1_note = None
    if why is None and d1_cfg is not None:
        p = ident.parameters.get("delta1")
        given = cfg.estimator.given() if cfg.estimator is not None else {}
        floor = delta1_tolerance(given.get("offset_switch", OFFSET_FLOOR))
        if (
            p is not None
            and p.identifiable
            and not p.covers(d1_cfg)
            and abs(p.value - d1_cfg) > floor
            and 0.0 <= p.value <= max(ident["delta"].value, 0.0)
        ):
            # the recording contradicts the configured δ1 (item 4 of issue 11: the offline
            # result supplies δ1): the online law gets the identified one, and the user is told
            d1 = float(p.value)
            d1_note = (
                f"[backlash] delta1 = {u.f(d1_cfg, '.3f')} lies outside the recording's 95 % interval "
                f"[{u.n(p.low, '.3f')}, {u.n(p.high, '.3f')}] {u} and differs by more than the δ1 "
                f"check's {u.f(floor, '.3g')}: the identified δ1 = {u.f(p.value, '.3f')} is used "
                "(wrong δ1 or an offset between the encoders)"
            )
    if why is None and d1 is None:
        p = ident.parameters.get("delta1")
        if p is None or not p.identifiable:
            why = f"δ1 is neither in [backlash] nor determined by the recording ({ident.reason})"
        elif not 0.0 <= p.value <= max(ident["delta"].value, 0.0):
            why = (
                f"the identified gap does not contain Δθ = 0 (δ1 = {u.f(p.value, '.4g')} outside [0, δ]): "
                "the encoders' zeros are offset (see the identification warning)"
            )
        else:
            d1 = float(p.value)
    from drivelash.estimation.estimator import INPUT_COLUMNS

    lacking = [c for c in INPUT_COLUMNS if c not in trace]
    if lacking:  # the identification differentiated positions; the online law needs recorded velocities
        no_vel = (
            f"the recording has no {' and no '.join(repr(c) for c in lacking)}: the online law needs the "
            "recorded velocities (map them in [columns]); the offline identification did not need them"
        )
        why = no_vel if why is None else f"{why}; and {no_vel}"  # every blocker, not only the first
    if why is not None:
        from drivelash.estimation.pipeline import _estimator_overrides, summary_units

        kind = summary_units(trace.meta.get("axis"))
        summary: dict[str, Any] = {
            "method": _estimator_overrides(cfg, method)[0],
            "axis": kind["axis"],
            "delta": None,
            "delta1": d1,
            "excitation_ok": False,
            "reason": f"online estimate not run: {why}",
            "converged": False,
            "convergence_time_s": None,
            "samples": len(trace),
            "T_s": trace.T_s,
            "online_run": False,
            "identification": off,
            "warnings": [f"online estimate not run: {why}"],
            "units": kind["units"],
        }
        return BacklashEstimate(
            summary=jsonable(summary), result=None, trace=trace, gains=None, identification=ident
        )
    from drivelash.params import DrivetrainParams

    vals = {**off["drivetrain"], **(base or {})}  # the configuration's own values win
    dt = DrivetrainParams(**{k: v for k, v in vals.items() if k in DrivetrainParams.__dataclass_fields__})
    from_ident = d1_cfg is None or d1_note is not None
    d1u = _delta1_uncertainty(trace, cfg, method, dt, d1, ident) if from_ident else None
    est = estimate_from_config(trace, cfg, method=method, drivetrain=dt, delta1=d1, delta1_uncertainty=d1u)
    s = est.summary
    s["online_run"] = True
    s["identification"] = off
    s["drivetrain_used"] = {k: float(v) for k, v in dt.__dict__.items()}
    s["delta1_source"] = "identification" if from_ident else "config"
    s.setdefault("warnings", [])
    if d1_note:
        s["delta1_configured"] = d1_cfg
        s["warnings"].append(d1_note)
    s["warnings"].extend(_configured_disagreements(base or {}, ident))
    std_on = s.get("delta_std")
    if std_on is not None and not math.isfinite(std_on):
        std_on = None
    dp = ident["delta"]
    if dp.identifiable:
        sig = math.hypot(dp.std, std_on or 0.0)
        diff = float(s["delta"]) - dp.value
        disagree = abs(diff) > 1.959963984540054 * sig
        s["agreement"] = {
            "offline_delta": dp.value,
            "offline_ci95": [dp.low, dp.high],
            "online_delta": s["delta"],
            "online_std": std_on,
            "difference": diff,
            "disagree": disagree,
        }
        if disagree:
            msg = (
                f"online δ̂ = {u.f(s['delta'], '.4g')} and offline δ = {u.f(dp.value, '.4g')} "
                f"[{u.n(dp.low, '.4g')}, {u.n(dp.high, '.4g')}] disagree beyond their intervals"
            )
            s["warnings"].append(msg)
    else:
        s["agreement"] = {"offline_delta": None, "reason": dp.reason, "disagree": None}
    est.summary = jsonable(s)
    est.identification = ident
    return est


#: ``estimate --identify`` keeps a configured drive value (the configuration's own values win)
#: but names it when it lies outside the identified 95 % interval AND differs from the
#: identified value by more than this factor either way: well beyond the identification's
#: own systematic misses (K_S / J_l at most 5.95 % off on the 48 random drives, 7–9 % before
#: session 18), so the note names a stated value, not the fit's bias (session 30 tester A, L6:
#: K_S stated 2× the truth sat next to the identified one without a remark).
CONFIG_DISAGREE_FACTOR = 1.25

#: The drive values ``estimate --identify`` compares with the identification, and their units.
#: The drive values a configuration states that the identification checks (its units: the
#: identification's own, kg·m² … or kg, N/m … on a linear axis).
_COMPARED = ("J_m", "J_l", "K_S", "D_S")


def _configured_disagreements(given: dict[str, Any], ident: Any) -> list[str]:
    """Notes naming configured drive values the recording contradicts (:data:`CONFIG_DISAGREE_FACTOR`).

    Parameters
    ----------
    given : dict
        The ``[drivetrain]`` values the user set (SI units).
    ident : DriveIdentification
        The two-mass identification of the same recording.

    Returns
    -------
    list of str
        One ``"note: …"`` per contradicted value (the online law still uses the configured one).
    """
    out = []
    for k in _COMPARED:
        v, p = given.get(k), ident.parameters.get(k)
        if v is None or p is None or not p.identifiable or p.covers(v) or not (p.value > 0.0 and v > 0.0):
            continue
        ratio = float(v) / p.value
        if max(ratio, 1.0 / ratio) > CONFIG_DISAGREE_FACTOR:
            unit = p.unit
            out.append(
                f"note: [drivetrain] {k} = {v:.4g} {unit} is used as configured, but the recording gives "
                f"{p.value:.4g} [{p.low:.4g}, {p.high:.4g}] {unit} ({ratio:.2f}× the identified value): "
                f"check it (leave {k} out to use the identified value)"
            )
    return out


def _delta1_uncertainty(trace: Trace, cfg: Any, method: str | None, dt: Any, d1: float, ident: Any) -> Any:
    """The identified δ1's standard error and δ̂ of the online law rerun at δ1 ± that error.

    The anchored online law does not correct a δ1 offset: δ̂ moves with δ1, by a factor the
    law's stiffness scale makes larger than 1 (geared drive, 250 Hz: 1.9 below, 0.9 above the
    identified δ1). The reruns measure it where it matters — one standard error either side
    (the lower one not below δ1 = 0), both sides because the response is not symmetric; each
    rerun is the whole online estimate (tuning, δ1 check), a small fraction of the
    identification's time. :class:`~drivelash.estimation.estimator.Delta1Uncertainty` turns
    them into δ̂'s part of the uncertainty (docs/assumptions.md).

    Parameters
    ----------
    trace : Trace
        The recording.
    cfg : DriveConfig
        The configuration (``[estimator]`` keys apply to the reruns as to the estimate).
    method : {"default", "paper"} or None
        The law, as for the estimate.
    dt : DrivetrainParams
        The drive train given to the online law.
    d1 : float
        The identified δ1 the estimate uses [rad].
    ident : DriveIdentification
        The identification (its ``delta1`` standard error [rad]).

    Returns
    -------
    Delta1Uncertainty or None
        None when the identification gives no finite positive standard error for δ1.
    """
    from drivelash.estimation.estimator import Delta1Uncertainty

    p = ident.parameters.get("delta1")
    sd = float(p.std) if p is not None else math.nan
    if not (math.isfinite(sd) and sd > 0.0):
        return None
    shifted = []
    for h in (sd, max(d1 - sd, 0.0) - d1):
        if h == 0.0:
            continue
        e = estimate_from_config(trace, cfg, method=method, drivetrain=dt, delta1=d1 + h)
        shifted.append((h, float(e.result.extra.get("delta_final", math.nan))))
    return Delta1Uncertainty(std=sd, shifted=tuple(shifted))


def _undetermined(ident: Any, missing: list[str]) -> str:
    """Why the online law cannot run: the drive-train parameters in ``missing`` that neither the
    configuration nor the recording gives, each group with the identification's reason, and
    what to do (give them in ``[drivetrain]``)."""
    groups: dict[str, list[str]] = {}
    for k in missing:
        q = ident.parameters.get(k)
        why = q.reason.removeprefix("not determined: ") if q is not None and q.reason else ident.reason
        groups.setdefault(why, []).append(k)
    if len(groups) == 1:
        because = next(iter(groups))
    else:
        because = "; ".join(f"{', '.join(ks)}: {why}" for why, ks in groups.items())
    return (
        f"the recording does not determine {', '.join(missing)} ({because}); "
        "give them in [drivetrain] to run the online law"
    )
