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
from pathlib import Path
from typing import Any

import typer

from drivelash.commands import FORCE_HELP, print_warnings
from drivelash.io.outputs import write_json
from drivelash.units import gap_unit

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


def _window(s: dict[str, Any], key: str) -> str:
    """A truth-metric window of an estimate summary, e.g. "20.0 s" (its length [s] at the end)."""
    w = s.get(key)
    return f"{w:.3g} s" if isinstance(w, (int, float)) and math.isfinite(w) else "?"


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
    resample: bool = False,
) -> dict[str, Any]:
    """Body of ``drivelash estimate`` (callable from Python; returns the JSON summary).

    ``identify``: identify the drive offline first (two-mass, 95 % intervals) and take the
    values the configuration lacks from it
    (:func:`drivelash.estimation.backlash_api.estimate_with_identification`).
    ``resample``: put a non-uniformly sampled recording on a uniform grid (``--resample``, as
    ``[sampling] resample = true``); without it such a recording is refused.
    Outputs (``json_out``, ``plot``, ``report``) are validated before any work and written
    together at the end (:class:`drivelash.io.outputs.Outputs`): a failing plot leaves none.
    """
    from drivelash.errors import DrivelashError
    from drivelash.estimation.backlash_api import IDENTIFY_COLUMNS, estimate_with_identification
    from drivelash.estimation.estimator import INPUT_COLUMNS
    from drivelash.estimation.pipeline import estimate_stream
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
            # what the identification needs; the online law's velocities are checked when it runs
            trace = load_trace(trace_path, cfg, required=IDENTIFY_COLUMNS, resample=resample or None)
            if not quiet:
                print_warnings(trace.meta)
            est = estimate_with_identification(trace, cfg, method=method)
            res, core = est.result, est.summary
            axis = trace.meta.get("axis")
        else:  # streamed: bounded memory, the same numbers as estimate_from_config on the whole trace
            rows = chunk_rows_from_env()
            with TraceStream(
                trace_path, cfg, required=INPUT_COLUMNS, chunk_rows=rows, resample=resample or None
            ) as stream:
                check_budget(
                    _stream_bytes(stream),
                    what=f"{trace_path}: estimating {stream.n_samples} samples in chunks",
                    option=f"lower {ENV_CHUNK_ROWS}",
                )
                if not quiet:
                    print_warnings(stream.meta)
                axis = stream.meta.get("axis")
                core, res, trace = estimate_stream(
                    cfg, stream, method, series=plot_t is not None or report_t is not None
                )
        ident_report = None
        if res is None and (plot_t is not None or report_t is not None):
            # --identify could not give the drive: no online time series to draw; the report is
            # the identification's (what the recording did determine, and why not the rest)
            if plot_t is not None:
                core.setdefault("warnings", []).append("no --plot written: the online estimate was not run")
            if report_t is not None and identify and est.identification is not None:
                from drivelash.report.identify_figures import render_two_mass_report

                why = str(core.get("reason") or "the online estimate was not run")
                ident_report = render_two_mass_report(trace, est.identification, cfg, online_not_run=why)
                core.setdefault("warnings", []).append(
                    "note: --report holds the offline identification only: the online estimate was not run"
                )
            elif report_t is not None:
                core.setdefault("warnings", []).append("no --report written: the online estimate was not run")
                report_t = None
            plot_t = None
        summary: dict[str, Any] = {"trace": str(trace_path), "config": str(config_path), **core}
        if json_t is not None:
            write_json(out.staging(json_t), summary)
        if plot_t is not None:
            from drivelash.report.estimation_figures import estimate_figure

            estimate_figure(trace, res, out.staging(plot_t))
        if ident_report is not None and report_t is not None:
            out.staging(report_t).write_text(ident_report, encoding="utf-8")
        elif report_t is not None:
            from drivelash.report import write_estimate_report

            write_estimate_report(out.staging(report_t), trace, res, cfg, summary=summary)
    if not quiet:
        _print_summary(summary, axis)
    return summary


