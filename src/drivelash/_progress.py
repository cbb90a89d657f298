"""The transient progress bar of the commands (rich), on stderr and only on a terminal.

Rich's transient bar leaves one newline behind when it stops on a console that is not a
terminal (a cron job's log, a pipe, a test capturing stderr): a successful ``track ingest``
wrote a blank line to stderr, and the one line after Ctrl-C came after a blank one (session 19).
Off a terminal the bar is disabled: it draws nothing and writes nothing.
"""

from __future__ import annotations

from typing import Any

__all__ = ["stderr_progress"]


def stderr_progress(*columns: Any, console: Any = None) -> Any:
    """A transient :class:`rich.progress.Progress` on ``console`` (default: a stderr console),
    disabled when that console is not a terminal.

    Parameters
    ----------
    *columns : rich.progress.ProgressColumn or str
        The bar's columns (rich's default columns when none are given).
    console : rich.console.Console, optional
        Where to draw (default ``Console(stderr=True)``).

    Returns
    -------
    rich.progress.Progress
        The bar, to be used as a context manager.
    """
    from rich.console import Console
    from rich.progress import Progress

    console = Console(stderr=True) if console is None else console
    return Progress(*columns, console=console, transient=True, disable=not console.is_terminal)
