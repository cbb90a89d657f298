"""``drivelash estimate`` and ``drivelash reproduce``: the online deadzone estimator on files.

``estimate TRACE --config DRIVE.toml`` reads a recording (any format :func:`drivelash.io.load_trace`
knows, with the configuration's column mapping), runs the estimator of spec 01 §2 with the
documented default tuning (gains in ``[estimator]`` override it), prints a summary and
writes JSON / PNG / HTML on request. Every user error is one line naming the file and the
field (exit code 2); outputs are written only after the estimate succeeded.

``reproduce`` runs ``paper-sim`` and the 18 bench tests (both methods), writes the table
(CSV + Markdown) of MAEE, steady-state peak and convergence times next to the paper's
values, and the figures (paper's Fig. 8, 13/19, 15, 10).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import typer

from drivelash.commands import FORCE_HELP, print_warnings
from drivelash.io.outputs import write_json

#: Fractions of a recording used for MAEE and steady-state peak when the truth is known
#: (for a 60 s bench run: the last 20 s and the last 10 s, as in ``reproduce``).
MAEE_FRACTION = 1.0 / 3.0
SS_FRACTION = 1.0 / 6.0


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


def estimate_trace(cfg: Any, trace: Any, method: str | None = None, keep: str = "full") -> tuple[Any, Any]:
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

    Returns
    -------
    (EstimationResult, MotionSummary)
    """
    from drivelash.estimation.estimator import trace_blocks

    return _estimate_blocks(cfg, trace_blocks(trace), trace.T_s, method, keep=keep, meta=trace.meta)


def _estimate_blocks(
    cfg: Any,
    blocks: Callable[[], Iterator[Mapping[str, np.ndarray]]],
    T_s: float,
    method: str | None,
    *,
    keep: str = "full",
    truth: bool = False,
    meta: Mapping[str, Any] | None = None,
) -> tuple[Any, Any]:
    """:func:`estimate_trace` on a block source (an in-memory trace or a file read in chunks).

    ``truth``: the blocks carry ``delta_true``; max |δ* − δ̂| over the MAEE and steady-state
    windows is accumulated while streaming (``extra["max_abs_error_since"]``). ``meta``: the
    recording's metadata (its ``encoder_reading``, when stated, is used).
    """
    from drivelash.errors import ConfigError
    from drivelash.estimation.estimator import estimate_blocks, scan_blocks

    drivetrain = cfg.to_drivetrain_params()
    bl = cfg.require("backlash")
    if not (math.isfinite(bl.delta1) and bl.delta1 >= 0):
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
        float(bl.delta1),
        blocks,
        method=law,  # type: ignore[arg-type]
        overrides=over,
        motion=motion,
        keep=keep,  # type: ignore[arg-type]
        error_since=since,
        encoder_reading=(meta or {}).get("encoder_reading"),
    )
    return res, motion


def estimate_summary(cfg: Any, res: Any, motion: Any, samples: int, T_s: float) -> dict[str, Any]:
    """The JSON summary of an estimate, without the truth metrics (shared by both paths)."""
    return {
        "method": res.config.method,
        "delta": res.delta,
        "delta1": float(cfg.backlash.delta1),
        "excitation_ok": res.excitation_ok,
        "reason": res.reason,
        "converged": res.converged,
        "convergence_time_s": res.convergence_time_s,
        "convergence_band_rad": res.band,
        "samples": samples,
        "T_s": T_s,
        "excitation_frequency_hz": motion.f_exc,
        **result_summary(res),
        "gains": res.config.to_dict(),
    }


#: Columns the estimator reads from a recording (the others are not read).
_ESTIMATE_COLUMNS = ("theta_m", "omega_m", "theta_l", "omega_l", "torque_m", "delta_true")
#: Columns kept, decimated like the result's series, for ``--plot`` / ``--report``.
_PLOT_COLUMNS = ("t", "theta_m", "omega_m", "theta_l", "omega_l", "delta_true")
#: Environment variable: rows per chunk when ``estimate`` streams a recording.
ENV_CHUNK_ROWS = "DRIVELASH_CHUNK_ROWS"


