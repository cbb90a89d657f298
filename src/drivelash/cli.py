"""Command-line interface: ``drivelash …`` (typer).

Each group of commands lives in its own module under :mod:`drivelash.commands`
and registers itself on the shared app; heavy imports (numba kernels, torch)
happen inside the commands, so ``drivelash --help`` stays fast.

:func:`main` is the one place where errors meet the user:

- a user error (:class:`~drivelash.errors.DrivelashError`) → ``drivelash: error: …``
  on stderr, exit code 2;
- a usage error from typer/click (missing or unknown option, bad option value,
  unknown command) → one line with click's message and its hint
  (``try 'drivelash estimate --help'``), exit code 2;
- ``drivelash`` or ``drivelash te`` without a command → the help (printed by typer's
  formatter) and exit code 2, as click itself does since 8.2 (``NoArgsIsHelpError``);
- an ``OSError`` naming a file that no check foresaw (a path component too long, a symlink
  loop) → ``drivelash: error: FILE: <the system's message>``, exit code 2;
- Ctrl-C (SIGINT) and SIGTERM → an exception, so every command's staged outputs are removed
  and its targets stay as they were (:mod:`drivelash.io.outputs`); one line on stderr
  (``drivelash: interrupted; no output written``, or which outputs had already been put in
  place), no traceback; exit code 130 for SIGINT, 143 for SIGTERM. SIGINT raises
  :class:`Interrupted`, not ``KeyboardInterrupt``, which typer turns into a silent exit 130;
  a SIGINT that the caller set to be ignored (a background job) stays ignored.

Numerical ``RuntimeWarning``\\ s (``invalid value encountered …``) are not actionable for
a user and are not shown; the sources silence the legitimate ones themselves, and
``DRIVELASH_WARNINGS=error`` turns any remaining one into a failure (used by the tests).
"""

from __future__ import annotations

import importlib
import os
import signal
import sys
import time
import warnings
from typing import Any

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
    _mod = importlib.import_module(f"drivelash.commands.{_name}")
    _mod.register(app, te_app)


def _escape_markup(cmd: Any) -> Any:
    """Escape Rich markup in the help of ``cmd``, its parameters and its subcommands (in place).

    The help texts name TOML tables and units in square brackets (``[drivetrain]``, ``[mm]``);
    typer renders help with Rich markup, which took them for style tags and dropped them
    ("write / TOML" for "write [drivetrain]/[backlash] TOML"). Escaped, they print as written.
    """
    from rich.markup import escape

    for attr in ("help", "short_help"):
        text = getattr(cmd, attr, None)
        if text:
            setattr(cmd, attr, escape(text))
    for param in getattr(cmd, "params", ()):
        if getattr(param, "help", None):
            param.help = escape(param.help)
    for sub in getattr(cmd, "commands", {}).values():
        _escape_markup(sub)
    return cmd


_command: Any = None


def _click_command() -> Any:
    """The click command of ``app`` with its help texts escaped (built once)."""
    global _command
    if _command is None:
        _command = _escape_markup(typer.main.get_command(app))
    return _command


class Terminated(BaseException):  # noqa: N818 - mirrors KeyboardInterrupt
    """Raised in the main thread on SIGTERM, so ``with``-blocks clean up (staged outputs)."""


class Interrupted(BaseException):  # noqa: N818 - mirrors KeyboardInterrupt
    """Raised in the main thread on SIGINT (Ctrl-C) in place of ``KeyboardInterrupt``."""


class _Stop:
    """State of the signal handlers while :func:`main` runs a command."""

    active = False  # a command runs: a signal raises Terminated / Interrupted
    in_hook = False  # inside _redeliver_signal: a signal handled there would be lost again
    pending: int | None = None  # a signal that could not stop the command where it landed
    timer: Any = None
    raised_at: float | None = None  # when the handler raised the stop (monotonic clock [s])
    raised_sig: int | None = None  # the signal of that stop


