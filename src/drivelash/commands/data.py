"""``drivelash identify`` and ``drivelash observe``: real recordings in, parameters out.

Both commands read a recording with :func:`drivelash.io.load_trace` (mapping and
units from ``--config``). Their output paths are validated before any work, and the
outputs are written together at the end (:class:`drivelash.io.outputs.Outputs`), so a
bad input (exit code 2, one-line message) leaves no partial files behind.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import typer

from drivelash.commands import FORCE_HELP, print_warnings

OUT_HELP = "Write a JSON summary here."


def _write_identify_outputs(outputs: Any, *pairs: tuple[Path | None, Any]) -> None:
    """Write the computed outputs of ``identify`` together (one staged set): each pair is
    (target or None, content); a ``dict`` content is JSON, a ``str`` is text, ``None`` skips."""
    from drivelash.io.outputs import write_json

    with outputs:
        for target, content in pairs:
            if target is None or content is None:
                continue
            if isinstance(content, dict):
                write_json(outputs.staging(target), content)
            else:
                outputs.staging(target).write_text(content, encoding="utf-8")


#: Decimated rows of the rigid identification kept for ``--report`` (about; every k-th row).
IDENTIFY_PLOT_ROWS = 20000


def _open_stream(path: Path, cfg: Any, need: list[str], resample: bool, what: str) -> Any:
    """A :class:`~drivelash.io.stream.TraceStream` of ``path`` (chunks of ``DRIVELASH_CHUNK_ROWS``),
    its memory plan checked against the budget."""
    from drivelash.commands.estimate import ENV_CHUNK_ROWS, chunk_rows_from_env
    from drivelash.io.budget import check_budget
    from drivelash.io.stream import TraceStream

    rows = chunk_rows_from_env()
    stream = TraceStream(path, cfg, required=need, resample=resample or None, chunk_rows=rows)
    try:
        check_budget(
            stream.peak_bytes() + OBSERVE_BYTES_PER_CHUNK_ROW * min(rows, stream.n_samples),
            what=f"{path}: {what} {stream.n_samples} samples in chunks",
            option=f"lower {ENV_CHUNK_ROWS}",
        )
    except BaseException:
        stream.close()
        raise
    return stream


def _thinned_chunks(
    stream: Any, keep: int | None, cols: list[str]
) -> tuple[Any, dict[str, list[np.ndarray]]]:
    """``chunks()`` over ``stream`` that also keeps every ``keep``-th row of ``cols`` (the
    report's thinned recording; the last pass's rows)."""
    kept: dict[str, list[np.ndarray]] = {}

    def chunks() -> Any:
        kept.clear()
        if keep is not None:
            kept.update({c: [] for c in ["t", *cols]})
        for ch in stream.chunks():
            if keep is not None:
                s = (-ch.row0) % keep
                for c in kept:
                    kept[c].append(ch[c][s::keep].copy())
            yield ch

    return chunks, kept


def _report_keep(n: int) -> int:
    from drivelash.report import _MAX_POINTS

    return max(1, n // _MAX_POINTS)


def _identify_motor_stream(stream: Any, opts: Any, spill_dir: Path, report: bool) -> tuple[Any, Any]:
    """Rigid IDIM-LS over the stream (:func:`~drivelash.estimation.identify.identify_rigid_stream`);
    with ``report`` also the recording thinned as the report draws it."""
    from drivelash.estimation.identify import identify_rigid_stream
    from drivelash.io import Trace

    keep = _report_keep(stream.n_samples) if report else None
    chunks, kept = _thinned_chunks(stream, keep, _observe_columns(stream.names, True))
    result = identify_rigid_stream(
        chunks,
        stream.n_samples,
        stream.T_s,
        list(stream.names),
        cutoff_hz=opts.cutoff_hz,
        filter_order=opts.filter_order,
        decimate=opts.decimate,
        n_border=opts.n_border,
        keep=None,
        plot_rows=IDENTIFY_PLOT_ROWS if report else None,
        spill_dir=spill_dir,
        back_rows=stream.chunk_rows,
        axis=str(stream.meta.get("axis", "rotary")),
        source=str(stream.path),
    )
    thin = Trace({c: np.concatenate(v) for c, v in kept.items()}, meta=stream.meta) if report else None
    return result, thin


def run_identify(
    trace_path: Path,
    config_path: Path,
    *,
    json_out: Path | None = None,
    report: Path | None = None,
    out: Path | None = None,
    cross: Path | None = None,
    resample: bool = False,
    quiet: bool = False,
    model: str | None = None,
    force: bool = False,
) -> dict[str, Any]:
    """Body of ``drivelash identify`` (callable from Python; returns the JSON summary).

    ``model`` (or ``[identification] model``): ``"rigid"`` (IDIM-LS, this function) or
    ``"two-mass"`` (:func:`run_identify_two_mass`).
    """
    from drivelash.errors import DrivelashError
    from drivelash.io import load_config as _load_config

    why = "--model"
    if model is None:
        from drivelash.estimation.identify_api import resolve_model
        from drivelash.io.stream import mapped_names

        cfg0 = _load_config(config_path)
        model, why = resolve_model(cfg0, None, names=mapped_names(trace_path, cfg0))
    if model not in ("rigid", "two-mass"):
        raise DrivelashError(f"--model: must be 'rigid' or 'two-mass', got {model!r}")
    if model == "two-mass":
        if cross is not None:
            raise DrivelashError("--cross: the cross-test is for the rigid model (IDIM-LS) only")
        return run_identify_two_mass(
            trace_path,
            config_path,
            json_out=json_out,
            report=report,
            out=out,
            resample=resample,
            quiet=quiet,
            force=force,
            model_choice=why,
        )
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    from drivelash.estimation.identify import cross_test, identify
    from drivelash.estimation.identify_two_mass import rigid_result
    from drivelash.io import load_config, load_trace
    from drivelash.io.config import drivetrain_fragment
    from drivelash.io.outputs import HTML_EXTENSIONS, JSON_EXTENSIONS, TOML_EXTENSIONS, Outputs
    from drivelash.io.spill import spill_directory

    outputs = Outputs("identify", inputs=[trace_path, config_path, cross], force=force)
    out_t = outputs.file(out, option="--out", kinds=TOML_EXTENSIONS)
    json_t = outputs.file(json_out, option="--json", kinds=JSON_EXTENSIONS)
    report_t = outputs.file(report, option="--report", kinds=HTML_EXTENSIONS)
    cfg = load_config(config_path)
    opts = cfg.identification_or_default()
    need = ["theta_m", "torque_m"] + (["theta_l"] if opts.side == "load" else [])
    if opts.side == "motor":  # streamed, bounded memory (the load side needs the whole trace)
        with _open_stream(trace_path, cfg, need, resample, "identifying") as stream:
            print_warnings(stream.meta)
            spill_dir = spill_directory(out_t, json_t, report_t)
            result, trace = _identify_motor_stream(stream, opts, spill_dir, report_t is not None)
            obs = None
            # the observer's report compares d̂ with F_c sign q̇ + offset: not with an undetermined F_c
            if result["M"] > 0 and not rigid_result(result).warnings and not result.not_determined:
                obs, _ = observe_recording(
                    stream,
                    J=result["M"],
                    beta=result["F_v"],
                    est=cfg.estimator,
                    opts=opts,
                    spill_dir=spill_dir,
                    report=report_t is not None,
                )
    else:
        trace = load_trace(trace_path, cfg, required=need, resample=resample or None)
        print_warnings(trace.meta)
        result = identify(trace, opts, cfg.drivetrain)
        obs = None

    flags = rigid_result(result).warnings
    if flags:  # physically impossible (e.g. a torque gain with the wrong sign): refuse, write nothing
        from drivelash.errors import DataError

        raise DataError(f"implausible identification, nothing written: {flags[0]}", path=str(trace_path))
    summary: dict[str, Any] = {
        "trace": str(trace_path),
        "config": str(config_path),
        "model": "rigid",
        "model_choice": why,
        **result.as_dict(),
    }
    ct = None
    vtrace = None
    if cross is not None:
        vtrace = load_trace(cross, cfg, required=need, resample=resample or None)
        print_warnings(vtrace.meta)
        ct = cross_test(result, vtrace)
        summary["cross_test"] = {
            "trace": str(cross),
            "relative_error": ct.relative_error,
            "scale": ct.scale,
            "notes": ct.notes,
        }

    values = result.drivetrain_values()
    merged: dict[str, float] = {}
    if cfg.drivetrain is not None:
        merged = {k: v for k, v in cfg.drivetrain.given().items() if v is not None}
    merged.update(values)
    unit = "N, N·s/m, kg (prismatic axis)" if result.axis == "prismatic" else "SI (N·m, N·m·s/rad, kg·m²)"
    comments = [
        f"drivelash identify {trace_path} ({result.side} side, IDIM-LS, units {unit}; model rigid "
        + (f"from {why})" if why in ("--model", "[identification] model") else f"{why})"),
        "identified: "
        + ", ".join(
            f"{n} not determined"
            if n in result.not_determined
            else f"{n} = {result[n]:.6g} ± {result.std_of(n):.2g}"
            for n in result.names
        ),
        f"relative force error {100 * result.relative_error:.2f} %"
        + (f"; cross-test {100 * ct.relative_error:.2f} % on {cross}" if ct else ""),
        *(f"warning: {note}" for note in result.notes),
        *(f"warning: {note}" for note in (ct.notes if ct else [])),
    ]
    fragment = drivetrain_fragment(merged, comments)
    summary["drivetrain"] = merged
    if result.side == "motor" and "offset" not in result.not_determined:
        # the constant part of the recorded force/torque (sensor offset, a constant load): in the
        # table `observe` reads it from, so that its reference is F_c sign q̇ + offset as here
        fragment += (
            "\n# the recorded motor torque's constant offset (IDIM-LS 'offset'; observe draws"
            " T_Cm sign q̇ + torque_offset)\n[identification]\n"
            f"torque_offset = {float(result['offset'])!r}\n"
        )
        summary["torque_offset"] = float(result["offset"])

    if obs is not None:
        summary["observer"] = {
            **obs.as_dict(),
            "identified_forward": result["F_c"] + result["offset"],
            "identified_backward": -result["F_c"] + result["offset"],
        }
    html = None
    if report is not None:
        from drivelash.report import render_identify_report

        html = render_identify_report(trace, result, cfg, cross=ct, cross_trace=vtrace, observer=obs)

    _write_identify_outputs(outputs, (out_t, fragment), (json_t, summary), (report_t, html))
    if not quiet:
        console = Console(stderr=out is None)
        table = Table(title=f"IDIM-LS ({result.side} side, {result.axis} axis)")
        for col in ("parameter", "value", "std", "std %"):
            table.add_column(col, justify="right")
        for n, v, s in zip(result.names, result.theta, result.std, strict=True):
            if n in result.not_determined:
                table.add_row(n, "not determined", "-", "-")
            else:
                table.add_row(n, f"{v:.6g}", f"{s:.3g}", f"{100 * s / abs(v):.2f}" if v else "-")
        console.print(table)
        console.print(f"relative force error: {100 * result.relative_error:.2f} %")
        if why != "--model":
            console.print(f"model: rigid ({escape(why)})")
        for note in result.notes:
            console.print(f"warning: {escape(note)}")
        if ct is not None:
            console.print(f"cross-test on {escape(str(cross))}: {100 * ct.relative_error:.2f} %")
            for note in ct.notes:
                console.print(f"warning: {escape(note)}")
        if out is None:
            sys.stdout.write(fragment)
    return summary


def run_identify_two_mass(
    trace_path: Path,
    config_path: Path,
    *,
    json_out: Path | None = None,
    report: Path | None = None,
    out: Path | None = None,
    resample: bool = False,
    quiet: bool = False,
    force: bool = False,
    model_choice: str = "--model",
) -> dict[str, Any]:
    """Body of ``drivelash identify --model two-mass`` (returns the JSON summary).

    Identifies J_m, J_l, K_S, D_S, friction, torque offset, δ and δ1 with 95 % intervals
    (:func:`drivelash.estimation.identify_two_mass.identify_two_mass`) and writes the
    ``[drivetrain]``/``[backlash]`` tables ``estimate`` reads. A physically impossible result
    (negative inertia, stiffness or friction beyond its interval) never goes into a drive
    table: no output requested (TOML to stdout) — refused with the likely cause, nothing
    written; ``--json``/``--report`` — the diagnosis is written (``plausible: false``, no parameter
    determined, the verdict saying why), then with ``--out`` the refusal is raised, without it
    the summary is returned and the ``identify`` command exits 2 (the same exit code whether
    ``--out`` was given or not).
    """
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    from drivelash.errors import DataError
    from drivelash.estimation.identify_api import identify_checked
    from drivelash.estimation.identify_two_mass import select_window
    from drivelash.io import load_config
    from drivelash.io.outputs import HTML_EXTENSIONS, JSON_EXTENSIONS, TOML_EXTENSIONS, Outputs

    outputs = Outputs("identify", inputs=[trace_path, config_path], force=force)
    out_t = outputs.file(out, option="--out", kinds=TOML_EXTENSIONS)
    json_t = outputs.file(json_out, option="--json", kinds=JSON_EXTENSIONS)
    report_t = outputs.file(report, option="--report", kinds=HTML_EXTENSIONS)
    cfg = load_config(config_path)
    opts = cfg.identification_or_default()
    need = ["theta_m", "theta_l", "torque_m"]
    with _open_stream(trace_path, cfg, need, resample, "identifying") as stream:
        if not quiet:
            print_warnings(stream.meta)
        # a recording longer than the fit's budget: its most informative stretch (stated)
        trace, window = select_window(stream, opts.max_samples)
    result = identify_checked(trace, cfg, model="two-mass")
    # an impossible drive (negative inertia or friction) never goes into a config file; the
    # diagnosis (--json / --report) is still written, with the verdict, and the command exits 2
    # either way (M7, session 30: with only --json it exited 0, without --out 2)
    implausible = not result.plausible
    diagnosis = json_t is not None or report_t is not None
    if implausible and not diagnosis:
        raise DataError(
            f"implausible identification, nothing written: {result.warnings[0]}", path=str(trace_path)
        )
    summary: dict[str, Any] = {
        "trace": str(trace_path),
        "config": str(config_path),
        "model": "two-mass",
        "model_choice": model_choice,
        **result.as_dict(),
    }
    if window is not None:
        summary["window"] = window
    # [drivetrain]: the configuration's values where the recording determined nothing
    merged = result.to_config()
    if cfg.drivetrain is not None:
        base = {k: v for k, v in cfg.drivetrain.given().items() if v is not None}
        merged["drivetrain"] = {**base, **merged["drivetrain"]}
    summary["config_tables"] = merged
    head = [
        f"drivelash identify {trace_path} --model two-mass (config {config_path}; "
        + (
            f"model from {model_choice})"
            if model_choice in ("--model", "[identification] model")
            else f"{model_choice})"
        ),
        f"method: {result.method}",
    ]
    if window is not None:
        head.append(
            f"fitted on samples {window['first_sample']}–{window['first_sample'] + window['samples'] - 1}"
            f" of {window['recording_samples']} (t = {window['start_s']:.6g}–{window['stop_s']:.6g} s):"
            f" {window['rule']}"
        )
    text = result.to_toml(comments=head, tables=merged)
    html = None
    if report_t is not None:
        from drivelash.report.identify_figures import render_two_mass_report

        html = render_two_mass_report(trace, result, cfg)
    _write_identify_outputs(
        outputs, (None if implausible else out_t, text), (json_t, summary), (report_t, html)
    )
    if implausible and out is not None:
        written = " and ".join(str(o) for o in (json_out, report) if o is not None)
        raise DataError(
            f"implausible identification, no drive table written (the diagnosis is in {written}): "
            f"{result.warnings[0]}",
            path=str(trace_path),
        )
    if not quiet:
        console = Console(stderr=out is None)
        table = Table(title="two-mass identification (95 % intervals)")
        for col in ("parameter", "value", "95 % interval", "unit", "note"):
            table.add_column(col, justify="right")
        for prm in result.parameters.values():
            if prm.identifiable:
                table.add_row(prm.name, f"{prm.value:.6g}", prm.interval_text(), prm.unit, escape(prm.note))
            else:
                table.add_row(prm.name, "–", prm.interval_text(4), prm.unit, escape(prm.reason))
        console.print(table)
        console.print(escape(result.verdict))
        if model_choice != "--model":
            console.print(f"model: two-mass ({escape(model_choice)})")
        for w in result.warnings:
            typer.echo(f"drivelash: warning: {w}", err=True)
        if out is None and result.plausible:
            sys.stdout.write(text)
    return summary


#: Working arrays of the streamed observer per chunk row (velocity, acceleration, their
#: context copies, torque, d̂, mask, the output rows): 16 float64 [bytes per row].
OBSERVE_BYTES_PER_CHUNK_ROW = 16 * 8


def _observe_columns(names: list[str], report: bool) -> list[str]:
    """Columns ``observe`` reads: torque, the velocity (else the position), and for the
    report's overview the positions and velocities too."""
    need = ["torque_m", "omega_m" if "omega_m" in names else "theta_m"]
    if report:
        need += [c for c in ("theta_m", "theta_l", "omega_m", "omega_l") if c in names]
    return list(dict.fromkeys(c for c in need if c in names))