def chunk_rows_from_env() -> int:
    """Rows per chunk of the streaming reader: ``DRIVELASH_CHUNK_ROWS`` or the default."""
    import os

    from drivelash.errors import ResourceError
    from drivelash.io.formats import DEFAULT_CHUNK_ROWS

    env = os.environ.get(ENV_CHUNK_ROWS, "").strip()
    if not env:
        return DEFAULT_CHUNK_ROWS
    try:
        rows = int(env)
    except ValueError:
        rows = 0
    if rows < 3:
        raise ResourceError(f"{ENV_CHUNK_ROWS}={env!r}: must be a whole number of rows >= 3")
    return rows


def _stream_bytes(stream: Any) -> float:
    """Memory ``estimate`` plans for a streamed recording [bytes]: the reader's
    (:meth:`~drivelash.io.stream.TraceStream.peak_bytes`), the pass-1 series (θ_m/N and the
    torque every ms: 16 B each), the two laws' output series and δ̂ histories."""
    from drivelash.estimation import deadzone as dz
    from drivelash.estimation.estimator import HISTORY_BLOCKS, SERIES_POINTS
    from drivelash.estimation.motion import DECIMATION_PERIOD

    B = max(1, int(DECIMATION_PERIOD / stream.T_s)) if stream.T_s > 0 else 1
    pass1 = 16.0 * stream.n_samples / B
    laws = 2 * (2 * SERIES_POINTS * (dz.N_OUT + 1) * 8.0 + 4 * HISTORY_BLOCKS * 8.0)
    return stream.peak_bytes() + pass1 + laws


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
        "law_disagreement",
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


def run_estimate(
    trace_path: Path,
    config_path: Path,
    *,
    json_out: Path | None = None,
    plot: Path | None = None,
    method: str | None = None,
    report: Path | None = None,
    quiet: bool = False,
    identify: bool = False,
    force: bool = False,
) -> dict[str, Any]:
    """Body of ``drivelash estimate`` (callable from Python; returns the JSON summary).

    ``identify``: identify the drive offline first (two-mass, 95 % intervals) and take the
    values the configuration lacks from it
    (:func:`drivelash.estimation.backlash_api.estimate_with_identification`).
    Outputs (``json_out``, ``plot``, ``report``) are validated before any work and written
    together at the end (:class:`drivelash.io.outputs.Outputs`): a failing plot leaves none.
    """
    from drivelash.errors import DrivelashError
    from drivelash.estimation.backlash_api import estimate_with_identification
    from drivelash.estimation.estimator import INPUT_COLUMNS
    from drivelash.io import load_config, load_trace
    from drivelash.io.budget import check_budget
    from drivelash.io.outputs import HTML_EXTENSIONS, JSON_EXTENSIONS, PLOT_EXTENSIONS, Outputs
    from drivelash.io.stream import TraceStream

    if method not in (None, "paper", "default"):
        raise DrivelashError(f"--method: must be 'paper' or 'default', got {method!r}")
    with Outputs("estimate", inputs=[trace_path, config_path], force=force) as out:
        json_t = out.file(json_out, option="--json", kinds=JSON_EXTENSIONS)
        plot_t = out.file(plot, option="--plot", kinds=PLOT_EXTENSIONS)
        report_t = out.file(report, option="--report", kinds=HTML_EXTENSIONS)
        cfg = load_config(config_path)
        if not identify:
            cfg.require("backlash")
        if identify:  # the offline identification needs the whole recording (read within the budget)
            trace = load_trace(trace_path, cfg, required=[*INPUT_COLUMNS, "torque_m"])
            if not quiet:
                print_warnings(trace.meta)
            est = estimate_with_identification(trace, cfg, method=method)
            res, core = est.result, est.summary
        else:  # streamed: bounded memory, the same numbers as estimate_from_config on the whole trace
            rows = chunk_rows_from_env()
            with TraceStream(trace_path, cfg, required=INPUT_COLUMNS, chunk_rows=rows) as stream:
                check_budget(
                    _stream_bytes(stream),
                    what=f"{trace_path}: estimating {stream.n_samples} samples in chunks",
                    option=f"lower {ENV_CHUNK_ROWS}",
                )
                if not quiet:
                    print_warnings(stream.meta)
                core, res, trace = estimate_stream(
                    cfg, stream, method, series=plot_t is not None or report_t is not None
                )
        if res is None and (plot_t is not None or report_t is not None):
            # --identify could not give the drive: the verdict only, no time series to draw
            core.setdefault("warnings", []).append(
                "no --plot/--report written: the online estimate was not run"
            )
            plot_t = report_t = None
        summary: dict[str, Any] = {"trace": str(trace_path), "config": str(config_path), **core}
        if json_t is not None:
            write_json(out.staging(json_t), summary)
        if plot_t is not None:
            from drivelash.report.estimation_figures import estimate_figure

            estimate_figure(trace, res, out.staging(plot_t))
        if report_t is not None:
            from drivelash.report import write_estimate_report

            write_estimate_report(out.staging(report_t), trace, res, cfg)
    if not quiet:
        _print_summary(summary)
    return summary


