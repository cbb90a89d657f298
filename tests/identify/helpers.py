"""Shared helpers of the io / identify / report tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from drivelash.io.trace import Trace
from realdata import shared_data

REPO = Path(__file__).resolve().parents[2]
EMPS_CONFIG = REPO / "examples" / "emps.toml"


def emps_file(name: str) -> Path:
    """Path of an EMPS file (``conftest.shared_data``: fails under CI=true when absent)."""
    return shared_data("emps", name)


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
