"""``drivelash te campaign``: record the measurement campaign on the virtual bench (spec 02)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import typer

if TYPE_CHECKING:
    from drivelash.sim.rack_campaign import CampaignConfig, RunSpec
    from drivelash.te.protocol.axis import RunTable


def register(app: typer.Typer, te_app: typer.Typer) -> None:
    """Add ``te campaign`` and ``te import`` to the CLI."""
    _import(app, te_app)

    @te_app.command("campaign")
    def campaign(
        out: Path = typer.Option(..., "-o", "--out", help="Output directory (written as a whole)."),
        config: Path | None = typer.Option(
            None,
            "--config",
            help="Axis file (TOML): [geometry], [drive], [gains], [campaign], [te_generator] and an"
            " optional [[runs]] list to record instead of the planned protocol.",
        ),
        seed: int = typer.Option(0, "--seed", min=0, max=2**63 - 1, help="Seed of the simulated drive."),
        quick: bool = typer.Option(False, "--quick", help="Reduced campaign: 0.4 m stroke, 3 loads."),
        workers: int = typer.Option(2, "--workers", min=1, max=64, help="Parallel simulation threads."),
        plot: bool = typer.Option(True, "--plot/--no-plot", help="Write fig2_te.png and a Bode plot."),
        force: bool = typer.Option(
            False, "--force", help="Replace OUT even if it is not a drivelash output."
        ),
    ) -> None:
        """Simulate the campaign (geometric, load and sine runs) and write traces + manifest.json."""
        from drivelash.io.outputs import Outputs
        from drivelash.sim.rack_campaign import CampaignConfig, run_campaign

        with Outputs("te campaign", inputs=[config], force=force) as outs:
            d = outs.directory(out, option="-o")
            base = CampaignConfig.quick() if quick else CampaignConfig()
            kw: dict = {}
            if config is not None:
                from drivelash.te.protocol.axis import load_axis

                axis = load_axis(config)
                bench = axis.bench()
                kw = {
                    "bench": bench,
                    "gains": axis.cascade_gains(bench),
                    "te_params": axis.generator(),
                }
                base = axis.params("campaign", base=base)
                if axis.runs:
                    kw["runs"] = [_spec(r, base, axis.source, i) for i, r in enumerate(axis.runs)]
            stage = outs.staging(d)
            m = run_campaign(stage, seed=seed, config=base, workers=workers, **kw)
            if plot:
                from drivelash.report.save import save_figure
                from drivelash.report.te_figures import bode_figure, plot_te_over_position
                from drivelash.te.protocol.campaign import load_campaign

                camp = load_campaign(stage)
                plot_te_over_position(camp, stage / "fig2_te.png")
                fig = bode_figure(camp.bench.J_s, camp.gains)
                save_figure(fig, stage / "bode_path_error.png")
        tm = m["timing"]
        typer.echo(
            f"{len(m['runs'])} runs, {tm['simulated_s']:.0f} s simulated in {tm['wall_s']:.1f} s "
            f"(real-time factor {tm['real_time_factor']:.0f}) -> {out}/manifest.json"
        )
        if plot:
            typer.echo(
                f"TE over position -> {out}/fig2_te.png; Bode plot of (2)-(3) -> {out}/bode_path_error.png"
            )


def _import(app: typer.Typer, te_app: typer.Typer) -> None:
    @te_app.command("import")
    def import_cmd(
        axis_file: Path = typer.Argument(
            ..., help="Axis file (TOML) with [geometry], [columns] and [[runs]]."
        ),
        out: Path = typer.Option(..., "-o", "--out", help="Campaign directory to write (as a whole)."),
        max_load: float = typer.Option(
            3000.0, "--max-load", help="Largest training load [N] (for the count of training loads)."
        ),
        force: bool = typer.Option(
            False, "--force", help="Replace OUT even if it is not a drivelash output."
        ),
        for_score: bool = typer.Option(
            False,
            "--for-score",
            help="Passes to score (te score), not to fit: no geometric run and a single load are warned.",
        ),
    ) -> None:
        """Bring real recordings into a campaign directory, after a plausibility check."""
        from drivelash.io.outputs import Outputs
        from drivelash.te.protocol.importer import import_campaign, recording_paths, summary_lines

        recs = recording_paths(axis_file)
        with Outputs("te import", inputs=[axis_file, *recs], force=force) as outs:
            d = outs.directory(out, option="-o")
            manifest, report = import_campaign(
                axis_file, outs.staging(d), max_load, warn=_warn, for_score=for_score
            )
        for line in summary_lines(manifest, report):
            typer.echo(line)
        typer.echo(f"-> {out}/manifest.json")


def _warn(line: str) -> None:
    typer.echo(f"drivelash: warning: {line}", err=True)


def _spec(r: RunTable, cfg: CampaignConfig, source: str, i: int) -> RunSpec:
    """A run of the axis file as a run of the virtual bench (a sine runs the campaign's sine)."""
    import math

    from drivelash.errors import ConfigError
    from drivelash.sim.rack_campaign import RunSpec

    v = r.velocity
    if r.kind == "sine":
        v = 2 * math.pi * cfg.sine_frequency * cfg.sine_amplitude
    elif v is None:
        raise ConfigError(f"{source}: table [[runs]] #{i + 1}, key 'velocity': missing (the bench needs it)")
    return RunSpec(r.kind, float(r.load), float(v), int(r.direction))
