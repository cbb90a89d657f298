"""SIGTERM/SIGKILL during ``te campaign -o EXISTING``: never a directory that mixes two drives.

The existing campaign (seed 1) is replaced by a run with seed 2 that is killed at a random
point. Afterwards the target is either the old campaign (every file unchanged) or the new
one, complete (no file of the old drive left) — so ``te fit`` never sees a mixture.
"""

from __future__ import annotations

import hashlib
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from drivelash.te.protocol.campaign import load_campaign

ENV = {**os.environ, "PYTHONWARNINGS": "ignore"}
TINY = """
[campaign]
stroke = 0.12
velocities = [0.1]
loads = [0.0, 1000.0]
sine_loads = []
"""


def _campaign(out: Path, seed: int, cwd: Path, axis: Path) -> subprocess.Popen:
    args = ["te", "campaign", "--config", str(axis), "-o", str(out), "--seed", str(seed), "--no-plot"]
    return subprocess.Popen(
        [sys.executable, "-c", "from drivelash.cli import main; main()", *args],
        cwd=cwd, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip


def _digests(d: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(d.glob("*.parquet"))}


@pytest.fixture(scope="module")
def old_campaign(tmp_path_factory) -> tuple[Path, dict]:
    """The seed-1 tiny campaign and its file digests."""
    d = tmp_path_factory.mktemp("sig")
    axis = d / "tiny.toml"
    axis.write_text(TINY)
    p = _campaign(d / "s1", 1, d, axis)
    _, err = p.communicate(timeout=600)
    assert p.returncode == 0, err
    return d, _digests(d / "s1")


def _one_run(tmp_path: Path, old_campaign: tuple, sig: int, delay: float) -> str:
    base, old = old_campaign
    target = tmp_path / "C"
    import shutil

    shutil.copytree(base / "s1", target)
    p = _campaign(target, 2, tmp_path, base / "tiny.toml")
    time.sleep(delay)
    p.send_signal(sig)
    p.communicate(timeout=600)
    visible = sorted(n for n in os.listdir(tmp_path) if not n.startswith("."))
    assert visible == ["C"]
    camp = load_campaign(target)  # complete and valid
    got = _digests(target)
    kept = [k for k in got if got[k] == old.get(k)]
    # all files of the old drive, or none of them (the new campaign, complete): never a mixture
    assert got.keys() == old.keys() and len(kept) in (0, len(old)), f"a mixed campaign: {kept}"
    assert camp.seed == (1 if got == old else 2)
    for n in os.listdir(tmp_path):  # a killed run's staging directory is never a campaign
        if n.startswith(".") and (tmp_path / n).is_dir() and not (tmp_path / n / "manifest.json").is_file():
            with pytest.raises(Exception):  # noqa: B017, PT011 - any refusal
                load_campaign(tmp_path / n)
    return "old" if got == old else "new"


def test_sigterm_during_campaign_keeps_old_or_gives_new(tmp_path, old_campaign):
    assert _one_run(tmp_path, old_campaign, signal.SIGTERM, random.Random(15).uniform(1.0, 4.0)) in (
        "old",
        "new",
    )


@pytest.mark.slow
@pytest.mark.parametrize("k", range(10))
def test_signal_at_random_points_of_campaign(tmp_path, old_campaign, k):
    rng = random.Random(2000 + k)
    sig = (signal.SIGTERM, signal.SIGKILL)[k % 2]
    _one_run(tmp_path, old_campaign, sig, rng.uniform(0.05, 12.0))