def _print_summary(s: dict[str, Any]) -> None:
    from rich.console import Console

    c = Console()
    verdict = "[green]sufficient[/green]" if s["excitation_ok"] else "[red]INSUFFICIENT[/red]"
    c.print(
        f"[bold]deadzone estimate[/bold] ({s['method']} method, {s['samples']} samples at {s['T_s']:.3g} s)"
    )
    ident = s.get("identification")
    if ident is not None:
        d = ident["delta"]
        if d["identifiable"]:
            c.print(
                f"  offline δ = {1e3 * d['value']:.3f} mrad, 95 % interval "
                f"[{1e3 * d['ci95'][0]:.3f}, {1e3 * d['ci95'][1]:.3f}] mrad"
            )
        else:
            c.print(f"  offline δ not determined: {ident['reason']}")
    if s["delta"] is None:  # --identify could not give the drive
        c.print(f"  [yellow]{s['reason']}[/yellow]")
        for w in s.get("warnings", []):
            c.print(f"  [yellow]warning:[/yellow] {w}")
        return
    std = s.get("delta_std")
    pm = f" ± {1e3 * 1.96 * std:.2f} mrad (95 %)" if std is not None and math.isfinite(std) else ""
    c.print(f"  δ̂ = {1e3 * s['delta']:.3f} mrad{pm}   (δ1 = {1e3 * s['delta1']:.3f} mrad)")
    if "delta_true" in s:
        c.print(
            f"  true δ = {1e3 * s['delta_true']:.3f} mrad, MAEE = {1e3 * s['maee_rad']:.3f} mrad, "
            f"steady-state peak = {1e3 * s['steady_state_peak_rad']:.3f} mrad"
        )
    c.print(f"  excitation {verdict}: {s['reason']}")
    conv = s["convergence_time_s"]
    if s["converged"]:
        after = f" after {conv:.2f} s" if conv is not None else ""
        c.print(f"  converged (band {1e3 * s['convergence_band_rad']:.2g} mrad){after}")
    else:
        c.print("  [yellow]not converged[/yellow] — do not use this estimate")
    if s.get("delta1_check_result") not in (None, "not run"):
        d1 = s.get("delta1_estimate")
        d1s = f" (data: {1e3 * d1:.2f} mrad)" if d1 is not None else ""
        c.print(f"  δ1 check: {s['delta1_check_result']}{d1s}")
    for w in s.get("warnings", []):
        c.print(f"  [yellow]warning:[/yellow] {w}")


def run_reproduce(
    out: Path, quick: bool = False, workers: int = 2, quiet: bool = False, force: bool = False
) -> dict[str, Any]:
    """Body of ``drivelash reproduce``; returns the table rows and the written files.

    ``out`` is written as a whole (:meth:`drivelash.io.outputs.Outputs.directory`): the
    files appear together at the end, replacing a previous ``reproduce`` output.
    """
    from rich.console import Console

    from drivelash.io.outputs import Outputs

    console = Console(quiet=quiet)
    with Outputs("reproduce", force=force) as outputs:
        target = outputs.directory(out, option="-o")
        assert target is not None
        result = _reproduce_into(outputs.staging(target), quick, workers, console)
    files = [target / f.name for f in result["files"]]
    console.print(f"[green]wrote {', '.join(str(f) for f in files)}[/green]")
    return result | {"files": files}