def observe_recording(
    stream: Any,
    *,
    J: float,
    beta: float | None,
    est: Any,
    opts: Any,
    out_path: Path | None = None,
    report: bool = False,
    spill_dir: Path | None = None,
    source: str = "",
) -> tuple[Any, Any]:
    """The disturbance observer over a :class:`~drivelash.io.stream.TraceStream`, in bounded
    memory (:func:`drivelash.estimation.identify.observe_stream`).

    ``out_path``: write t, velocity, disturbance there (a staging path), chunk by chunk.
    ``report``: also return the recording's columns thinned as the report draws them.

    Returns
    -------
    (DisturbanceEstimate, Trace or None)
        The estimate keeps every k-th sample (k = samples // the report's point budget) when
        ``report``, else no series; the thinned recording for the report.
    """
    from drivelash.estimation.identify import observe_stream
    from drivelash.io import Trace
    from drivelash.io.formats import TraceWriter
    from drivelash.io.spill import Spill

    n = stream.n_samples
    keep = _report_keep(n) if report else None
    chunks, kept = _thinned_chunks(stream, keep, _observe_columns(stream.names, report))
    out_rows = Spill(n, 3, spill_dir) if out_path is not None else None
    row = [0]

    def sink(t: np.ndarray, v: np.ndarray, d: np.ndarray) -> None:
        assert out_rows is not None
        out_rows.write(row[0], np.column_stack([t, v, d]))
        row[0] += len(t)

    try:
        res = observe_stream(
            chunks,
            n,
            stream.T_s,
            list(stream.names),
            J=J,
            beta=beta or 0.0,
            k1=est.k1 if est else None,
            k2=est.k2 if est else None,
            cutoff_hz=opts.cutoff_hz,
            filter_order=opts.filter_order,
            keep=keep,
            sink=sink if out_rows is not None else None,
            spill_dir=spill_dir,
            back_rows=stream.chunk_rows,
        )
        if out_rows is not None and out_path is not None:
            names = ["t", "velocity", "disturbance"]
            with TraceWriter(out_path, names, n, {"source": source, "observer": res.as_dict()}) as w:
                for a in range(0, n, stream.chunk_rows):
                    block = out_rows.read(a, a + stream.chunk_rows)
                    w.write({c: np.ascontiguousarray(block[:, j]) for j, c in enumerate(names)})
    finally:
        if out_rows is not None:
            out_rows.close()
    thin = Trace({c: np.concatenate(v) for c, v in kept.items()}, meta=stream.meta) if report else None
    return res, thin


