"""The progress bars draw on a terminal only: off one (a cron log, a pipe) a command's stderr
holds its messages and nothing else — rich's transient bar used to leave a blank line there
(a successful ``track ingest`` wrote "\\n"; the one line after Ctrl-C followed a blank one)."""

from __future__ import annotations

import os
import subprocess
import sys

from rich.console import Console

from drivelash._progress import stderr_progress


def test_a_long_simulate_writes_nothing_to_a_non_terminal_stderr(tmp_path):
    # 31 s ≥ 30 s: the length from which simulate shows its bar
    r = subprocess.run(
        [sys.executable, "-m", "drivelash.cli", "simulate", "bench-0A", "-o", str(tmp_path / "r.parquet")]
        + ["--duration", "31"],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONWARNINGS": "ignore"},
        timeout=600,
    )
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""


def test_the_bar_is_drawn_on_a_terminal_only():
    assert stderr_progress(console=Console(force_terminal=True)).disable is False
    assert stderr_progress(console=Console(force_terminal=False)).disable is True