#: A further Ctrl-C/SIGTERM within this time after the one that stopped the command is not
#: raised again: the stop is still unwinding (a process pool terminating its workers, staged
#: outputs removed), and an exception raised into that clean-up is what left a pool worker
#: behind and hung the interpreter's exit (session 19's tester). Later it is raised again, in
#: case the first one was lost [s].
STOP_AGAIN_AFTER_S = 10.0


def _stop_exception(signum: int) -> BaseException:
    return Terminated() if signum == signal.SIGTERM else Interrupted()


def _redeliver_later(signum: int) -> None:
    """Deliver ``signum`` to the main thread again in 10 ms (once the current hook returned)."""
    import _thread
    import threading

    if _Stop.timer is not None:
        _Stop.timer.cancel()
    _Stop.timer = threading.Timer(0.01, _thread.interrupt_main, args=(signum,))
    _Stop.timer.daemon = True
    _Stop.timer.start()


def _on_signal(signum: int, frame: Any) -> None:
    """SIGINT and SIGTERM: stop the running command (or remember the signal, see :class:`_Stop`)."""
    if _Stop.active and not _Stop.in_hook:
        now = time.monotonic()
        if _Stop.raised_at is None or now - _Stop.raised_at >= STOP_AGAIN_AFTER_S:
            _Stop.raised_at, _Stop.raised_sig = now, signum
            raise _stop_exception(signum)
        return  # the stop is under way (see STOP_AGAIN_AFTER_S)
    _Stop.pending = signum
    if _Stop.active:
        _redeliver_later(signum)


def _redeliver_signal(unraisable: Any, previous: Any) -> None:
    """``sys.unraisablehook`` while a command runs: a Ctrl-C/SIGTERM that landed in a callback
    from C code is delivered again instead of being lost.

    Numba's JIT calls Python through ctypes (its object-cache notifications); an exception
    raised there cannot propagate: Python printed "Exception ignored …" with a traceback and
    the run went on to write its outputs. Delivering the signal again a moment later
    (:func:`_thread.interrupt_main` from a timer thread, so that it does not land in this
    hook) makes the handler run at a point of ordinary Python code, where it stops the
    command as usual; one that lands in a callback again comes back here. Should the command
    end first, :func:`main` still reports it as interrupted.
    """
    exc = unraisable.exc_value
    if not isinstance(exc, Terminated | Interrupted | KeyboardInterrupt):
        previous(unraisable)
        return
    signum = signal.SIGTERM if isinstance(exc, Terminated) else signal.SIGINT
    _Stop.in_hook = True
    _Stop.raised_at = None  # that stop was lost: the next delivery raises again
    try:
        _Stop.pending = signum
        _redeliver_later(signum)
    finally:
        _Stop.in_hook = False


def _stopped_line(what: str) -> str:
    """The one line after Ctrl-C or SIGTERM: what happened and which outputs were written."""
    outputs = sys.modules.get("drivelash.io.outputs")  # not imported: nothing was written
    written = outputs.written_outputs() if outputs is not None else []
    if not written:
        return f"drivelash: {what}; no output written"
    return f"drivelash: {what} after writing {', '.join(written)}; nothing else written"


def _forget_written() -> None:
    outputs = sys.modules.get("drivelash.io.outputs")
    if outputs is not None:
        outputs.forget_written()


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _usage_error_line(exc: Any) -> str:
    """Click's message and hint on one line."""
    msg = _one_line(exc.format_message())
    ctx = getattr(exc, "ctx", None)
    if ctx is not None:
        return f"{msg} (try '{ctx.command_path} --help')"
    return msg


