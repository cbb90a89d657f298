"""Command-line interface: ``drivelash …`` (typer).

Each group of commands lives in its own module under :mod:`drivelash.commands`
and registers itself on the shared app; heavy imports (numba kernels, torch)
happen inside the commands, so ``drivelash --help`` stays fast.

User errors (:class:`~drivelash.errors.DrivelashError`) become a one-line
message on stderr and exit code 2 — never a traceback.
"""

from __future__ import annotations

import importlib
import sys

import typer

from drivelash.errors import DrivelashError

app = typer.Typer(
    name="drivelash",
    help="Backlash estimation, transmission-error learning and compensation for drive trains.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
te_app = typer.Typer(
    help="Rack-and-pinion transmission errors: campaign, learning, compensation.",
    no_args_is_help=True,
)
app.add_typer(te_app, name="te")

# Modules under drivelash.commands, each with ``register(app, te_app)``.
_COMMAND_MODULES = (
    "sim",
    "estimate",
    "data",
    "te_campaign",
    "te_model",
    "te_compensate",
    "te_score",
    "te_update",
    "demo",
    "iso230",
    "track",
)

for _name in _COMMAND_MODULES:
    try:
        _mod = importlib.import_module(f"drivelash.commands.{_name}")
    except ModuleNotFoundError as exc:  # a command module not written yet
        if exc.name != f"drivelash.commands.{_name}":
            raise
        continue
    _mod.register(app, te_app)


def fail(message: str, code: int = 2) -> typer.Exit:
    """Print a one-line error to stderr and return the exit to raise."""
    typer.echo(f"drivelash: error: {message}", err=True)
    return typer.Exit(code)


def main() -> None:
    """Console-script entry point: run the app, turning user errors into one line."""
    try:
        app(standalone_mode=False)
    except DrivelashError as exc:
        typer.echo(f"drivelash: error: {exc}", err=True)
        sys.exit(2)
    except typer.Exit as exc:
        sys.exit(exc.exit_code)
    except (typer.Abort, KeyboardInterrupt):
        typer.echo("drivelash: aborted", err=True)
        sys.exit(130)
    except Exception as exc:  # click usage errors
        import click

        if isinstance(exc, click.exceptions.ClickException):
            exc.show()
            sys.exit(2)
        raise


if __name__ == "__main__":
    main()