def _print_summary(s: dict[str, Any], axis: str | None = None) -> None:
    """The terminal summary; δ, δ1 and the band in mrad, or in µm on a prismatic axis (positions
    in m: a linear axis's lost motion is micrometres, and "0.002 mrad … band 2 mrad" read as an
    angle; session 31 tester C, C7). The JSON keeps SI (rad or m)."""
    from rich.console import Console
    from rich.markup import escape

    c = Console()
    unit = gap_unit(axis)
    k, u = unit.per_si, unit.symbol
    verdict = "[green]sufficient[/green]" if s["excitation_ok"] else "[red]INSUFFICIENT[/red]"
    if s.get("delta1_outside_range"):  # the reason names a wrong δ1, not the recording
        verdict = "[red]not judged[/red]"
    c.print(
        f"[bold]deadzone estimate[/bold] ({s['method']} method, {s['samples']} samples at {s['T_s']:.3g} s)"
    )
    ident = s.get("identification")
    if ident is not None:
        d = ident["delta"]
        if d["identifiable"]:
            c.print(
                f"  offline δ = {k * d['value']:.3f} {u}, 95 % interval "
                f"[{k * d['ci95'][0]:.3f}, {k * d['ci95'][1]:.3f}] {u}"
            )
        else:
            c.print(f"  offline δ not determined: {escape(ident['reason'])}")
        for w in ident.get("warnings", []):  # the online warnings may point here ("see the
            # identification warning"): the remedy must be on the terminal, not only in the JSON
            c.print(f"  [yellow]offline warning:[/yellow] {escape(w)}")
    if s["delta"] is None:  # --identify could not give the drive: its reason and the warnings only
        c.print(f"  [yellow]{escape(s['reason'])}[/yellow]")
    else:
        std = s.get("delta_std")
        pm = f" ± {k * 1.96 * std:.2f} {u} (95 %)" if std is not None and math.isfinite(std) else ""
        d1 = f"{k * s['delta1']:.3f} {u}"
        d1_std = s.get("delta1_std")  # an identified δ1 (--identify): its own 95 % interval
        if s.get("delta1_source") == "identification" and d1_std is not None and math.isfinite(d1_std):
            d1 = f"{k * s['delta1']:.3f} ± {k * 1.96 * d1_std:.2f} {u}, identified"
        c.print(f"  δ̂ = {k * s['delta']:.3f} {u}{pm}   (δ1 = {d1})")
        if "delta_true" in s:
            c.print(  # windows stated (F8): they are fractions of the recording, not reproduce's
                f"  true δ = {k * s['delta_true']:.3f} {u}, MAEE (last {_window(s, 'maee_window_s')})"
                f" = {k * s['maee_rad']:.3f} {u},"
            )
            c.print(
                f"  steady-state peak (last {_window(s, 'steady_state_window_s')})"
                f" = {k * s['steady_state_peak_rad']:.3f} {u}"
            )
        c.print(f"  excitation {verdict}: {escape(s['reason'])}")
        conv = s["convergence_time_s"]
        if s["converged"]:
            after = f" after {conv:.2f} s" if conv is not None else ""
            c.print(f"  converged (band {k * s['convergence_band_rad']:.2g} {u}){after}")
        else:
            c.print("  [yellow]not converged[/yellow] — do not use this estimate")
        if s.get("delta1_check_result") not in (None, "not run"):
            d1 = s.get("delta1_estimate")
            # an unsettled joint law's δ1 is where it was, not what the data give
            said = "unsettled law" if s.get("delta1_check_result") == "not settled" else "data"
            d1s = f" ({said}: {k * d1:.3g} {u})" if d1 is not None else ""
            bound = s.get("delta1_check_bound")
            if (
                s.get("delta1_check_result") == "consistent"
                and d1 is not None
                and s.get("delta1_check_by_ratio")
            ):
                # the joint law's δ1 beside a different configured one, no bound: say why (J4)
                d1s = (
                    f" (data: {k * d1:.3g} {u} — no evidence against δ1: the joint δ/δ1 law that gives it"
                    " fits the shaft torque clearly worse)"
                )
            elif s.get("delta1_check_result") == "consistent" and d1 is not None and bound:
                # the data's δ1 beside a different configured one: say why that is "consistent"
                # and what it costs (I5: "consistent (data: 1.50 mrad)" beside δ1 = 1.800 mrad)
                d1s = (
                    f" (data: {k * d1:.3g} {u}, {k * (d1 - s['delta1_used']):+.2g} {u} from δ1, within the"
                    f" check's tolerance; δ1 kept, the interval allows ±{k * bound:.2g} {u} for it)"
                )
            c.print(f"  δ1 check: {escape(str(s['delta1_check_result']))}{d1s}")
    for w in s.get("warnings", []):
        if s["delta"] is None and w == s["reason"]:
            continue  # printed just above
        if w.startswith("note: "):  # a note is not a warning: one prefix, not "warning: note:"
            c.print(f"  note: {escape(w[len('note: ') :])}")
        else:
            c.print(f"  [yellow]warning:[/yellow] {escape(w)}")


