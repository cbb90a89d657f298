"""``drivelash te validate`` and ``drivelash te export``: compensation of the learned TE.

Heavy imports (numba kernels, the simulator, matplotlib) happen inside the commands.
"""

from __future__ import annotations

import json
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
            None, "--campaign", help="Campaign of the drive; default: the one recorded in the model."
        ),
        quick: bool = typer.Option(False, "--quick", help="Reduced protocol: 3 loads, one direction, 0.6 m."),
        no_update: bool = typer.Option(
            False, "--no-update", help="Skip the update(stage='trees') retraining."
        ),
    ) -> None:
        """Validate the compensation on the virtual bench (paper Figs 8-9, monitoring) and write DIR."""
        from drivelash.te.protocol.bench import ValidationConfig, drive_for_model
        from drivelash.te.protocol.validate import validate
        from drivelash.te.protocol.wear_demo import TreesUpdater
        from drivelash.te.runtime.persist import load_model

        model = load_model(model_dir)
        camp = drive_for_model(model, campaign)
        cfg = ValidationConfig.quick() if quick else ValidationConfig()
        upd = None if no_update else TreesUpdater(echo=typer.echo)
        from drivelash.report import te_figures

        summary = validate(model, camp, out, cfg, updater=upd, progress=typer.echo, figures=te_figures)
        typer.echo(format_summary(summary))
        typer.echo(f"outputs in {out}/")

    @te_app.command("export")
    def export_cmd(
        model_dir: Path = typer.Argument(..., help="Model directory (drivelash te fit)."),
        out: Path = typer.Option(..., "-o", "--out", help="Table file, .csv or .json."),
        dx_mm: float = typer.Option(0.2, "--dx-mm", help="Position step of the table [mm]."),
        torque_max: float | None = typer.Option(
            None, "--torque-max", help="Largest motor torque of the grid [N·m]; default: the training range."
        ),
        torque_step: float = typer.Option(
            0.5, "--torque-step", min=1e-3, help="Torque step of the grid [N·m]."
        ),
        x_min: float | None = typer.Option(None, "--x-min", help="First position [m]; default 0."),
        x_max: float | None = typer.Option(None, "--x-max", help="Last position [m]; default: the travel."),
    ) -> None:
        """Sample the model on a position x torque grid per direction and write it for a CNC."""
        from drivelash.te.runtime.compensator import CompensatorParams
        from drivelash.te.runtime.export import export_table
        from drivelash.te.runtime.persist import load_model
        from drivelash.te.runtime.table import build_table

        model = load_model(model_dir)
        lo = 0.0 if x_min is None else x_min
        hi = x_max if x_max is not None else _travel(model)
        tmax = torque_max if torque_max is not None else _training_torque(model)
        n_torque = int(math.ceil(tmax / torque_step - 1e-9)) + 1
        table = build_table(model, lo, hi, dx_mm * 1e-3, tmax, n_torque,
                            meta={"model_dir": str(model_dir)})  # fmt: skip
        export_table(table, out, _params_for(model, CompensatorParams()))
        n = table.te.shape
        typer.echo(f"wrote {out}: {n[1]} positions x {n[2]} torques x 2 directions "
                   f"(x_T in mm, torque in N*m, TE in um)")  # fmt: skip


def _travel(model: object) -> float:
    """Travel [m] of the drive the model was trained on (from its campaign), else 2.2 m."""
    info = getattr(model, "info", {}) or {}
    cand = info.get("campaign")
    if cand and (Path(cand) / "manifest.json").is_file():
        man = json.loads((Path(cand) / "manifest.json").read_text())
        return float(man["bench"]["travel"])
    return 2.2


def _params_for(model: object, default: object) -> object:
    """Compensator settings with the drive's friction/inertia if the model's campaign is at hand."""
    info = getattr(model, "info", {}) or {}
    cand = info.get("campaign")
    if not cand or not (Path(cand) / "manifest.json").is_file():
        return default
    from drivelash.te.protocol.bench import compensator_for
    from drivelash.te.protocol.campaign import load_campaign

    return compensator_for(load_campaign(cand).bench, None, default)


def _training_torque(model: object) -> float:
    """Largest training motor torque [N·m] from the model's campaign (see ``training_torque_max``)."""
    from drivelash.errors import DataError
    from drivelash.te.protocol.bench import training_torque_max
    from drivelash.te.protocol.campaign import load_campaign

    info = getattr(model, "info", {}) or {}
    cand = info.get("campaign")
    if not cand or not (Path(cand) / "manifest.json").is_file():
        raise DataError(
            "the model's campaign is not available to find the training torque; pass --torque-max"
        )
    return training_torque_max(load_campaign(cand), float(info.get("max_load", 3000.0)))


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
