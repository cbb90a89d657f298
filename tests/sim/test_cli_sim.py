"""CLI: ``drivelash scenarios`` and ``drivelash simulate`` (real entry point, subprocess)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from drivelash.io.trace import Trace


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", "from drivelash.cli import main; main()", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=300,
    )


def test_scenarios_lists_all(tmp_path: Path) -> None:
    r = _cli("scenarios", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    for name in ("paper-sim", "bench-0A", "bench-5C"):
        assert name in r.stdout


def test_simulate_writes_trace(tmp_path: Path) -> None:
    out = tmp_path / "run.parquet"
    r = _cli("simulate", "bench-0C", "-o", str(out), "--duration", "0.5", "--seed", "4", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    tr = Trace.from_parquet(out)
    assert len(tr) == 4000 and tr.meta["scenario"] == "bench-0C" and tr.meta["seed"] == 4


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (("simulate", "bench-9Z", "-o", "x.parquet"), "unknown scenario 'bench-9Z'"),
        (("simulate", "bench-0A", "-o", "x.parquet", "--duration", "-1"), "duration"),
        (("simulate", "bench-0A", "-o", "x.txt"), "unsupported extension"),
        (("simulate", "bad.toml", "-o", "x.parquet"), "J_m"),
        (("simulate", "missing.toml", "-o", "x.parquet"), "no such file"),
    ],
)
def test_user_errors_are_one_line(tmp_path: Path, args: tuple[str, ...], needle: str) -> None:
    (tmp_path / "bad.toml").write_text("[plant]\nJ_m = -1.0\n")
    r = _cli(*args, cwd=tmp_path)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("drivelash: error:") and needle in lines[0]
    assert "Traceback" not in r.stderr