#: Values of the two-mass keys a rigid ``[drivetrain]`` (J_m, beta_m, T_Cm) leaves out, used only
#: to run the DrivetrainParams field checks on the keys it has (``observe``).
_RIGID_PLACEHOLDERS = {"J_l": 1.0, "N": 1.0, "K_S": 1.0, "D_S": 0.0}


def run_observe(
    trace_path: Path,
    config_path: Path,
    *,
    drivetrain: Path | None = None,
    json_out: Path | None = None,
    report: Path | None = None,
    out: Path | None = None,
    resample: bool = False,
    quiet: bool = False,
    force: bool = False,
) -> dict[str, Any]:
    """Body of ``drivelash observe`` (returns the JSON summary).

    The recording is read in chunks (:class:`~drivelash.io.stream.TraceStream`,
    ``DRIVELASH_CHUNK_ROWS``) and the observer runs in bounded memory
    (:func:`observe_recording`); the outputs equal those of
    :func:`~drivelash.estimation.identify.observe_disturbance` on the whole recording bit for bit.
    """
    from drivelash.errors import ConfigError
    from drivelash.io import load_config
    from drivelash.io.outputs import HTML_EXTENSIONS, JSON_EXTENSIONS, TRACE_EXTENSIONS, Outputs, write_json
    from drivelash.io.spill import spill_directory

    outputs = Outputs("observe", inputs=[trace_path, config_path, drivetrain], force=force)
    out_t = outputs.file(out, option="--out", kinds=TRACE_EXTENSIONS)
    json_t = outputs.file(json_out, option="--json", kinds=JSON_EXTENSIONS)
    report_t = outputs.file(report, option="--report", kinds=HTML_EXTENSIONS)
    cfg = load_config(config_path)
    dt_sec = cfg.drivetrain
    t_off = cfg.identification_or_default().torque_offset
    if drivetrain is not None:
        extra = load_config(drivetrain)
        dt_sec = extra.require("drivetrain")
        if extra.identification is not None and extra.identification.torque_offset is not None:
            t_off = extra.identification.torque_offset  # written by `identify --model rigid`
    if dt_sec is None or dt_sec.J_m is None:
        raise ConfigError(
            f"{drivetrain or config_path}: table [drivetrain], key 'J_m': missing"
            " (run `drivelash identify … --out FRAGMENT.toml` and pass --drivetrain FRAGMENT.toml)"
        )
    # the same field checks as `estimate` (finite, J_m > 0, beta_m >= 0, …); the two-mass keys a
    # rigid table leaves out are filled with neutral values for the check only
    dt_sec.to_params(
        f"{drivetrain or config_path}: table [drivetrain]",
        **{k: _RIGID_PLACEHOLDERS.get(k, 1.0) for k in dt_sec.missing()},
    )
    opts = cfg.identification_or_default()
    with outputs, _open_stream(trace_path, cfg, ["torque_m"], resample, "observing") as stream:
        print_warnings(stream.meta)
        res, thin = observe_recording(
            stream,
            J=dt_sec.J_m,
            beta=dt_sec.beta_m,
            est=cfg.estimator,
            opts=opts,
            out_path=outputs.staging(out_t) if out_t is not None else None,
            report=report_t is not None,
            spill_dir=spill_directory(out_t, json_t, report_t),
            source=str(trace_path),
        )
        summary: dict[str, Any] = {"trace": str(trace_path), **res.as_dict()}
        if dt_sec.T_Cm:
            summary["coulomb_friction"] = dt_sec.T_Cm
        if t_off is not None:
            summary["torque_offset"] = t_off
        if report_t is not None and thin is not None:
            from drivelash.report import render_observe_report

            t_c = dt_sec.T_Cm or 0.0
            c0 = t_off or 0.0
            expected = (lambda v: t_c * np.sign(v) + c0) if t_c > 0 else None
            label = (
                "T_Cm sign q̇ + torque_offset ([drivetrain], [identification])"
                if t_off is not None
                else "T_Cm sign q̇ ([drivetrain]; no torque_offset given)"
            )
            html = render_observe_report(thin, res, cfg, expected=expected, expected_label=label)
            outputs.staging(report_t).write_text(html, encoding="utf-8")
        if json_t is not None:
            write_json(outputs.staging(json_t), summary)
        axis = stream.meta.get("axis")
    for w in res.warnings:
        typer.echo(f"drivelash: warning: {w}", err=True)
    if not quiet:
        unit = "N" if axis == "prismatic" else "N·m"
        typer.echo(f"mean disturbance, forward constant-velocity stretches:  {res.mean_positive:.4g} {unit}")
        typer.echo(f"mean disturbance, backward constant-velocity stretches: {res.mean_negative:.4g} {unit}")
    return summary


