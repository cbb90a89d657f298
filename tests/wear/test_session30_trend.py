"""Wear trend defects found by session 30's tester B (docs/assumptions.md, "Wear tracking").

* B-05: the noise scale σ̂ took second differences as if the recordings were equally spaced;
  recordings at varying times of day (``simulate fleet``: a random minute within 2 h) gave
  second differences of the trend itself, σ̂ above the stated uncertainty, σ_sys = 0 and a
  90 % crossing interval minutes wide that missed the truth.
"""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.wear import trend
from drivelash.wear.trend import fit_trend, jump_scale, noise_scale


def _jittered_line(rng: np.random.Generator, rate: float, jitter_h: float = 2.0, n: int = 20):
    """Daily recordings at a random minute within ``jitter_h`` hours, linear wear ``rate``
    [rad/day], a per-axis error of 0.1 mrad (≈ the stated sd) and 0.03 mrad scatter."""
    t = np.arange(n) + rng.uniform(0, jitter_h / 24, n)
    d0 = rng.uniform(0.05, 0.08)
    thr = d0 + 0.08
    y = d0 + rate * t + rng.normal(0, 0.1e-3) + rng.normal(0, 0.03e-3, n)
    return t, y, thr, (thr - d0) / rate


def test_noise_scale_of_a_noise_free_trend_at_uneven_times_is_the_floor():
    rng = np.random.default_rng(5)
    t = np.arange(20) + rng.uniform(0, 2 / 24, 20)
    y = 0.05 + 4.3e-3 * t
    assert noise_scale(y) > 3 * trend.SIGMA_FLOOR  # the rule as it was: the trend read as noise
    assert noise_scale(y, t) == trend.SIGMA_FLOOR
    assert jump_scale(y, t) == trend.SIGMA_FLOOR


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_negative_control_equally_spaced_scale_is_unchanged(seed):
    rng = np.random.default_rng(seed)
    t = np.arange(30) * 7.0
    y = 0.05 + 1e-3 * t + rng.normal(0, 0.2e-3, t.size)
    y[17:] += 0.01
    assert noise_scale(y, t) == noise_scale(y)
    assert jump_scale(y, t) == jump_scale(y)


def test_fast_axis_at_varying_times_keeps_its_systematic_uncertainty_and_the_interval_holds():
    """4–6 mrad/day recorded within 2 h each day (mc_jitter.py, 150 axes): coverage 0.31 → 0.95."""
    rng = np.random.default_rng(1)
    held = 0
    for _ in range(10):
        t, y, thr, t_cross = _jittered_line(rng, rng.uniform(4e-3, 6e-3))
        tr = fit_trend(t, y, np.full(t.size, 0.105e-3), thr)
        assert tr.sigma_sys > 0.08e-3
        held += tr.forecast.t_early <= t_cross <= tr.forecast.t_late
    assert held >= 8, held


