"""CLI command modules; each defines ``register(app, te_app)``."""

from __future__ import annotations

from typing import Any

import typer

#: Help text of every command's ``--force``.
FORCE_HELP = "Replace existing output files that were not written by drivelash."
#: Largest accepted noise seed (NumPy and numba seed with unsigned 32-bit integers).
SEED_MAX = 2**32 - 1


def print_warnings(meta: dict[str, Any]) -> None:
    """Print the load warnings of a trace (``meta["warnings"]``) to stderr, one line each."""
    for w in meta.get("warnings", []):
        typer.echo(f"drivelash: warning: {w}", err=True)
