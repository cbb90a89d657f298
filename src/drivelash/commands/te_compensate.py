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
        out: Path = typer.Option(..., "-o", "--out", help="Table file, .csv or .json."),
        dx_mm: float = typer.Option(0.2, "--dx-mm", help="Position step of the table [mm]."),
        torque_max: float | None = typer.Option(
            None, "--torque-max", help="Largest motor torque of the grid [N·m]; default: the training range."
        ),
        torque_step: float = typer.Option(0.5, "--torque-step", help="Torque step of the grid [N·m]."),
        x_min: float | None = typer.Option(
            None, "--x-min", help="First position [m]; default: the start of the valid range."
        ),
        x_max: float | None = typer.Option(
            None, "--x-max", help="Last position [m]; default: the end of the valid range."
        ),
        force: bool = typer.Option(
            False, "--force", help="Replace OUT even if it is not a drivelash output."
        ),
    ) -> None:
        """Sample the model on a position x torque grid per direction and write it for a CNC."""
        from drivelash.io.outputs import Outputs
        from drivelash.te.runtime.export import export_table
        from drivelash.te.runtime.persist import load_model
        from drivelash.te.runtime.table import build_table

        with Outputs("te export", inputs=[model_dir], force=force) as outs:
            target = outs.file(out, option="-o", kinds=(".csv", ".json"))
            model = load_model(model_dir)
            ctx = model.context
            vr = ctx.valid_range
            lo = vr.x_min if x_min is None else x_min
            hi = vr.x_max if x_max is None else x_max
            tmax = vr.torque_max if torque_max is None else torque_max
            n_torque = _check_grid(lo, hi, dx_mm, tmax, torque_step, vr)
            table = build_table(model, lo, hi, dx_mm * 1e-3, tmax, n_torque,
                                meta={"model_dir": str(model_dir)})  # fmt: skip
            export_table(table, outs.staging(target), ctx.compensator)
        n = table.te.shape
        typer.echo(f"wrote {out}: {n[1]} positions x {n[2]} torques x 2 directions "
                   f"(x_T in mm, torque in N*m, TE in um)")  # fmt: skip


#: Largest table `te export` writes [grid points per flank]: 10 M (e.g. 0.1 mm over 10 m × 100
#: torques); a CNC compensation table holds thousands, the default grid ≈ 0.2 M.
MAX_TABLE_POINTS = 10_000_000


def _check_grid(lo: float, hi: float, dx_mm: float, tmax: float, step: float, vr: object) -> int:
    """Validate the export grid up front; returns the torque count (refuses absurd sizes)."""
    from drivelash.errors import ParameterError, ResourceError
    from drivelash.io.budget import check_budget
    from drivelash.te.runtime.table import table_bytes

    for name, v in (("--dx-mm", dx_mm), ("--torque-step", step), ("--torque-max", tmax)):
        if not (math.isfinite(v) and v > 0):
            raise ParameterError("te export", name.lstrip("-"), f"must be a finite number > 0, got {v!r}")
    for name, v in (("--x-min", lo), ("--x-max", hi)):
        if not math.isfinite(v):
            raise ParameterError("te export", name.lstrip("-"), f"must be finite, got {v!r}")
    if not vr.contains(lo, hi):  # type: ignore[attr-defined]
        raise ParameterError(
            "te export",
            "x-min" if lo < vr.x_min else "x-max",  # type: ignore[attr-defined]
            f"[{lo:.6g}, {hi:.6g}] m leaves the model's valid range [{vr.x_min:.6g}, {vr.x_max:.6g}] m",  # type: ignore[attr-defined]
        )
    if not hi > lo:
        raise ParameterError("te export", "x-max", f"must exceed x-min ({lo:g} m), got {hi:g}")
    n_x = (hi - lo) / (dx_mm * 1e-3) + 1
    n_torque = math.ceil(tmax / step - 1e-9) + 1
    what = f"te export: {n_x:.4g} positions x {n_torque:.4g} torques x 2 flanks"
    option = "raise --dx-mm or --torque-step, or lower --torque-max"
    if n_x * n_torque > MAX_TABLE_POINTS:  # no CNC loads more; checked before any size is allocated
        raise ResourceError(
            f"{what} = {2 * n_x * n_torque:.4g} values, more than {2 * MAX_TABLE_POINTS:.4g}"
            f" (≈ {table_bytes(int(n_x), int(n_torque)) / 2**30:.3g} GiB to build); {option}"
        )
    # the table in memory, and the CSV text (~40 bytes per row, 2 flanks) written from it
    check_budget(table_bytes(int(n_x), int(n_torque)) + 40.0 * 2 * n_x * n_torque, what=what, option=option)
    return int(n_torque)


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
