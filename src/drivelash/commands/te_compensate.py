"""``drivelash te validate`` and ``drivelash te export``: compensation of the learned TE.

Both read everything from the model directory (axis, valid range, compensator settings,
the virtual drive of a simulated campaign); nothing is read back from the campaign.
Heavy imports (numba kernels, the simulator, the report figures) happen inside the commands.
"""

from __future__ import annotations

import math
from pathlib import Path

import typer


def register(app: typer.Typer, te_app: typer.Typer) -> None:
    """Add ``te validate`` and ``te export`` to the CLI."""

    @te_app.command("validate")
    def validate_cmd(
        model_dir: Path = typer.Argument(..., help="Model directory (drivelash te fit)."),
        out: Path = typer.Option(
            ..., "-o", "--out", help="Output directory (figures, tables, summary.json)."
        ),
        campaign: Path | None = typer.Option(
            None,
            "--campaign",
            help="The model's training campaign, if at hand (else it is regenerated from the model).",
        ),
        quick: bool = typer.Option(
            False, "--quick", help="Reduced protocol: 3 loads, one direction, at most 0.6 m."
        ),
        no_update: bool = typer.Option(
            False, "--no-update", help="Skip the update(stage='trees') retraining."
        ),
        force: bool = typer.Option(
            False, "--force", help="Replace OUT even if it is not a drivelash output."
        ),
    ) -> None:
        """Validate the compensation on the virtual bench (paper Figs 8-9, monitoring) and write OUT."""
        from drivelash.io.outputs import Outputs
        from drivelash.te.protocol.bench import ValidationConfig, drive_for_model
        from drivelash.te.runtime.persist import load_model

        with Outputs("te validate", inputs=[model_dir, campaign], force=force) as outs:
            d = outs.directory(out, option="-o")
            model = load_model(model_dir)
            drive = drive_for_model(model, campaign)

            from drivelash.report import te_figures
            from drivelash.te.protocol.validate import validate
            from drivelash.te.protocol.wear_demo import TreesUpdater

            cfg = ValidationConfig.quick() if quick else ValidationConfig()
            upd = None if no_update else TreesUpdater(echo=typer.echo)
            summary = validate(
                model, drive, outs.staging(d), cfg, updater=upd, progress=typer.echo, figures=te_figures
            )
        typer.echo(format_summary(summary))
        if quick:
            typer.echo(quick_verdict(summary))
        typer.echo(f"outputs in {out}/")

    @te_app.command("export")
    def export_cmd(
        model_dir: Path = typer.Argument(..., help="Model directory (drivelash te fit)."),
        out: Path = typer.Option(
            ...,
            "-o",
            "--out",
            help="Output file: .csv or .json (runtime table), .ini (SINUMERIK), .com (HEIDENHAIN).",
        ),
        fmt: str | None = typer.Option(
            None,
            "--format",
            help="table (position x torque, .csv/.json), sinumerik (.ini: $AA_ENC_COMP + direction CEC"
            " tables) or heidenhain (.com: AXISPOS, axis, BACKLASH); the extension of --out decides, and"
            " --format, when given, must agree with it.",
        ),
        dx_mm: float | None = typer.Option(
            None,
            "--dx-mm",
            help="Position step of the table in mm (millimetres; table format; default 0.2 mm).",
        ),
        torque_max: float | None = typer.Option(
            None,
            "--torque-max",
            help="Largest motor torque of the grid in N·m, at most the training range (the default).",
        ),
        torque_step: float | None = typer.Option(
            None,
            "--torque-step",
            help="Torque step of the grid in N·m (table format; default 0.5 N·m).",
        ),
        step_mm: float | None = typer.Option(
            None,
            "--step-mm",
            help=f"Distance of the CNC compensation points in mm (millimetres; default {CNC_STEP_MM:g} mm).",
        ),
        axis: str | None = typer.Option(
            None, "--axis", help="Machine axis name (sinumerik, default X1) or axis key (heidenhain, X)."
        ),
        cec_tables: str | None = typer.Option(
            None,
            "--cec-tables",
            help="SINUMERIK CEC table indices of the positive and negative direction (default 0,1).",
        ),
        x_min: float | None = typer.Option(
            None,
            "--x-min",
            help="First position in m (metres, not mm: 0.1 is 100 mm); default: the valid range's start.",
        ),
        x_max: float | None = typer.Option(
            None,
            "--x-max",
            help="Last position in m (metres, not mm: 2.1 is 2100 mm); default: where the valid range ends.",
        ),
        force: bool = typer.Option(
            False, "--force", help="Replace OUT even if it is not a drivelash output."
        ),
    ) -> None:
        """Write the model for a CNC: the runtime table (position x torque per direction, .csv/.json)
        or the no-load error per direction in a SINUMERIK (.ini) or HEIDENHAIN (.com) layout."""
        from drivelash.errors import ParameterError
        from drivelash.io.outputs import Outputs
        from drivelash.te.runtime.persist import load_model

        layout = _export_layout(fmt, out)
        cnc = layout != "table"
        table_opts = (("--dx-mm", dx_mm), ("--torque-max", torque_max), ("--torque-step", torque_step))
        cnc_opts = (("--step-mm", step_mm), ("--axis", axis), ("--cec-tables", cec_tables))
        for name, v in table_opts if cnc else cnc_opts:
            if v is not None:
                hint = "the compensation points' distance is --step-mm" if name == "--dx-mm" else ""
                raise ParameterError(
                    "te export", name, f"does not apply to --format {layout}" + (f" ({hint})" if hint else "")
                )
        if layout == "heidenhain" and cec_tables is not None:
            raise ParameterError("te export", "--cec-tables", "applies to --format sinumerik only")
        with Outputs("te export", inputs=[model_dir], force=force) as outs:
            target = outs.file(out, option="-o", kinds=EXPORT_KINDS[layout])
            model = load_model(model_dir)
            if cnc:
                from drivelash.te.runtime.cnc import geometric_table, write_cnc

                step = CNC_STEP_MM if step_mm is None else step_mm
                tables = _parse_cec(cec_tables)
                tab = geometric_table(model, step * 1e-3, x_min, x_max, source=str(model_dir))
                write_cnc(tab, outs.staging(target), layout, axis, tables)
            else:
                table = _export_table(model, model_dir, outs.staging(target), x_min, x_max,
                                      0.2 if dx_mm is None else dx_mm, torque_max,
                                      0.5 if torque_step is None else torque_step)  # fmt: skip
        if cnc:
            typer.echo(
                f"wrote {out}: {layout} compensation table, {tab.te_pos.size} points"
                f" {tab.x0 * 1e3:.3f} ... {tab.x_max * 1e3:.3f} mm, step {tab.step * 1e3:g} mm, both"
                " directions"
                f" (no-load TE; valid range {tab.valid[0] * 1e3:.3f} ... {tab.valid[1] * 1e3:.3f} mm;"
                f" interpolation <= {tab.interpolation_error * 1e6:.3f} um; constant part"
                f" {tab.constant * 1e6:+.3f} um; backlash {tab.backlash_range[0] * 1e6:.3f} ..."
                f" {tab.backlash_range[1] * 1e6:.3f} um in the tables: the control's backlash"
                " compensation must be 0)" + (f"; {tab.update_note}" if tab.update_note else "")
            )
            return
        n = table.te.shape
        typer.echo(f"wrote {out}: {n[1]} positions x {n[2]} torques x 2 directions "
                   f"(x_T in mm, torque in N*m, TE in um)")  # fmt: skip