def _click_exception_types() -> tuple[type[BaseException], ...]:
    from typer._click.exceptions import ClickException

    types: list[type[BaseException]] = [ClickException]
    try:  # a stray real click exception (e.g. from a dependency) is shown the same way
        import click

        types.append(click.exceptions.ClickException)
    except ImportError:  # pragma: no cover - click is a dependency of dask
        pass
    return tuple(types)


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point: run the app; every error becomes one line and an exit code.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (default ``sys.argv[1:]``).
    """
    from typer._click.exceptions import NoArgsIsHelpError

    click_errors = _click_exception_types()
    in_main_thread = _is_main_thread()
    old_handler = signal.signal(signal.SIGTERM, _on_signal) if in_main_thread else None
    # Python's own Ctrl-C handler only: an ignored SIGINT (a background job) stays ignored
    old_int = None
    if in_main_thread and signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        old_int = signal.signal(signal.SIGINT, _on_signal)
    old_hook = sys.unraisablehook
    if in_main_thread:
        sys.unraisablehook = lambda u: _redeliver_signal(u, old_hook)
    _forget_written()
    try:
        with warnings.catch_warnings():
            if os.environ.get("DRIVELASH_WARNINGS") == "error":
                warnings.simplefilter("error", RuntimeWarning)
            else:
                warnings.simplefilter("ignore", RuntimeWarning)
            _Stop.pending, _Stop.active, _Stop.raised_at, _Stop.raised_sig = None, True, None, None
            try:
                rv = _click_command()(args=argv, prog_name="drivelash", standalone_mode=False)
            except Exception:
                # a stop raised inside library code can come back as another error: numba's
                # compiler swallowed the Interrupted and its cache then failed with "no compiled
                # object yet" (a traceback, exit 1, in the clean-clone run of session 32)
                sig = _Stop.raised_sig if _Stop.raised_at is not None else _Stop.pending
                if sig is None:
                    raise
                raise _stop_exception(sig) from None
            finally:  # from here on a signal is only remembered, never raised
                _Stop.active = False
                if _Stop.timer is not None:
                    _Stop.timer.cancel()
                    _Stop.timer = None
            if _Stop.pending is not None:  # lost in a callback; the command ended first
                raise _stop_exception(_Stop.pending)
        if rv == 130 and not isinstance(rv, bool):
            # typer turns a KeyboardInterrupt (not raised by our handler: e.g. a handler
            # installed by a library) into a silent Exit(130); no command exits 130 itself
            typer.echo(_stopped_line("interrupted"), err=True)
            sys.exit(130)
        if isinstance(rv, int) and not isinstance(rv, bool) and rv != 0:
            sys.exit(rv)  # typer returns the code of an Exit
    except DrivelashError as exc:
        typer.echo(f"drivelash: error: {_one_line(str(exc))}", err=True)
        sys.exit(2)
    except OSError as exc:
        # a file the checks did not foresee (a path component too long, a symlink loop, an
        # unreadable file): the operating system's own words, naming the file; no traceback
        if not isinstance(exc.filename, str | bytes | os.PathLike):
            raise
        reason = os.strerror(exc.errno) if exc.errno else _one_line(str(exc))
        typer.echo(f"drivelash: error: {os.fsdecode(exc.filename)}: {reason}", err=True)
        sys.exit(2)
    except NoArgsIsHelpError as exc:
        # typer's rich formatter has already printed the help (stdout) while raising this;
        # the plain formatter returns it as the message instead.
        if exc.format_message().strip():
            typer.echo(exc.format_message(), err=True)
        sys.exit(2)
    except click_errors as exc:
        typer.echo(f"drivelash: error: {_usage_error_line(exc)}", err=True)
        sys.exit(int(getattr(exc, "exit_code", 2) or 2))
    except typer.Exit as exc:
        sys.exit(exc.exit_code)
    except (typer.Abort, KeyboardInterrupt, Interrupted):
        typer.echo(_stopped_line("interrupted"), err=True)
        sys.exit(130)
    except Terminated:
        typer.echo(_stopped_line("terminated"), err=True)
        sys.exit(143)
    finally:
        if old_handler is not None:
            signal.signal(signal.SIGTERM, old_handler)
        if old_int is not None:
            signal.signal(signal.SIGINT, old_int)
        sys.unraisablehook = old_hook


def _is_main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()


if __name__ == "__main__":
    main()
