"""Fixtures of the estimator tests: small simulated drives (the simulator's engine)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from drivelash.control.cascade import gains_from_bandwidth
from drivelash.control.references import position_sine, sampled, time_grid
from drivelash.params import BacklashParams, SensorParams
from drivelash.sim.engine import simulate
from drivelash.sim.scenarios import RIG_DRIVETRAIN

TS = 125e-6

#: The bench drive (bench-0B's estimator parameters and δ1) as the `[drivetrain]`/`[backlash]`
#: TOML `estimate` reads.
BENCH_DRIVE_TOML = """
[drivetrain]
J_m = 8.31e-4
J_l = 8.31e-4
N = 1.0
K_S = 32.94
D_S = 0.0548
T_Cm = 0.0223
T_Cl = 0.0232
beta_m = 0.0016
beta_l = 0.0016

[backlash]
delta1 = 0.093
"""
BENCH_SENSORS = SensorParams(counts_m=2048, counts_l=2048, sigma_omega_m=0.0316, sigma_omega_l=0.0316)
RIG_ESTIMATOR = replace(RIG_DRIVETRAIN, T_Sm=0.0, T_Sl=0.0)


def rig_trace(reference, delta=0.186, delta1=0.093, seed=0):
    """Simulated bench-rig trace on ``reference`` (11-bit encoders, noisy velocities)."""
    bl = BacklashParams(delta, delta1)
    g = gains_from_bandwidth(RIG_DRIVETRAIN, 100.0)
    return simulate(RIG_DRIVETRAIN, bl, g, reference, sensors=BENCH_SENSORS, seed=seed).to_trace(), bl


@pytest.fixture(scope="session")
def short_bench_trace():
    """8 s of bench-B-like motion (θ_r = sin πt)."""
    return rig_trace(position_sine(8.0, TS, 1.0, 0.5))


@pytest.fixture(scope="session")
def inside_trace():
    """Motor amplitude 0.03 rad, far inside the 0.186 rad deadzone (δ1 = 0.093): no engagement."""
    return rig_trace(position_sine(10.0, TS, 0.03, 0.5))


@pytest.fixture(scope="session")
def unidirectional_trace():
    """Motor turning one way at 2 rad/s: the load is pushed on one contact side only."""
    t = time_grid(10.0, TS)
    return rig_trace(sampled(t, 2.0 * t, 2.0 * np.ones_like(t)))