#: Default distance of the CNC compensation points [mm]: linear interpolation of a meshing error
#: of amplitude A and tooth pitch p between points h apart loses at most A·(πh/p)²/2 — 0.3 % of A
#: for h = 1 mm, p = 9.4 mm (m_n 3 mm) — and ~400 points per metre fit any control's table.
CNC_STEP_MM = 1.0
#: Output extensions per layout of `te export`.
EXPORT_KINDS = {"table": (".csv", ".json"), "sinumerik": (".ini",), "heidenhain": (".com",)}


def _export_layout(fmt: str | None, out: Path) -> str:
    """The layout from ``--format`` or, without it, from the output's extension."""
    from drivelash.errors import ParameterError

    ext = Path(out).suffix.lower()
    by_ext = next((k for k, kinds in EXPORT_KINDS.items() if ext in kinds), None)
    if fmt is None:
        if by_ext is None:
            shown = f"'{Path(out).suffix}'" if Path(out).suffix else "(none)"
            raise ParameterError(
                "te export",
                "-o",
                f"unsupported extension {shown} (use .csv, .json) for the table, .ini for --format sinumerik,"
                " .com for --format heidenhain",
            )
        return by_ext
    layout = fmt.strip().lower()
    if layout not in EXPORT_KINDS:
        raise ParameterError("te export", "--format", f"must be table, sinumerik or heidenhain, got {fmt!r}")
    if by_ext is not None and by_ext != layout:
        raise ParameterError(
            "te export",
            "-o",
            f"extension '{Path(out).suffix}' is the {by_ext} format, not --format {layout}"
            f" (use {', '.join(EXPORT_KINDS[layout])})",
        )
    return layout


def _parse_cec(text: str | None) -> tuple[int, int]:
    from drivelash.errors import ParameterError

    if text is None:
        return (0, 1)
    try:
        vals = tuple(int(v) for v in text.split(","))
    except ValueError:
        vals = ()
    if len(vals) != 2:
        raise ParameterError(
            "te export",
            "--cec-tables",
            f"must be two table indices like 0,1 (positive,negative), got {text!r}",
        )
    return vals  # type: ignore[return-value]


