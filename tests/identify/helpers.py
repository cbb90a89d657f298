"""Shared helpers of the io / identify / report tests."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from drivelash.io.trace import Trace

REPO = Path(__file__).resolve().parents[2]
EMPS_DIR = REPO.parent / "shared" / "data" / "emps"
EMPS_CONFIG = REPO / "examples" / "emps.toml"


def shared_data(path: Path) -> Path:
    """A file of ../shared/data: skip with the reason when absent, but fail under CI=true
    (real-data tests must not pass silently on a machine without the data)."""
    if not path.exists():
        msg = f"real data not available at {path} (../shared/data is absent)"
        if os.environ.get("CI", "").lower() in ("1", "true", "yes"):
            pytest.fail(msg + " — CI=true requires it")
        pytest.skip(msg)
    return path


def emps_file(name: str) -> Path:
    """Path of an EMPS file (see :func:`shared_data`)."""
    return shared_data(EMPS_DIR / name)


def simulated_trace(duration: float = 2.0) -> Trace:
    """A simulated two-mass trace (the simulator's bench-0A scenario)."""
    from drivelash.sim.scenarios import get_scenario

    return get_scenario("bench-0A").simulate(duration=duration)


def synthetic_trace(n: int = 2000, T_s: float = 1e-3, seed: int = 0) -> Trace:
    """A small rotary trace with smooth motion (no simulator needed)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * T_s
    theta_m = 0.8 * np.sin(2 * np.pi * 1.3 * t) + 0.1 * np.sin(2 * np.pi * 3.1 * t)
    omega_m = 0.8 * 2 * np.pi * 1.3 * np.cos(2 * np.pi * 1.3 * t) + 0.1 * 2 * np.pi * 3.1 * np.cos(
        2 * np.pi * 3.1 * t
    )
    theta_l = 0.5 * theta_m + 1e-3 * np.sin(2 * np.pi * 0.7 * t)
    omega_l = np.gradient(theta_l, T_s)
    torque = 2.0 * np.sin(2 * np.pi * 1.3 * t + 0.4) + 0.05 * rng.standard_normal(n)
    return Trace(
        {
            "t": t,
            "theta_m": theta_m,
            "omega_m": omega_m,
            "theta_l": theta_l,
            "omega_l": omega_l,
            "torque_m": torque,
        },
        {"scenario": "synthetic", "seed": seed},
    )
