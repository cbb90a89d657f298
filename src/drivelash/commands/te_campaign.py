"""``drivelash te campaign``: record the measurement campaign on the virtual bench (spec 02)."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer, te_app: typer.Typer) -> None:
    """Add ``te campaign`` to the CLI."""

    @te_app.command("campaign")
    def campaign(
        out: Path = typer.Option(..., "-o", "--out", help="Output directory (created)."),
        seed: int = typer.Option(0, "--seed", help="Seed of the simulated drive (TE generator)."),
        quick: bool = typer.Option(False, "--quick", help="Reduced campaign: 0.4 m stroke, 3 loads."),
        workers: int = typer.Option(2, "--workers", min=1, help="Parallel simulation threads."),
        plot: bool = typer.Option(True, "--plot/--no-plot", help="Write fig2_te.png and a Bode plot."),
    ) -> None:
        """Simulate the campaign (geometric, load and sine runs) and write traces + manifest.json."""
        from drivelash.report.te_figures import plot_te_over_position
        from drivelash.sim.rack_campaign import CampaignConfig, run_campaign
        from drivelash.te.protocol.campaign import load_campaign

        cfg = CampaignConfig.quick() if quick else CampaignConfig()
        m = run_campaign(out, seed=seed, config=cfg, workers=workers)
        tm = m["timing"]
        typer.echo(
            f"{len(m['runs'])} runs, {tm['simulated_s']:.0f} s simulated in {tm['wall_s']:.1f} s "
            f"(real-time factor {tm['real_time_factor']:.0f}) -> {out}/manifest.json"
        )
        if plot:
            png = plot_te_over_position(load_campaign(out), out / "fig2_te.png")
            from drivelash.report.te_figures import bode_figure

            camp = load_campaign(out)
            fig = bode_figure(camp.bench.J_s, camp.gains)
            fig.savefig(out / "bode_path_error.png", dpi=110)
            typer.echo(f"TE over position -> {png}; Bode plot of (2)-(3) -> {out / 'bode_path_error.png'}")
