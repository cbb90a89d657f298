"""SIGTERM and SIGKILL at random points of ``simulate -o EXISTING``: never a result a later command takes.

After the signal, the target is either the old complete file or (if the run finished
first) the new complete one — never truncated; a SIGTERM leaves no temporary file, a
SIGKILL only hidden ``….part`` names that no command accepts as a recording.
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from drivelash.errors import DataError
from drivelash.io import Trace, load_trace, write_trace

ENV = {**os.environ, "PYTHONWARNINGS": "ignore"}


def _drivelash(*args: str, cwd: Path) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-c", "from drivelash.cli import main; main()", *args],
        cwd=cwd,
        env=ENV,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


@pytest.fixture(scope="module")
def old_file(tmp_path_factory) -> tuple[Path, dict[str, np.ndarray]]:
    """A complete earlier output of drivelash (signed, so no --force is needed)."""
    d = tmp_path_factory.mktemp("sig")
    t = np.arange(4000) * 125e-6
    cols = {
        "t": t,
        "theta_m": np.sin(2 * np.pi * t),
        "omega_m": 2 * np.pi * np.cos(2 * np.pi * t),
        "torque_m": np.cos(5 * t),
    }
    write_trace(Trace(cols, {"scenario": "old"}), d / "old.parquet")
    return d / "old.parquet", load_trace(d / "old.parquet").columns


def _one_run(tmp_path: Path, old: tuple[Path, dict], sig: int, delay: float) -> str:
    src, old_cols = old
    target = tmp_path / "existing.parquet"
    target.write_bytes(src.read_bytes())
    p = _drivelash("simulate", "bench-0A", "-o", str(target), "--duration", "30", "--seed", "3", cwd=tmp_path)
    time.sleep(delay)
    p.send_signal(sig)
    _, err = p.communicate(timeout=300)
    names = sorted(os.listdir(tmp_path))
    visible = [n for n in names if not n.startswith(".")]
    assert visible == ["existing.parquet"], names
    if sig == signal.SIGTERM:
        assert names == ["existing.parquet"], names  # staging removed
        if p.returncode == -signal.SIGTERM:
            pass  # killed while Python was still importing, before cli.main ran: nothing was staged
        elif p.returncode != 0:
            assert p.returncode == 143 and err.strip().splitlines()[-1] == "drivelash: terminated", err
    for n in names:
        if n.startswith("."):
            with pytest.raises(DataError):  # a killed run's temporary file is refused by every reader
                load_trace(tmp_path / n)
    tr = load_trace(target)  # complete: loads and validates
    if len(tr) == len(old_cols["t"]):
        assert all(np.array_equal(tr[k], old_cols[k]) for k in old_cols), "changed but not replaced"
        return "old"
    assert tr.duration == pytest.approx(30.0, abs=1e-3)
    return "new"


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_signal_during_simulate_keeps_old_file_or_gives_new_one(tmp_path, old_file, sig):
    rng = random.Random(int(sig))
    outcome = _one_run(tmp_path, old_file, sig, rng.uniform(0.5, 3.0))
    assert outcome in ("old", "new")


@pytest.mark.slow
@pytest.mark.parametrize("k", range(12))
def test_signal_at_random_points_of_simulate(tmp_path, old_file, k):
    rng = random.Random(1000 + k)
    sig = (signal.SIGTERM, signal.SIGKILL)[k % 2]
    _one_run(tmp_path, old_file, sig, rng.uniform(0.05, 8.0))