# ------------------------------------------------------------------ B-03: jumps on weekly data
def _weekly_jump(rng: np.random.Generator, rate: float, every: float, J: float, n: int = 16):
    """mc_jump.py's axes: linear wear, a step J halfway, 0.03 mrad scatter, 0.05 mrad per-axis error."""
    t = np.arange(n) * every
    tj = t[n // 2] - every / 2
    d0 = 0.050
    thr = d0 + J + rate * t[-1] + 0.03  # crossing 30 mrad beyond the latest estimate
    y = d0 + rate * t + J * (t >= tj) + rng.normal(0, 0.03e-3, n) + rng.normal(0, 0.05e-3)
    return t, y, thr, t[-1] + 0.03 / rate


@pytest.mark.parametrize("rate, every, J", [(1e-3, 7.0, 0.015), (2e-3, 7.0, 0.020), (0.5e-3, 14.0, 0.010)])
def test_a_jump_on_weekly_or_fortnightly_data_is_found_and_the_forecast_holds(rate, every, J):
    """B-03 (mc_jump.py, 20 seeds each): found 0/20 → 20/20, interval holds the truth 0/20 → 20/20;
    before, the estimates after the step left the fit as outliers and δ now was 3–5 mrad high."""
    rng = np.random.default_rng(7)
    for _ in range(4):
        t, y, thr, t_cross = _weekly_jump(rng, rate, every, J)
        tr = fit_trend(t, y, np.full(t.size, 0.105e-3), thr)
        assert len(tr.change_points) == 1 and tr.change_points[0].index == t.size // 2
        assert tr.change_points[0].size == pytest.approx(J, rel=0.1)
        assert tr.inlier.all()
        assert tr.forecast.t_early <= t_cross <= tr.forecast.t_late


@pytest.mark.parametrize("every, n", [(7.0, 16), (14.0, 12)])
def test_negative_control_smooth_accelerating_weekly_wear_is_no_jump(every, n):
    """Smooth wear whose rate grows 4× over the history, weekly or fortnightly, no jump: none
    found (30 of 30 axes before and after; 360 smooth axes up to 40× growth: 30 false jumps
    with the rule before and after, all at 12× and 40×)."""
    import math

    rng = np.random.default_rng(17)
    for _ in range(6):
        L = n * every
        d0, G = rng.uniform(0.03, 0.1), rng.uniform(0.04, 0.1)
        t = np.arange(n) * every + rng.uniform(0, 2 / 24, n)
        k = math.log(4.0) / L
        y = d0 + G * k / math.expm1(k * L) * np.expm1(k * t) / k + rng.normal(0, 0.3e-3, n)
        assert fit_trend(t, y, np.full(n, 0.3e-3), d0 + 1.2 * G).change_points == []


def test_negative_control_a_lone_outlier_on_weekly_data_is_no_jump():
    rng = np.random.default_rng(3)
    for i in (5, 9, 14):
        t = np.arange(16) * 7.0
        y = 0.05 + 1e-3 * t + rng.normal(0, 0.03e-3, 16)
        y[i] += 0.015
        tr = fit_trend(t, y, np.full(16, 0.105e-3), 0.2)
        assert tr.change_points == [] and not tr.inlier[i]


# ------------------------------------------------------------------ B-04: the new part's own rate
def _repaired(rng: np.random.Generator, r1: float, r2: float, n2: int = 8):
    """mc_repair.py's axes: 15 daily estimates at r1 [rad/day], a repair at day 14.5 to 55 mrad,
    then ``n2`` at r2; 0.03 mrad scatter, 0.05 mrad per-axis error; threshold 110 mrad."""
    t = np.arange(15 + n2, dtype=float)
    true = np.where(t < 14.5, 0.060 + r1 * t, 0.055 + r2 * (t - 14.5))
    y = true + rng.normal(0, 0.03e-3, t.size) + rng.normal(0, 0.05e-3)
    return t, y, 0.110, 14.5 + (0.110 - 0.055) / r2


@pytest.mark.parametrize("r1, r2", [(3e-3, 1e-3), (1e-3, 3e-3)])
def test_after_a_repair_the_new_part_wears_at_its_own_rate(r1, r2):
    """B-04 (mc_repair.py, 40 seeds): interval holding the truth 0/40 → 35/40 (r2 = r1/3) and
    39/40 (r2 = 3 r1); before, one slope across the repair put δ now 6.6 mrad high and the
    forecast a month early."""
    rng = np.random.default_rng(3)
    held = 0
    for _ in range(6):
        t, y, thr, t_cross = _repaired(rng, r1, r2)
        tr = fit_trend(t, y, np.full(t.size, 0.105e-3), thr)
        assert len(tr.change_points) == 1 and tr.change_points[0].size < 0
        assert tr.model == "linear" and tr.params["b"] + tr.params["b1"] == pytest.approx(r2, rel=0.05)
        assert float(tr.curve(t[-1:])[0][0]) == pytest.approx(y[-1], abs=0.3e-3)  # δ now
        held += tr.forecast.t_early <= t_cross <= tr.forecast.t_late
    assert held >= 5, held


def test_negative_control_equal_rates_across_a_repair_share_the_slope():
    rng = np.random.default_rng(3)
    for _ in range(6):
        t, y, thr, t_cross = _repaired(rng, 3e-3, 3e-3)
        tr = fit_trend(t, y, np.full(t.size, 0.105e-3), thr)
        assert "b1" not in tr.params
        assert tr.forecast.t_early <= t_cross <= tr.forecast.t_late


# ------------------------------------------------------------------ B-07: the report's monotone line
def test_monotone_trend_does_not_pass_through_an_outlier():
    """B-07: a +12 mrad wild estimate on a 1 mrad/day line (the report's M03/Y): the isotonic
    line jumped to it and stayed up to 3.8 mrad above every inlier; now it follows the inliers."""
    rng = np.random.default_rng(2)
    t = np.arange(30, dtype=float)
    y = 0.07 + 1e-3 * t + rng.normal(0, 0.05e-3, t.size)
    y[12] += 0.012
    tr = fit_trend(t, y, np.full(t.size, 0.1e-3), 0.2)
    assert not tr.inlier[12] and tr.inlier.sum() == 29
    assert np.all(np.abs(tr.isotonic - (0.07 + 1e-3 * t)) < 0.5e-3)
    assert np.all(np.diff(tr.isotonic) >= 0)
