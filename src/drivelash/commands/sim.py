"""``drivelash scenarios`` and ``drivelash simulate``."""

from __future__ import annotations

from pathlib import Path

import typer

from drivelash.errors import ParameterError


def register(app: typer.Typer, te_app: typer.Typer) -> None:
    """Add ``scenarios`` and ``simulate`` to the CLI."""

    @app.command()
    def scenarios() -> None:
        """List the built-in simulation scenarios with one-line descriptions."""
        from rich.console import Console
        from rich.table import Table

        from drivelash.sim.scenarios import list_scenarios

        table = Table("name", "duration [s]", "description", box=None)
        for sc in list_scenarios():
            table.add_row(sc.name, f"{sc.duration:g}", sc.description)
        Console().print(table)

    @app.command()
    def simulate(
        scenario: str = typer.Argument(
            ..., help="Scenario name (see `drivelash scenarios`), CONFIG.toml, or 'fleet'."
        ),
        out: Path = typer.Option(
            ..., "-o", "--out", help="Output trace (.parquet or .csv); a directory for 'fleet'."
        ),
        duration: float | None = typer.Option(
            None, "--duration", help="Simulated time [s] (per recording for 'fleet')."
        ),
        seed: int | None = typer.Option(None, "--seed", help="Noise seed."),
        machines: int = typer.Option(3, "--machines", help="'fleet': machines."),
        axes: int = typer.Option(2, "--axes", help="'fleet': axes per machine."),
        recordings: int = typer.Option(30, "--recordings", help="'fleet': recordings per axis (one a day)."),
        workers: int = typer.Option(1, "--workers", help="'fleet': processes simulating recordings."),
    ) -> None:
        """Simulate a scenario and write its trace (measured signals + true deadzone).

        ``simulate fleet -o DIR`` writes a simulated fleet for the wear tracker instead:
        recordings, drive configs, fleet.toml and truth.json (see ``drivelash track``).
        """
        if scenario == "fleet":
            from drivelash.commands.track import run_simulate_fleet
            from drivelash.sim.fleet import RECORDING_SECONDS

            run_simulate_fleet(
                out,
                machines,
                axes,
                recordings,
                0 if seed is None else seed,
                RECORDING_SECONDS if duration is None else duration,
                workers,
            )
            return
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

        from drivelash.sim.scenarios import load_scenario

        if out.suffix.lower() not in (".parquet", ".pq", ".csv"):
            raise ParameterError(
                "simulate", "out", f"unsupported extension {out.suffix!r} (.parquet or .csv)"
            )
        sc = load_scenario(scenario)
        T = sc.duration if duration is None else duration
        if not T > 0:
            raise ParameterError("simulate", "duration", f"must be > 0, got {T!r}")
        console = Console(stderr=True)
        if T >= 30.0:
            with Progress(
                TextColumn(f"simulating {sc.name}"),
                BarColumn(),
                TextColumn("{task.percentage:>3.0f}%"),
                TimeRemainingColumn(),
                console=console,
                transient=True,
            ) as bar:
                task = bar.add_task("sim", total=1.0)
                trace = sc.simulate(
                    duration=T,
                    seed=seed,
                    progress=lambda done, total: bar.update(task, completed=done / total),
                )
        else:
            trace = sc.simulate(duration=T, seed=seed)
        out.parent.mkdir(parents=True, exist_ok=True)
        trace.save(out)
        typer.echo(f"{sc.name}: {len(trace)} samples ({trace.duration + sc.T_s:g} s) -> {out}")
