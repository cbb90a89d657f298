"""``drivelash scenarios`` and ``drivelash simulate``."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from drivelash.commands import FORCE_HELP, SEED_MAX
from drivelash.errors import ParameterError

#: Peak memory of ``simulate`` per output sample [bytes]: 160 B measured (bench-0A, 10
#: columns, ``ru_maxrss``), doubled for writing the file (the Arrow table / text copy).
SIM_BYTES_PER_SAMPLE = 400.0
#: Nominal integration rate used to refuse hopeless requests [plant substeps/s]: 10×
#: the measured ≈ 1e6/s, so only requests that certainly exceed the time budget are refused
#: (100× let ``n_sub = 1e8`` over 60 s at 1 kHz through: 6e4 s nominal, 70 days real).
SIM_SUBSTEPS_PER_S = 1e7


def check_simulation_size(name: str, duration: float, T_s: float, n_sub: int) -> int:
    """Refuse a simulation that exceeds the memory or time budget; returns its sample count.

    Parameters
    ----------
    name : str
        Scenario name (for the message).
    duration : float
        Simulated time [s].
    T_s : float
        Sample period [s].
    n_sub : int
        Plant substeps per sample.
    """
    from drivelash.io.budget import check_budget, check_time

    if not (math.isfinite(T_s) and T_s > 0):
        raise ParameterError(name, "T_s", f"must be finite and > 0, got {T_s!r}")
    n = duration / T_s + 1.0
    what = f"simulate {name}: {duration:g} s at T_s = {T_s:g} s ({n:.3g} samples)"
    check_budget(n * SIM_BYTES_PER_SAMPLE, what=what, option="shorten --duration")
    check_time(
        n * max(1, n_sub) / SIM_SUBSTEPS_PER_S,
        what=f"{what} × {n_sub} substeps",
        option="shorten --duration or reduce n_sub",
    )
    return int(n)


def register(app: typer.Typer, te_app: typer.Typer) -> None:
    """Add ``scenarios`` and ``simulate`` to the CLI."""

    @app.command()
    def scenarios() -> None:
        """List the built-in simulation scenarios with one-line descriptions."""
        from rich.console import Console
        from rich.markup import escape
        from rich.table import Table

        from drivelash.sim.scenarios import list_scenarios

        table = Table("name", "duration [s]", "description", box=None)
        for sc in list_scenarios():
            table.add_row(escape(sc.name), f"{sc.duration:g}", escape(sc.description))
        Console().print(table)

    @app.command()
    def simulate(
        scenario: str = typer.Argument(
            ..., help="Scenario name (see `drivelash scenarios`), CONFIG.toml, or 'fleet'."
        ),
        out: Path = typer.Option(
            ..., "-o", "--out", help="Output trace (.parquet, .csv, .h5 or .mat); a directory for 'fleet'."
        ),
        duration: float | None = typer.Option(
            None, "--duration", help="Simulated time [s] (per recording for 'fleet')."
        ),
        seed: int | None = typer.Option(None, "--seed", min=0, max=SEED_MAX, help="Noise seed."),
        machines: int = typer.Option(3, "--machines", min=1, help="'fleet': machines."),
        axes: int = typer.Option(2, "--axes", min=1, help="'fleet': axes per machine."),
        recordings: int = typer.Option(
            30, "--recordings", min=2, help="'fleet': recordings per axis (one a day; at least 2)."
        ),
        workers: int = typer.Option(1, "--workers", min=1, help="'fleet': processes simulating recordings."),
        force: bool = typer.Option(False, "--force", help=FORCE_HELP),
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
                force=force,
            )
            return
        from rich.console import Console
        from rich.progress import BarColumn, TextColumn, TimeRemainingColumn

        from drivelash._progress import stderr_progress
        from drivelash.io.formats import write_trace
        from drivelash.io.outputs import TRACE_EXTENSIONS, Outputs
        from drivelash.sim.scenarios import load_scenario

        source = Path(scenario) if scenario.lower().endswith(".toml") else None
        with Outputs("simulate", inputs=[source], force=force) as outs:
            target = outs.file(out, option="-o", kinds=TRACE_EXTENSIONS)
            sc = load_scenario(scenario)
            T = sc.duration if duration is None else duration
            if not (math.isfinite(T) and T > 0):
                raise ParameterError("simulate", "duration", f"must be finite and > 0, got {T!r}")
            check_simulation_size(sc.name, T, sc.T_s, sc.n_sub)
            console = Console(stderr=True)
            if T >= 30.0:
                with stderr_progress(
                    TextColumn(f"simulating {sc.name}"),
                    BarColumn(),
                    TextColumn("{task.percentage:>3.0f}%"),
                    TimeRemainingColumn(),
                    console=console,
                ) as bar:
                    task = bar.add_task("sim", total=1.0)
                    trace = sc.simulate(
                        duration=T,
                        seed=seed,
                        progress=lambda done, total: bar.update(task, completed=done / total),
                    )
            else:
                trace = sc.simulate(duration=T, seed=seed)
            write_trace(trace, outs.staging(target))
        typer.echo(f"{sc.name}: {len(trace)} samples ({trace.duration + sc.T_s:g} s) -> {out}")
