"""``drivelash demo``: the main job on built-in examples, writing a report directory.

Steps are plain functions in :func:`_steps`, each ``step(out_dir, console) -> None``.
The output directory is written as a whole (:meth:`drivelash.io.outputs.Outputs.directory`):
the steps write into a hidden sibling directory that replaces ``OUT`` at the end, so an
interrupted demo leaves the previous ``OUT`` as it was. The cache of the compensation
step (``OUT/te-demo/campaign``, ``model``) is carried over from a previous demo output.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import typer
from rich.console import Console

from drivelash.commands import FORCE_HELP

DemoStep = Callable[[Path, Console], None]

#: Sub-directories of a previous demo output reused as a cache (campaign and model).
_CACHE = ("te-demo/campaign", "te-demo/model")


def _steps() -> list[DemoStep]:
    from drivelash.estimation.demo import demo_estimate
    from drivelash.iso230.demo import demo_iso230
    from drivelash.sim.demo import demo_simulate
    from drivelash.te.demo import demo_compensate
    from drivelash.wear.demo import demo_fleet

    return [demo_simulate, demo_estimate, demo_compensate, demo_iso230, demo_fleet]


class _FinalPaths:
    """A console that shows the final output paths instead of the staging ones."""

    def __init__(self, console: Console, stage: Path, target: Path) -> None:
        self._c, self._stage, self._target = console, str(stage), str(target)

    def print(self, *args: Any, **kwargs: Any) -> None:
        shown = (a.replace(self._stage, self._target) if isinstance(a, str) else a for a in args)
        self._c.print(*shown, **kwargs)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._c, name)


def run_demo(out: Path, force: bool = False, console: Console | None = None) -> Path:
    """Body of ``drivelash demo``; returns the output directory."""
    from drivelash.io.outputs import Outputs, is_own_output

    console = console or Console()
    with Outputs("demo", force=force) as outputs:
        target = outputs.directory(out, option="-o")
        assert target is not None
        stage = outputs.staging(target)
        if target.is_dir() and is_own_output(target):
            for sub in _CACHE:
                if (target / sub).is_dir():
                    shutil.copytree(target / sub, stage / sub)
        shown = _FinalPaths(console, stage, target)
        for step in _steps():
            step(stage, shown)  # type: ignore[arg-type]
    console.print(f"[green]demo outputs in {out}/[/green]")
    return target


def register(app: typer.Typer, te_app: typer.Typer) -> None:
    """Add ``demo`` to the CLI."""

    @app.command()
    def demo(
        out: Path = typer.Option(Path("demo-output"), "-o", "--out", help="Output directory."),
        force: bool = typer.Option(False, "--force", help=FORCE_HELP),
    ) -> None:
        """Run the built-in example end to end and write its outputs to OUT."""
        run_demo(out, force=force)
