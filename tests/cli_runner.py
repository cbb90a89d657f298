"""Run the ``drivelash`` console script in-process (one helper for every CLI test)."""

from __future__ import annotations

import sys

from drivelash.cli import main


def run_in_process(argv: list[str], capsys) -> tuple[int, str, str]:
    """Run ``drivelash ARGV`` as the console script does; return (exit code, stdout, stderr)."""
    old = sys.argv
    sys.argv = ["drivelash", *argv]
    try:
        main()
        code = 0
    except SystemExit as exc:
        code = int(exc.code or 0)
    finally:
        sys.argv = old
    out, err = capsys.readouterr()
    return code, out, err
