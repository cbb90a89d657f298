"""CLI command modules; each defines ``register(app, te_app)``."""

from __future__ import annotations

from typing import Any

import typer


def print_warnings(meta: dict[str, Any]) -> None:
    """Print the load warnings of a trace (``meta["warnings"]``) to stderr, one line each."""
    for w in meta.get("warnings", []):
        typer.echo(f"drivelash: warning: {w}", err=True)