def _reproduce_into(out: Path, quick: bool, workers: int, console: Any) -> dict[str, Any]:
    from drivelash.estimation.reproduce import (
        reproduce_table,
        summary_numbers,
        table_csv,
        table_markdown,
    )
    from drivelash.report import estimation_figures as figs

    if quick:
        names = ["paper-sim", "bench-0B", "bench-5C"]
        bench_duration: float | None = 30.0
    else:
        from drivelash.sim.scenarios import list_scenarios

        names = [s.name for s in list_scenarios()]
        bench_duration = None
    rows = reproduce_table(
        names,
        duration=None,
        bench_duration=bench_duration,
        workers=workers,
        progress=lambda n: console.print(f"  {n} done"),
    )
    md = table_markdown(rows)
    head = (
        "# Deadzone estimation: paper vs this implementation\n\n"
        + ("**Quick run** (subset, 30 s bench runs).\n\n" if quick else "")
        + "MAEE: max |δ̂ − δ*| over the last 20 s of each bench run (paper-sim: from 2 s after the step); "
        "SS peak: last 10 s (bench) / last 0.5 s before the step and at the end (paper-sim); "
        "t(band): first time after which |δ̂ − δ*| stays within the band (after the step for "
        "paper-sim). Paper values: §V–VI (MAEE 1.75/1.90/0.66 mrad for 0A/0B/0C, ≤ 4 mrad "
        "elsewhere; convergence ≈ 40 s on the bench, < 2 s in simulation).\n\n"
    )
    summ = {m: summary_numbers(rows, m) for m in ("paper", "default")}
    tail = "\n" + "".join(
        f"- {m}: worst bench MAEE {v['max_maee_mrad']:.3f} mrad, "
        f"worst t(10 mrad) {v['max_conv_10mrad_s']:.2f} s\n"
        for m, v in summ.items()
        if v
    )
    (out / "reproduce.md").write_text(head + md + tail, encoding="utf-8")
    (out / "reproduce.csv").write_text(table_csv(rows), encoding="utf-8")
    files = [out / "reproduce.md", out / "reproduce.csv"]
    console.print("figures …")
    files += figs.reproduce_figures(out, rows, quick=quick)
    console.print(md)
    return {"rows": rows, "files": files, "summary": summ}


def register(app: typer.Typer, te_app: typer.Typer) -> None:
    """Add ``estimate`` and ``reproduce`` to the CLI."""

    @app.command()
    def estimate(
        trace: Path = typer.Argument(..., help="Recording (CSV, Parquet, HDF5, MAT)."),
        config: Path = typer.Option(
            ..., "--config", "-c", help="DRIVE.toml: tables drivetrain, backlash, estimator (optional)."
        ),
        json_out: Path | None = typer.Option(None, "--json", help="Write a JSON summary here."),
        plot: Path | None = typer.Option(None, "--plot", help="Write a PNG of δ̂(t) and torque vs Δθ here."),
        method: str | None = typer.Option(
            None,
            "--method",
            help="paper (the paper's law) or default (improved); default: [estimator] method, else default.",
        ),
        report: Path | None = typer.Option(None, "--report", help="Write a self-contained HTML report here."),
        identify: bool = typer.Option(
            False,
            "--identify",
            help="Identify the drive first (two-mass, 95 % intervals); values the config lacks come "
            "from it; the JSON carries offline δ and online δ̂ and flags disagreement.",
        ),
        force: bool = typer.Option(False, "--force", help=FORCE_HELP),
    ) -> None:
        """Estimate the deadzone (backlash) angle of a drive train from a recording."""
        run_estimate(
            trace,
            config,
            json_out=json_out,
            plot=plot,
            method=method,
            report=report,
            identify=identify,
            force=force,
        )

    @app.command()
    def reproduce(
        quick: bool = typer.Option(False, "--quick", help="Subset with shorter runs (about a minute)."),
        out: Path = typer.Option(Path("reproduce-output"), "-o", "--out", help="Output directory."),
        workers: int = typer.Option(2, "--workers", min=1, help="Parallel processes for the scenario sweep."),
        force: bool = typer.Option(False, "--force", help=FORCE_HELP),
    ) -> None:
        """Re-run the paper's simulation and the 18 bench tests; write table and figures."""
        run_reproduce(out, quick=quick, workers=workers, force=force)
