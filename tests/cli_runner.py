"""Run the ``drivelash`` console script in-process (one helper for every CLI test)."""

from __future__ import annotations

import sys
import warnings
from typing import NamedTuple

from drivelash.cli import main

#: A fresh interpreter's warning filters (``python -m drivelash.cli`` without ``-W``): what a
#: user's terminal shows. Under pytest every warning would be captured by pytest instead, so a
#: test's "stderr is one line" could not see a stray warning that the console script prints.
_PYTHON_DEFAULT_FILTERS = (
    ("ignore", DeprecationWarning),
    ("ignore", PendingDeprecationWarning),
    ("ignore", ImportWarning),
    ("ignore", ResourceWarning),
)


class CliResult(NamedTuple):
    """Exit code, standard output and standard error of one command (a tuple, like before)."""

    returncode: int
    stdout: str
    stderr: str


def run_in_process(argv: list[str], capsys) -> CliResult:
    """Run ``drivelash ARGV`` as the console script does; return (exit code, stdout, stderr).

    Output printed before the call is dropped; warnings the command emits are appended to
    stderr as Python prints them (the interpreter's default filters, not pytest's).
    """
    capsys.readouterr()
    old = sys.argv
    sys.argv = ["drivelash", *argv]
    with warnings.catch_warnings(record=True) as caught:
        warnings.resetwarnings()
        for action, category in _PYTHON_DEFAULT_FILTERS:
            warnings.simplefilter(action, category)
        try:
            main()
            code = 0
        except SystemExit as exc:
            code = int(exc.code or 0)
        finally:
            sys.argv = old
    out, err = capsys.readouterr()
    fmt = warnings.formatwarning
    err += "".join(fmt(w.message, w.category, w.filename, w.lineno, w.line) for w in caught)
    return CliResult(code, out, err)
