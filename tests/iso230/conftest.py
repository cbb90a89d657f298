"""Shared helpers of the iso230 tests."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from cli_runner import run_in_process


@pytest.fixture
def run_cli(capsys) -> Callable[[list[str]], tuple[int, str, str]]:
    """Run ``drivelash ARGV`` in-process as the console script does: (exit code, stdout, stderr)."""
    return lambda argv: run_in_process(argv, capsys)
