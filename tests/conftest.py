"""Shared fixtures."""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import pytest

# Reports state when they were generated; tests that compare two renders byte for byte must not
# straddle a minute (a flaky failure in session 15): every report of the run, in this process
# and in the CLI subprocesses it starts, states this fixed time (reproducible-builds.org's
# SOURCE_DATE_EPOCH, honoured by drivelash.report.html.generated_at). 2026-01-01 12:00 UTC.
os.environ.setdefault("SOURCE_DATE_EPOCH", "1767268800")

# Real data (../shared/data): one rule, in tests/realdata.py (a module name no conftest shadows)
from realdata import SHARED_DATA, in_ci, shared_data  # noqa: E402,F401


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded random generator (tests are reproducible)."""
    return np.random.default_rng(12345)


# ---------------------------------------------------------------------------
# TE: the seed-0 run whose figures the README quotes (slow tests only)

_REPO = __import__("pathlib").Path(__file__).resolve().parents[1]


def _source_hash() -> str:
    """Hash of the package sources and pins: a cached TE run is reused only for identical code."""
    import hashlib

    h = hashlib.sha256()
    files = sorted((_REPO / "src" / "drivelash").rglob("*.py"))
    for p in [*files, _REPO / "pyproject.toml", _REPO / "requirements.lock"]:
        h.update(str(p.relative_to(_REPO)).encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def _te_step(workdir, name: str, args) -> None:
    """Run ``drivelash ARGS`` once (marker file ``.done-NAME``); a half-done step is redone.

    ``args`` may instead be a callable ``args(workdir)`` (a Python step that writes ``NAME``).
    """
    import shutil
    import subprocess
    import sys

    marker = workdir / f".done-{name}"
    if marker.is_file():
        return
    target = workdir / name
    if target.exists():
        shutil.rmtree(target)
    if callable(args):
        args(workdir)
        marker.write_text("ok\n")
        return
    log = workdir / f"{name}.log"
    with log.open("w") as fh:
        cmd = [sys.executable, "-m", "drivelash.cli", *args]
        proc = subprocess.run(cmd, stdout=fh, stderr=subprocess.STDOUT, cwd=workdir)
    if proc.returncode != 0:
        raise RuntimeError(f"drivelash {' '.join(args)} failed (exit {proc.returncode}), see {log}")
    marker.write_text("ok\n")


@pytest.fixture(scope="session")
def te_seed0():
    """The README's TE run, by its own commands: ``drivelash te campaign -o C --seed 0``,
    ``te fit C -o M``, ``te evaluate M C -o E``, ``te validate M -o V``.

    Cached in ``$DRIVELASH_CACHE`` (default ``.venv/drivelash-cache``) under a hash of the
    sources, so a second ``make test-slow`` on unchanged code reuses it; a file lock makes
    the pytest-xdist workers share one run. ``DRIVELASH_TE_SEED0=DIR`` points at a finished
    run (C, M, E, V) instead (development only). Returns the four directories.
    """
    import os
    from pathlib import Path

    from filelock import FileLock

    env = os.environ.get("DRIVELASH_TE_SEED0")
    if env:
        d = Path(env)
    else:
        cache = Path(os.environ.get("DRIVELASH_CACHE", _REPO / ".venv" / "drivelash-cache"))
        d = cache / f"te-seed0-{_source_hash()}"
        d.mkdir(parents=True, exist_ok=True)
        with FileLock(str(d) + ".lock"):
            _te_step(d, "C", ["te", "campaign", "-o", "C", "--seed", "0"])
            _te_step(d, "M", ["te", "fit", "C", "-o", "M"])
            _te_step(d, "E", ["te", "evaluate", "M", "C", "-o", "E"])
            _te_step(d, "V", ["te", "validate", "M", "-o", "V"])
    return {k: d / k for k in ("C", "M", "E", "V")}


def _te_run(tag: str, steps: list[tuple[str, Any]]) -> dict:
    """Run TE command steps once in a cached directory keyed by ``tag`` and the source hash
    (a step is ``(NAME, ARGS)``, see :func:`_te_step`)."""
    import os
    from pathlib import Path

    from filelock import FileLock

    cache = Path(os.environ.get("DRIVELASH_CACHE", _REPO / ".venv" / "drivelash-cache"))
    d = cache / f"{tag}-{_source_hash()}"
    d.mkdir(parents=True, exist_ok=True)
    with FileLock(str(d) + ".lock"):
        for name, args in steps:
            _te_step(d, name, args)
    return {name: d / name for name, _ in steps}


@pytest.fixture(scope="session")
def te_quick():
    """The quick path with every default: ``te campaign --quick -o C``, ``te fit C -o M``,
    ``te validate M -o V --quick`` (cached like :func:`te_seed0`)."""
    return _te_run(
        "te-quick",
        [
            ("C", ["te", "campaign", "--quick", "-o", "C", "--seed", "0"]),
            ("M", ["te", "fit", "C", "-o", "M"]),
            ("V", ["te", "validate", "M", "-o", "V", "--quick"]),
        ],
    )


@pytest.fixture(scope="session")
def te_custom_axis():
    """A custom axis (examples/rack_axis.toml: 3 mm module, 24 teeth, i = 10, 1.2 m travel):
    ``te campaign --config``, ``te fit``, ``te validate`` (cached like :func:`te_seed0`)."""
    axis = str(_REPO / "examples" / "rack_axis.toml")
    return _te_run(
        "te-custom-axis",
        [
            ("C", ["te", "campaign", "--config", axis, "-o", "C", "--seed", "0"]),
            ("M", ["te", "fit", "C", "-o", "M"]),
            ("V", ["te", "validate", "M", "-o", "V"]),
        ],
    )


@pytest.fixture(scope="session")
def te_round_trip(te_seed0):
    """Issue 12's round trip, once per test run: the seed-0 campaign written as CNC traces
    (``tests/te_axis/cnc.py``), then ``te import cnc/axis.toml -o C2``, ``te fit C2 -o M2``,
    ``te evaluate M2 C2 -o E2``. Cached like :func:`te_seed0` (keyed also by the campaign's
    path and the exporter's source), so the pytest-xdist workers share one run instead of
    each building its own. Returns the directories ``cnc``, ``C2``, ``M2``, ``E2``.
    """
    import hashlib

    exporter = _REPO / "tests" / "te_axis" / "cnc.py"
    key = hashlib.sha256(str(te_seed0["C"].resolve()).encode() + exporter.read_bytes()).hexdigest()[:8]

    def export(workdir) -> None:
        from drivelash.te.protocol.campaign import load_campaign
        from te_axis.cnc import export_cnc

        export_cnc(load_campaign(te_seed0["C"]), workdir / "cnc")

    return _te_run(
        f"te-round-trip-{key}",
        [
            ("cnc", export),
            ("C2", ["te", "import", "cnc/axis.toml", "-o", "C2"]),
            ("M2", ["te", "fit", "C2", "-o", "M2"]),
            ("E2", ["te", "evaluate", "M2", "C2", "-o", "E2"]),
        ],
    )