def register(app: typer.Typer, te_app: typer.Typer) -> None:
    """Add ``identify`` and ``observe`` to the CLI."""

    @app.command()
    def identify(
        trace: Path = typer.Argument(..., help="Recording: .csv, .parquet, .h5, .mat"),
        config: Path = typer.Option(
            ..., "--config", "-c", help="TOML configuration: columns, sampling, identification tables."
        ),
        json_out: Path | None = typer.Option(None, "--json", help=OUT_HELP),
        report: Path | None = typer.Option(None, "--report", help="Write a self-contained HTML report here."),
        out: Path | None = typer.Option(
            None, "--out", "-o", help="Write the drivetrain TOML fragment here (default: stdout)."
        ),
        cross: Path | None = typer.Option(None, "--cross", help="Validation recording for a cross-test."),
        resample: bool = typer.Option(
            False, "--resample", help="Resample non-uniform time onto a uniform grid."
        ),
        model: str | None = typer.Option(
            None,
            "--model",
            help="rigid (IDIM-LS: inertia, friction) or two-mass (J_m, J_l, K_S, D_S, friction, "
            "delta, delta1 with 95 % intervals); default: [identification] model, else two-mass when "
            "theta_l is recorded and N given, rigid otherwise.",
        ),
        force: bool = typer.Option(False, "--force", help=FORCE_HELP),
    ) -> None:
        """Identify a drive (rigid IDIM-LS or two-mass with backlash); write [drivetrain]/[backlash] TOML.

        A physically impossible fit (negative inertia, stiffness or friction) exits with code 2
        and writes no drive table; --json/--report still get the diagnosis.
        """
        summary = run_identify(
            trace,
            config,
            json_out=json_out,
            report=report,
            out=out,
            cross=cross,
            resample=resample,
            model=model,
            force=force,
        )
        if summary.get("plausible") is False:  # two-mass diagnosis only (--json/--report): exit 2 too
            from drivelash.errors import DataError

            written = " and ".join(str(o) for o in (json_out, report) if o is not None)
            raise DataError(
                f"implausible identification, no drive table written (the diagnosis is in {written}): "
                f"{summary['warnings'][0]}",
                path=str(trace),
            )

    @app.command()
    def observe(
        trace: Path = typer.Argument(..., help="Recording: .csv, .parquet, .h5, .mat"),
        config: Path = typer.Option(..., "--config", "-c", help="TOML configuration."),
        drivetrain: Path | None = typer.Option(
            None,
            "--drivetrain",
            help="TOML with a drivetrain table: J_m, beta_m (e.g. from `identify --out`).",
        ),
        json_out: Path | None = typer.Option(None, "--json", help=OUT_HELP),
        report: Path | None = typer.Option(None, "--report", help="Write a self-contained HTML report here."),
        out: Path | None = typer.Option(
            None, "--out", "-o", help="Write t, velocity, disturbance to a file."
        ),
        resample: bool = typer.Option(
            False, "--resample", help="Resample non-uniform time onto a uniform grid."
        ),
        force: bool = typer.Option(False, "--force", help=FORCE_HELP),
    ) -> None:
        """Estimate the disturbance torque/force of an axis with the super-twisting observer."""
        run_observe(
            trace,
            config,
            drivetrain=drivetrain,
            json_out=json_out,
            report=report,
            out=out,
            resample=resample,
            force=force,
        )
