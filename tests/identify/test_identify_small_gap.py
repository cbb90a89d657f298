"""A small gap on bench-0B: the two-mass identification's intervals miss (session 22, a known miss).

A sweep of bench-0B variants (session 22; the cases rebuilt here with ``bench_variant``, 8 s at
8 kHz, seeds 1–6) found the identification honest at the bench's own 186 mrad gap (K_S, J_l, δ inside
every interval; the 100-seed coverage test measures 0.94 / 0.97) but biased at smaller gaps, with
intervals that exclude the truth. K_S outside its interval in 4 of 18 runs: δ = 5 mrad seeds 1 and
3 (+10.0 %, +12.2 %), 20 mrad seed 3 (+13.1 %, J_l +20.5 % outside too), 50 mrad seed 2 (−7.5 %);
δ outside in 5 of 18: +0.49 / +0.51 mrad at 5 mrad, +0.47 / +0.33 at 20 mrad, +0.30 at 50 mrad.
Not the encoders: 65536-count encoders give the same biases (seed 1, 5 mrad: K_S +9.7 %, δ +10.4 %).
The random drives of the acceptance (δ 10–500 mrad on other drives) meet the 5 % / 1 mrad limits;
here the shaft deflects up to ≈ 10 mrad beyond the contacts (Δθ spans −6.1 … +12.3 mrad around
contacts at ±2.5 mrad). Narrowed to the windows' acceleration targets built from the recorded
velocities' noise (docs/assumptions.md, "Gaps much smaller than the shaft's deflection": true-velocity
targets remove it, K_S −0.86 %), not yet fixed. The goal is kept: the 95 %
intervals hold the truth. The measured values are asserted so that the known miss cannot drift
unnoticed.
"""

from __future__ import annotations

import pytest

from drivelash.estimation.identify_two_mass import identify_two_mass
from identify.acceptance import bench_variant


@pytest.fixture(scope="module")
def small_gap():
    plant, trace = bench_variant(0.005, 0.0025, 1)  # bench-0B's shaft, δ = 5 mrad, seed 1
    return plant, identify_two_mass(trace, 1.0)


@pytest.mark.xfail(
    strict=True,
    reason="known miss: bench-0B with δ = 5 mrad (seed 1): K_S 36.22 [33.44, 39.00] N·m/rad for 32.94 "
    "(+10.0 %), δ 5.49 [5.07, 5.92] mrad for 5.00 — both intervals exclude the truth; goal: the 95 % "
    "intervals hold it (as at the bench's own 186 mrad gap); because the identification is biased at "
    "gaps much smaller than the shaft's deflection — narrowed to the window accelerations built from the "
    "recorded velocity noise, not fixed (a 4 ms window holds the truth: "
    "test_a_longer_window_holds_the_truth)",
)
def test_small_gap_intervals_hold_the_truth(small_gap):
    plant, r = small_gap
    assert r["K_S"].identifiable and r["K_S"].covers(plant.K_S), r["K_S"]
    assert r["delta"].identifiable and r["delta"].covers(0.005), r["delta"]


def test_small_gap_measured_as_stated(small_gap):
    """The figures of the known miss above (and of docs/assumptions.md), as measured."""
    plant, r = small_gap
    assert r.backlash_visible
    assert r["K_S"].value / plant.K_S - 1 == pytest.approx(0.100, abs=0.01)
    assert 1e3 * r["delta"].value == pytest.approx(5.49, abs=0.03)
    assert 1e3 * r["delta"].low == pytest.approx(5.07, abs=0.03)
    assert 1e3 * r["delta"].high == pytest.approx(5.92, abs=0.03)


def test_a_longer_window_holds_the_truth(small_gap):
    """The workaround README names: ``[identification] window = 0.004`` (32 samples; the target
    noise shrinks with the window, the integral equation stays exact). Measured (session 22) on
    δ = 5 and 20 mrad, seeds 1 and 3, and the bench's 186 mrad: K_S within 2.5 %, every K_S, J_l
    and δ interval holding the truth (6 of 6). Asserted here on the case above, with the default's
    miss as the negative control."""
    plant, r_default = small_gap
    assert not r_default["K_S"].covers(plant.K_S)  # the known miss, at the default 1 ms
    _, trace = bench_variant(0.005, 0.0025, 1)
    r = identify_two_mass(trace, 1.0, window_s=0.004)
    assert abs(r["K_S"].value / plant.K_S - 1) <= 0.05 and r["K_S"].covers(plant.K_S), r["K_S"]
    assert r["J_l"].covers(plant.J_l), r["J_l"]
    assert r["delta"].covers(0.005) and abs(r["delta"].value - 0.005) < 1e-4, r["delta"]


@pytest.mark.slow
@pytest.mark.parametrize(
    ("delta", "seed"), [(0.005, 1), (0.005, 3), (0.02, 1), (0.02, 3), (0.186, 1), (0.186, 3)]
)
def test_a_longer_window_holds_the_truth_on_every_measured_case(delta, seed):
    """README: "window = 0.004 … holds the truth in every interval (K_S within 2.5 % on 6 of 6
    runs at 5, 20 and 186 mrad)"."""
    plant, trace = bench_variant(delta, delta / 2, seed)
    r = identify_two_mass(trace, 1.0, window_s=0.004)
    assert abs(r["K_S"].value / plant.K_S - 1) <= 0.025, r["K_S"]
    for n, v in (("K_S", plant.K_S), ("J_l", plant.J_l), ("delta", delta)):
        assert r[n].identifiable and r[n].covers(v), (n, r[n])


def _sweep_case(args: tuple[float, int]) -> tuple[bool, bool]:
    delta, seed = args
    plant, trace = bench_variant(delta, delta / 2, seed)
    r = identify_two_mass(trace, 1.0)
    return not r["K_S"].covers(plant.K_S), not r["delta"].covers(delta)


@pytest.mark.slow
def test_small_gap_sweep_measured_as_stated():
    """README / docs: at 5, 20 and 50 mrad, seeds 1–6, K_S's interval misses the truth in 4 of 18
    runs and δ's in 5 of 18 (the known miss's extent, measured as stated)."""
    from concurrent.futures import ProcessPoolExecutor

    cases = [(d, s) for d in (0.005, 0.02, 0.05) for s in range(1, 7)]
    with ProcessPoolExecutor(2) as ex:
        res = list(ex.map(_sweep_case, cases))
    assert sum(k for k, _ in res) == 4 and sum(d for _, d in res) == 5, list(zip(cases, res, strict=True))


@pytest.mark.slow
def test_a_4ms_window_breaks_the_fast_random_drive():
    """README: "a drive that resonates at 332 Hz needs the short window (K_S −17 % at 4 ms)" — random
    drive seed 1 / case 0 of the acceptance (K_S −4.72 % at the default 1 ms)."""
    import numpy as np

    from estimation.test_generalisation import random_drive

    rng = np.random.default_rng(1)
    dt, bl, trace = random_drive(rng, 0)
    f_res = np.sqrt(dt.K_S * (1 / dt.J_l + 1 / (dt.N**2 * dt.J_m))) / (2 * np.pi)
    assert f_res == pytest.approx(332, abs=1)
    r = identify_two_mass(trace, dt.N, window_s=0.004)
    assert r["K_S"].value / dt.K_S - 1 == pytest.approx(-0.175, abs=0.01)
