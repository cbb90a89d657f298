"""``drivelash demo``: the main job on built-in examples, writing a report directory.

Steps are plain functions in :data:`DEMO_STEPS`, each ``step(out_dir, console) -> None``;
later capabilities append theirs (estimation, compensation).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import typer
from rich.console import Console

DemoStep = Callable[[Path, Console], None]


def _steps() -> list[DemoStep]:
    steps: list[DemoStep] = []
    try:
        from drivelash.sim.demo import demo_simulate

        steps.append(demo_simulate)
    except ModuleNotFoundError:
        pass
    try:
        from drivelash.estimation.demo import demo_estimate

        steps.append(demo_estimate)
    except ModuleNotFoundError:
        pass
    try:
        from drivelash.te.demo import demo_compensate

        steps.append(demo_compensate)
    except ModuleNotFoundError:
        pass
    try:
        from drivelash.iso230.demo import demo_iso230

        steps.append(demo_iso230)
    except ModuleNotFoundError:
        pass
    try:
        from drivelash.wear.demo import demo_fleet

        steps.append(demo_fleet)
    except ModuleNotFoundError:
        pass
    return steps


def register(app: typer.Typer, te_app: typer.Typer) -> None:
    """Add ``demo`` to the CLI."""

    @app.command()
    def demo(
        out: Path = typer.Option(Path("demo-output"), "-o", "--out", help="Output directory."),
    ) -> None:
        """Run the built-in example end to end and write its outputs to OUT."""
        console = Console()
        out.mkdir(parents=True, exist_ok=True)
        for step in _steps():
            step(out, console)
        console.print(f"[green]demo outputs in {out}/[/green]")
