"""CLI: ``drivelash scenarios`` and ``drivelash simulate``.

One test runs the real console entry point in a subprocess; the others call
:func:`drivelash.cli.main` in-process (same code path: argv → typer → one-line errors).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from drivelash.cli import main
from drivelash.io.trace import Trace


def _main(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture, *args: str) -> tuple[int, str, str]:
    monkeypatch.setattr(sys, "argv", ["drivelash", *args])
    code = 0
    try:
        main()
    except SystemExit as exc:
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


def test_unknown_scenario_subprocess(tmp_path: Path) -> None:
    entry = "from drivelash.cli import main; main()"
    r = subprocess.run(
        [sys.executable, "-c", entry, "simulate", "bench-9Z", "-o", "x.parquet"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=300,
    )
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("drivelash: error: unknown scenario 'bench-9Z'")


def test_scenarios_lists_all(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture) -> None:
    code, out, _ = _main(monkeypatch, capsys, "scenarios")
    assert code == 0
    for name in ("paper-sim", "bench-0A", "bench-5C"):
        assert name in out


def test_simulate_writes_trace(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture
) -> None:
    out = tmp_path / "run.parquet"
    code, stdout, err = _main(
        monkeypatch, capsys, "simulate", "bench-0C", "-o", str(out), "--duration", "0.5", "--seed", "4"
    )
    assert code == 0, err
    assert "4000 samples" in stdout
    tr = Trace.from_parquet(out)
    assert len(tr) == 4000 and tr.meta["scenario"] == "bench-0C" and tr.meta["seed"] == 4


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (("simulate", "bench-9Z", "-o", "x.parquet"), "unknown scenario 'bench-9Z'"),
        (("simulate", "bench-0A", "-o", "x.parquet", "--duration", "-1"), "duration"),
        (("simulate", "bench-0A", "-o", "x.txt"), "unsupported extension"),
        (("simulate", "bad.toml", "-o", "x.parquet"), "J_m"),
        (("simulate", "missing.toml", "-o", "x.parquet"), "no such configuration file"),
    ],
)
def test_user_errors_are_one_line(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture,
    args: tuple[str, ...],
    needle: str,
) -> None:
    (tmp_path / "bad.toml").write_text("[plant]\nJ_m = -1.0\n")
    monkeypatch.chdir(tmp_path)
    code, _, err = _main(monkeypatch, capsys, *args)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("drivelash: error:") and needle in lines[0]
