"""First run of the README's commands: numba compiling its kernels, against the cached run.

Run: ``make bench`` (or ``.venv/bin/python benchmarks/bench_first_run.py``). In a temporary
directory, with ``NUMBA_CACHE_DIR`` pointing at an empty directory, each command runs twice:

1. ``drivelash simulate bench-0A -o run.parquet --duration 4``
2. ``drivelash estimate run.parquet --config examples/drive_bench.toml``
3. ``drivelash identify run.parquet --config examples/drive_bench.toml --model two-mass``

The first run compiles the kernels it calls and writes them to the cache; the **baseline** is
the second run of the same command, which loads them (what every later run costs). Printed:
wall time of each run (a fresh process each: interpreter start and imports included), the
difference (the compile time a new user waits once) and the ratio first / cached. The load
average is printed because other jobs may share the cores. These are the README's figures
("The first run of a command compiles its numba kernels …"); no test asserts times.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CONFIG = str(ROOT / "examples" / "drive_bench.toml")
COMMANDS = [
    ("simulate", ["simulate", "bench-0A", "-o", "run.parquet", "--duration", "4"]),
    ("estimate", ["estimate", "run.parquet", "--config", CONFIG]),
    ("identify", ["identify", "run.parquet", "--config", CONFIG, "--model", "two-mass"]),
]


def _timed(args: list[str], cwd: Path, env: dict[str, str]) -> float:
    t0 = time.perf_counter()
    r = subprocess.run(
        [sys.executable, "-m", "drivelash.cli", *args], cwd=cwd, env=env, capture_output=True, text=True
    )
    dt = time.perf_counter() - t0
    if r.returncode != 0:
        raise SystemExit(
            f"drivelash {' '.join(args)} failed (exit {r.returncode}): {r.stderr.strip()[-500:]}"
        )
    return dt


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        work, cache = Path(tmp) / "work", Path(tmp) / "numba-cache"
        work.mkdir()
        cache.mkdir()
        env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONDONTWRITEBYTECODE": ""}
        print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())} ({os.cpu_count()} cores)")
        print(f"{'command':<10}{'first run s':>13}{'cached s':>11}{'compile s':>11}{'first/cached':>14}")
        for name, args in COMMANDS:
            first = _timed(args, work, env)
            cached = _timed(args, work, env)
            print(f"{name:<10}{first:13.1f}{cached:11.1f}{first - cached:11.1f}{first / cached:13.1f}x")


if __name__ == "__main__":
    main()
