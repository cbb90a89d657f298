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
    from drivelash.estimation.demo import demo_estimate
    from drivelash.iso230.demo import demo_iso230
    from drivelash.sim.demo import demo_simulate
    from drivelash.te.demo import demo_compensate
    from drivelash.wear.demo import demo_fleet

    return [demo_simulate, demo_estimate, demo_compensate, demo_iso230, demo_fleet]


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
