"""The online estimator as ``drivelash estimate`` runs it on a recording.

One place for the computation behind the command, the notebook API
(:func:`drivelash.estimation.backlash_api.estimate_from_config`) and the wear tracker
(:func:`drivelash.wear.estimate.estimate_recording`): the two passes (the recording's motion
tunes the gains and the contact threshold, then the chosen law and the δ1 check run over it),
the ``[estimator]`` overrides, and the JSON summary. On a loaded :class:`~drivelash.io.Trace`
(:func:`estimate_trace`) or streamed in chunks from a file (:func:`estimate_stream`) — the same
numbers bit for bit (tests/cli/test_estimate_stream.py).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping
from typing import Any

import numpy as np

__all__ = [
    "MAEE_FRACTION",
    "SS_FRACTION",
    "SUMMARY_EFFORT_KEYS",
    "SUMMARY_LENGTH_KEYS",
    "estimate_stream",
    "estimate_summary",
    "estimate_trace",
    "result_summary",
    "truth_windows",
]

#: Fractions of a recording used for MAEE and steady-state peak when the truth is known
#: (for a 60 s bench run: the last 20 s and the last 10 s, as in ``reproduce``).
MAEE_FRACTION = 1.0 / 3.0
SS_FRACTION = 1.0 / 6.0


def truth_windows(T: float) -> dict[str, float]:
    """Lengths [s] of the windows at the end of a recording of duration ``T`` [s] over which the
    summary's ``maee_rad`` and ``steady_state_peak_rad`` are taken (keys ``maee_window_s``,
    ``steady_state_window_s``; session 32, tester F, F8: the JSON and the terminal did not say
    which window, and ``reproduce`` uses others for paper-sim)."""
    return {"maee_window_s": MAEE_FRACTION * T, "steady_state_window_s": SS_FRACTION * T}


def _estimator_overrides(cfg: Any, method: str | None = None) -> tuple[str, dict[str, Any], bool]:
    """The law and the keys that override the tuning rule.

    ``--method`` (``method``) wins over ``[estimator] method``, else "default"; the other keys
    of ``[estimator]`` and ``[backlash] alpha`` override the tuning rule (alpha given in both
    tables with different values is an error). Returns (method, overrides, alpha taken from
    ``[backlash]``).
    """
    from drivelash.errors import ConfigError

    src = cfg.source or "<config>"
    over: dict[str, Any] = cfg.estimator.given() if cfg.estimator is not None else {}
    file_method = over.pop("method", None)
    law = method if method is not None else (file_method or "default")
    bl = cfg.backlash
    alpha_from_backlash = bl is not None and "alpha" in bl.model_fields_set and "alpha" not in over
    if bl is not None and "alpha" in bl.model_fields_set and over.get("alpha", bl.alpha) != bl.alpha:
        raise ConfigError(
            f"{src}: table [estimator], key 'alpha': {over['alpha']!r} contradicts [backlash] alpha"
            f" = {bl.alpha!r} (give it once)"
        )
    if alpha_from_backlash:
        over["alpha"] = bl.alpha
    return law, over, alpha_from_backlash


def _estimator_config(
    cfg: Any, drivetrain: Any, T_s: float, f_exc: float, method: str | None, motion: Any = None
) -> Any:
    """Gains: the tuning rule (from the recording's motion when given), overridden by the file
    and by ``--method``."""
    from drivelash.errors import ConfigError, ParameterError
    from drivelash.params import EstimatorConfig

    src = cfg.source or "<config>"
    law, over, alpha_from_backlash = _estimator_overrides(cfg, method)
    try:
        return EstimatorConfig.tuned(drivetrain, T_s, f_exc, method=law, motion=motion, **over)  # type: ignore[arg-type]
    except ParameterError as exc:
        table = "backlash" if exc.field == "alpha" and alpha_from_backlash else "estimator"
        raise ConfigError(f"{src}: table [{table}], key '{exc.field}': {exc.problem}") from None


def estimate_trace(
    cfg: Any, trace: Any, method: str | None = None, keep: str = "full", delta1_uncertainty: Any = None
) -> tuple[Any, Any]:
    """The estimator exactly as ``drivelash estimate`` runs it on a loaded recording.

    Two passes (:func:`drivelash.estimation.estimator.estimate_blocks`): the recording's
    motion (reversal frequency, torque) tunes the gains and the contact threshold, then the
    chosen law and the δ1 check run over it; ``[estimator]`` keys override the tuning.

    Parameters
    ----------
    cfg : DriveConfig
        The loaded configuration (``[drivetrain]``, ``[backlash]``, optional ``[estimator]``).
    trace : Trace
        The recording (``theta_m``, ``omega_m``, ``theta_l``, ``omega_l``; ``torque_m`` used
        when present).
    method : {"paper", "default"}, optional
        Law; None: ``[estimator] method`` of the file, else "default".
    keep : {"full", "decimated"}
        Output series kept in the result (``estimate_blocks``); the verdict and every figure
        are the same either way — "decimated" spares the copies when only the figures count
        (the wear tracker).
    delta1_uncertainty : Delta1Uncertainty, optional
        ``[backlash] delta1`` is itself uncertain (``estimate --identify``: the identified δ1);
        propagated into δ̂'s uncertainty and verdict
        (:class:`~drivelash.estimation.estimator.Delta1Uncertainty`).

    Returns
    -------
    (EstimationResult, MotionSummary)
    """
    from drivelash.estimation.estimator import trace_blocks

    return _estimate_blocks(
        cfg,
        trace_blocks(trace),
        trace.T_s,
        method,
        keep=keep,
        meta=trace.meta,
        delta1_uncertainty=delta1_uncertainty,
    )


def _estimate_blocks(
    cfg: Any,
    blocks: Callable[[], Iterator[Mapping[str, np.ndarray]]],
    T_s: float,
    method: str | None,
    *,
    keep: str = "full",
    truth: bool = False,
    meta: Mapping[str, Any] | None = None,
    delta1_uncertainty: Any = None,
) -> tuple[Any, Any]:
    """:func:`estimate_trace` on a block source (an in-memory trace or a file read in chunks).

    ``truth``: the blocks carry ``delta_true``; max |δ* − δ̂| over the MAEE and steady-state
    windows is accumulated while streaming (``extra["max_abs_error_since"]``). ``meta``: the
    recording's metadata (its ``encoder_reading``, when stated, is used). ``delta1_uncertainty``:
    as for :func:`estimate_trace`.
    """
    from drivelash.errors import ConfigError
    from drivelash.estimation.estimator import estimate_blocks, scan_blocks
    from drivelash.params import rounded_delta1

    drivetrain = cfg.to_drivetrain_params()
    bl = cfg.require("backlash")
    delta1 = rounded_delta1(bl.delta1)
    if not (math.isfinite(delta1) and delta1 >= 0):
        raise ConfigError(
            f"{cfg.source or '<config>'}: table [backlash], key 'delta1': "
            f"must be finite and >= 0, got {bl.delta1!r}"
        )
    motion = scan_blocks(blocks, drivetrain.N)
    _estimator_config(cfg, drivetrain, T_s, motion.f_exc, method, motion=motion)  # names a bad key
    law, over, _ = _estimator_overrides(cfg, method)
    since: tuple[float, ...] = ()
    if truth:  # the windows of metrics.maee / steady_state_peak as estimate_from_config takes them
        T = motion.t_last - motion.t0
        since = (motion.t_last - MAEE_FRACTION * T, motion.t_last - SS_FRACTION * T)
    res = estimate_blocks(
        drivetrain,
        float(delta1),
        blocks,
        method=law,  # type: ignore[arg-type]
        overrides=over,
        motion=motion,
        keep=keep,  # type: ignore[arg-type]
        error_since=since,
        encoder_reading=(meta or {}).get("encoder_reading"),
        delta1_uncertainty=delta1_uncertainty,
        axis=(meta or {}).get("axis"),
    )
    # the axis kind travels with the result into the summary (its "axis" and "units" keys, G8)
    res.extra.setdefault("axis", str((meta or {}).get("axis") or "rotary"))
    return res, motion


#: Summary keys holding a gap, an offset or a displacement: rad on a rotary axis, m on a prismatic
#: one (the ``_rad`` suffix of three of them is kept for compatibility: it names the rotary unit).
SUMMARY_LENGTH_KEYS = (
    "delta",
    "delta1",
    "convergence_band_rad",
    "delta_std",
    "delta_interval_95",
    "delta1_estimate",
    "delta1_used",
    "dtheta_range",
    "contact_deflection",
    "load_range",
    "motor_range",
    "encoder_offset_bound",
    "law_disagreement",
    "delta1_std",
    "delta1_propagated_std",
    "delta_true",
    "maee_rad",
    "steady_state_peak_rad",
)
#: Summary keys holding the drive's effort: N·m on a rotary axis, N on a prismatic one.
SUMMARY_EFFORT_KEYS = ("contact_threshold", "load_torque_constant")


def summary_units(axis: str | None) -> dict[str, Any]:
    """The ``axis`` and ``units`` keys of an estimate's summary for an axis kind (None: rotary).

    ``units`` names the SI unit of every length key (:data:`SUMMARY_LENGTH_KEYS`: "rad" or "m")
    and effort key (:data:`SUMMARY_EFFORT_KEYS`: "N·m" or "N") the summary may carry.
    """
    from drivelash.units import gap_unit

    kind = str(axis or "rotary")
    u = gap_unit(kind)
    return {
        "axis": kind,
        "units": {k: u.si for k in SUMMARY_LENGTH_KEYS} | {k: u.torque for k in SUMMARY_EFFORT_KEYS},
    }


def estimate_summary(cfg: Any, res: Any, motion: Any, samples: int, T_s: float) -> dict[str, Any]:
    """The JSON summary of an estimate, without the truth metrics (shared by both paths).

    ``axis`` is the recording's axis kind ("rotary", or "prismatic": positions in m) and
    ``units`` the SI unit of every gap, displacement and effort key the summary may carry
    (:data:`SUMMARY_LENGTH_KEYS`: "rad" or "m"; :data:`SUMMARY_EFFORT_KEYS`: "N·m" or "N"; the
    truth keys ``delta_true``, ``maee_rad``, ``steady_state_peak_rad`` are listed although only a
    recording with the true δ has them). On a prismatic axis the keys ending in ``_rad`` hold
    metres: the names are kept for compatibility, ``units`` says what they hold (session 34,
    tester G, G8: a script could not tell metres from radians). ``gains`` are in the same units.
    """
    from drivelash.params import rounded_delta1

    kind = summary_units(res.extra.get("axis"))
    return {
        "method": res.config.method,
        "axis": kind["axis"],
        "delta": res.delta,
        "delta1": rounded_delta1(float(cfg.backlash.delta1)),
        "excitation_ok": res.excitation_ok,
        "reason": res.reason,
        "converged": res.converged,
        "convergence_time_s": res.convergence_time_s,
        "convergence_band_rad": res.band,
        "samples": samples,
        "T_s": T_s,
        "excitation_frequency_hz": motion.f_exc,
        "excitation_frequency_source": (
            "measured" if motion.reversals >= 3 else "default (fewer than 3 motion reversals)"
        ),
        **result_summary(res),
        "units": kind["units"],
        "gains": res.config.to_dict(),
    }


#: Columns the estimator reads from a recording (the others are not read).
_ESTIMATE_COLUMNS = ("theta_m", "omega_m", "theta_l", "omega_l", "torque_m", "delta_true")
#: Columns kept, decimated like the result's series, for ``--plot`` / ``--report``.
_PLOT_COLUMNS = ("t", "theta_m", "omega_m", "theta_l", "omega_l", "torque_m", "delta_true")


def estimate_stream(
    cfg: Any, stream: Any, method: str | None = None, *, series: bool = False
) -> tuple[dict[str, Any], Any, Any]:
    """``drivelash estimate`` on a :class:`~drivelash.io.stream.TraceStream`, in bounded memory.

    The same two passes, tuning and verdict as :func:`estimate_trace` on the whole recording,
    over chunks: the JSON summary equals that of
    :func:`~drivelash.estimation.backlash_api.estimate_from_config` on ``load_trace`` of the
    same file bit for bit (tests/cli/test_estimate_stream.py). What grows with the recording
    is the pass-1 series (θ_m/N and the torque at ≥ 1 kHz: 16 B per ms).

    Parameters
    ----------
    cfg : DriveConfig
        The configuration.
    stream : TraceStream
        The validated recording.
    method : {"paper", "default"}, optional
        Law (as for :func:`estimate_trace`).
    series : bool
        Also return the recording's columns decimated like the result's series (for the
        plot and the report); else None.

    Returns
    -------
    (summary, EstimationResult, Trace or None)
        The result keeps a decimated series (:data:`~drivelash.estimation.estimator.SERIES_POINTS` rows).
    """
    from drivelash.estimation.estimator import series_step
    from drivelash.io.trace import Trace

    names = ["t", *[c for c in _ESTIMATE_COLUMNS if c in stream.names]]
    truth = "delta_true" in names
    keep = [c for c in _PLOT_COLUMNS if c in names] if series else []
    step = series_step(stream.n_samples)
    kept: dict[str, list[np.ndarray]] = {}

    def blocks() -> Iterator[dict[str, np.ndarray]]:
        kept.clear()  # only the last pass's (both passes see the same rows)
        kept.update({c: [] for c in keep})
        for ch in stream.chunks():
            start = (-ch.row0) % step
            for c in keep:
                kept[c].append(ch[c][start::step].copy())
            yield {c: ch[c] for c in names}

    res, motion = _estimate_blocks(
        cfg, blocks, stream.T_s, method, keep="decimated", truth=truth, meta=stream.meta
    )
    summary = estimate_summary(cfg, res, motion, stream.n_samples, stream.T_s)
    if truth:
        maee_v, ss_v = res.extra["max_abs_error_since"]
        summary["delta_true"] = res.extra["delta_true_last"]
        summary["maee_rad"] = maee_v
        summary["steady_state_peak_rad"] = ss_v
        summary.update(truth_windows(motion.t_last - motion.t0))
    trace = Trace({c: np.concatenate(v) for c, v in kept.items()}, meta=stream.meta) if series else None
    return summary, res, trace


def result_summary(res: Any) -> dict[str, Any]:
    """The estimator's figures of a result for the JSON summary (shared with the notebook API)."""
    x = res.extra
    lo, hi = res.delta_interval
    d1 = x.get("delta1_estimate", x.get("delta1_check"))
    keys = (
        "delta1_check_result",
        "delta1_used",
        "delta1_outside_range",
        "dtheta_range",
        "traversals",
        "torque_reversals",
        "sigma_fraction",
        "contact_threshold",
        "contact_deflection",
        "torque_source",
        "load_torque_constant",
        "load_range",
        "motor_range",
        "encoder_offset_bound",
        "encoder_reading",  # the convention applied (``gains`` holds the configuration's)
        "encoder_reading_from",  # "configuration", "recording metadata" or "none" (B7)
        "law_disagreement",
        # what a δ1 the check called "consistent" (within its floor) may still do to δ̂ [rad]: the
        # κ gain × the difference the check found, a bounded part of the interval (session 36)
        "delta1_check_bound",
        # "consistent" because the joint law fits the torque clearly worse (its δ1 no evidence)
        "delta1_check_by_ratio",
        # σ_δ: the scale of the verdict's δ1 floor, band and claim (params.verdict_scale)
        "verdict_scale",
        # an uncertain δ1 (estimate --identify): its std [rad], ∂δ̂/∂δ1 and the part of delta_std
        "delta1_std",
        "delta1_sensitivity",
        "delta1_sensitivity_measured",
        "delta1_propagated_std",
    )
    out: dict[str, Any] = {
        "delta_std": res.delta_std,
        "delta_interval_95": [lo, hi],
        "stiffness_scale": x.get("stiffness_scale"),
        "delta1_estimate": d1,
        "offset_switched": bool(x.get("offset_switched", False)),
        "warnings": list(res.warnings),
    }
    out.update({k: x[k] for k in keys if k in x})
    return out