def _export_table(
    model: object,
    model_dir: Path,
    path: Path,
    x_min: float | None,
    x_max: float | None,
    dx_mm: float,
    torque_max: float | None,
    torque_step: float,
) -> object:
    """Build the runtime table over the model's measured range and write it (``te export``, table format)."""
    from drivelash.te.runtime.export import export_table
    from drivelash.te.runtime.table import build_table, check_measured, measured_range

    ctx = model.context  # type: ignore[attr-defined]
    vr = ctx.valid_range
    mlo, mhi = measured_range(model)
    lo = mlo if x_min is None else x_min
    hi = mhi if x_max is None else x_max
    tmax = vr.torque_max if torque_max is None else torque_max
    if math.isfinite(lo) and math.isfinite(hi):  # a value outside names itself and the valid range
        check_measured(lo, hi, (mlo, mhi), names=_export_names())  # type: ignore[arg-type]
    n_torque = _check_grid(lo, hi, dx_mm, tmax, torque_step)
    # build_table refuses positions outside the measured range, torques above the trained range
    # and oversized grids — the same checks for the API — worded with this command's options
    table = build_table(model, lo, hi, dx_mm * 1e-3, tmax, n_torque,
                        meta={"model_dir": str(model_dir)}, names=_export_names())  # type: ignore[arg-type]  # fmt: skip
    export_table(table, path, ctx.compensator)
    return table


def _export_names() -> object:
    """How :func:`~drivelash.te.runtime.table.build_table` words its refusals for `te export`
    (imported when run: the command module stays light)."""
    from drivelash.te.runtime.table import X_UNIT_NOTE, GridNames

    return GridNames(
        owner="te export",
        x_min="--x-min",
        x_max="--x-max",
        x_unit_note=X_UNIT_NOTE,
        torque_max="--torque-max",
        torque_hint="leave --torque-max out or lower it",
        size_hint="raise --dx-mm or --torque-step, or lower --torque-max",
        dx="--dx-mm",
        dx_unit="mm",
        coarse_dx_error=True,
        extra_bytes_per_value=40.0,  # the CSV text (~40 bytes per row) written from the table
    )


def _check_grid(lo: float, hi: float, dx_mm: float, tmax: float, step: float) -> int:
    """Validate the export options up front; returns the torque count. The model-dependent
    refusals (valid positions and torques, the table's size) are :func:`build_table`'s."""
    from drivelash.errors import ParameterError

    for name, v in (("--dx-mm", dx_mm), ("--torque-step", step), ("--torque-max", tmax)):
        if not (math.isfinite(v) and v > 0):
            raise ParameterError("te export", name.lstrip("-"), f"must be a finite number > 0, got {v!r}")
    for name, v in (("--x-min", lo), ("--x-max", hi)):
        if not math.isfinite(v):
            raise ParameterError("te export", name.lstrip("-"), f"must be finite, got {v!r}")
    if not hi > lo:
        raise ParameterError("te export", "x-max", f"must exceed x-min ({lo:g} m), got {hi:g}")
    return int(math.ceil(tmax / step - 1e-9) + 1)


#: Goal of the reduced protocol (issue 12: quick path with defaults): average improvement.
QUICK_GOAL_AVERAGE = 0.60


def quick_verdict(summary: dict) -> str:
    """One line for ``te validate --quick``: the table's limits are the full protocol's; the quick
    run's own goal is ≥ 60 % average improvement with no section made worse."""
    p = summary["passes"]
    met = p["average_improvement"] >= QUICK_GOAL_AVERAGE and p["min_section"] > 0.0
    return (
        "--quick ran the reduced protocol (the quick campaign's stroke, 3 loads); the limits above are"
        f" the full protocol's. Its own goal - average >= {QUICK_GOAL_AVERAGE:.0%} with no section made"
        f" worse - is {'met' if met else 'NOT MET'}: average {p['average_improvement']:.1%},"
        f" worst section {p['min_section']:+.1%}"
    )


def format_summary(summary: dict) -> str:
    """The acceptance figures of a validation summary as a short text table."""
    lines = ["acceptance (value / limit / passed):"]
    for k, v in summary.get("acceptance", {}).items():
        val = v.get("value")
        lim = v.get("limit", "")
        sval = f"{val:.3f}" if isinstance(val, float) else str(val)
        slim = f"{lim:.3f}" if isinstance(lim, float) else str(lim)
        lines.append(f"  {k:36s} {sval:>10s} {slim:>8s}  {'ok' if v.get('passed') else 'NOT MET'}")
    return "\n".join(lines)