def run_reproduce(
    out: Path, quick: bool = False, workers: int = 2, quiet: bool = False, force: bool = False
) -> dict[str, Any]:
    """Body of ``drivelash reproduce``; returns the table rows and the written files.

    ``out`` is written as a whole (:meth:`drivelash.io.outputs.Outputs.directory`): the
    files appear together at the end, replacing a previous ``reproduce`` output.
    """
    from rich.console import Console
    from rich.markup import escape

    from drivelash.io.outputs import Outputs

    console = Console(quiet=quiet)
    with Outputs("reproduce", force=force) as outputs:
        target = outputs.directory(out, option="-o")
        assert target is not None
        result = _reproduce_into(outputs.staging(target), quick, workers, console)
    files = [target / f.name for f in result["files"]]
    console.print(f"[green]wrote {escape(', '.join(str(f) for f in files))}[/green]")
    return result | {"files": files}


def _reproduce_into(out: Path, quick: bool, workers: int, console: Any) -> dict[str, Any]:
    from drivelash.estimation.reproduce import (
        BENCH_MAEE_WINDOW_S,
        BENCH_SETTLE_HOLD_S,
        BENCH_SS_WINDOW_S,
        PAPER_SIM_MAEE_AFTER_STEP_S,
        PAPER_SIM_SETTLE_HOLD_S,
        PAPER_SIM_SS_WINDOW_S,
        SCORED_ESTIMATOR,
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
        + f'Each row scores {SCORED_ESTIMATOR}; "converged" and "±95 %" are that estimate\'s own '
        "verdict and interval half-width (a run not converged is one `estimate` says not to use). "
        f"MAEE: max |δ̂ − δ*| over the last {BENCH_MAEE_WINDOW_S:g} s of each bench run (paper-sim: "
        f"from {PAPER_SIM_MAEE_AFTER_STEP_S:g} s after the step to the end); SS peak: last "
        f"{BENCH_SS_WINDOW_S:g} s (bench) / max over the last {PAPER_SIM_SS_WINDOW_S:g} s before the "
        "step and at the end (paper-sim: so it can exceed its MAEE). `drivelash estimate` on a "
        "recording with δ* uses other windows: the last third (MAEE) and the last sixth (SS peak) of "
        "the recording — the same as here for a 60 s bench run only. t(band): first time after which "
        '|δ̂ − δ*| stays within the band (after the step for paper-sim); "not settled" when it '
        f"does not stay there for the last {BENCH_SETTLE_HOLD_S:g} s of a bench run "
        f"({PAPER_SIM_SETTLE_HOLD_S:g} s of each paper-sim interval). Paper values: §V–VI (MAEE "
        "1.75/1.90/0.66 mrad for 0A/0B/0C, ≤ 4 mrad elsewhere; convergence ≈ 40 s on the bench, "
        "< 2 s in simulation).\n\n"
    )
    summ = {m: summary_numbers(rows, m) for m in ("paper", "default")}

    def _conv(v: float) -> str:
        return f"{v:.2f} s" if math.isfinite(v) else "— (a run did not settle)"

    tail = "\n" + "".join(
        f"- {m}: worst bench MAEE {v['max_maee_mrad']:.3f} mrad, "
        f"worst t(10 mrad) {_conv(v['max_conv_10mrad_s'])}, "
        f"converged on {v['converged']:.0f} of {v['runs']:.0f} bench runs\n"
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
            "from it (an identified δ1's uncertainty is carried into δ̂'s interval); the JSON carries "
            "offline δ and online δ̂ and flags disagreement.",
        ),
        resample: bool = typer.Option(
            False, "--resample", help="Resample non-uniform time onto a uniform grid."
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
            resample=resample,
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
