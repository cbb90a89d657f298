"""Shared helpers of the iso230 tests."""

from __future__ import annotations

import sys
from collections.abc import Callable

import pytest

from drivelash.cli import main


@pytest.fixture
def run_cli(capsys) -> Callable[[list[str]], tuple[int, str, str]]:
    """Run ``drivelash ARGV`` in-process as the console script does: (exit code, stdout, stderr)."""

    def run(argv: list[str]) -> tuple[int, str, str]:
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

    return run
