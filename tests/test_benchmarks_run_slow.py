"""`make bench` runs: the benchmark scripts that broke unnoticed in sessions 13–15 (the compensation
table over more than the model's measured range; the memory bench's JSON compared byte for byte
after the command began recording its name) run to exit 0 in a reduced form. Their figures are
not asserted (no absolute times in tests); this only keeps `make bench` from rotting again."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
@pytest.mark.parametrize(
    "args",
    [
        ["benchmarks/bench_compensation.py"],
        ["benchmarks/bench_memory.py", "--minutes", "0", "--prefix-minutes", "0.25", "--formats", "parquet"],
        ["benchmarks/bench_first_run.py"],
    ],
    ids=["compensation", "memory-prefix", "first-run"],
)
def test_benchmark_script_runs(args, tmp_path):
    env = {**os.environ, "DRIVELASH_CACHE": str(tmp_path / "cache")}
    cmd = [sys.executable, *args]
    r = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=1800)
    assert r.returncode == 0, (r.stdout + r.stderr)[-2000:]
    if "first_run" in args[0]:  # three commands, each a first and a cached run
        assert len([ln for ln in r.stdout.splitlines() if ln.rstrip().endswith("x")]) == 3, r.stdout
    if "memory" in args[0]:
        # the streamed command reproduces the in-memory figures (the bench's own check, printed)
        assert r.stdout.count(": True") == 4, r.stdout
