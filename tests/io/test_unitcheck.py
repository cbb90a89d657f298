"""The loader's unit check in one compiled pass equals its numpy definition (np.gradient,
np.convolve moving mean, masked dot products) on uniform and jittered time, short and long
signals, quantised positions and wrong units (the refusal itself: tests/io/test_io_validation.py)."""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.io._unitcheck import unit_ratio_sums


def _reference(t: np.ndarray, th: np.ndarray, om: np.ndarray, k: int):
    d = np.gradient(th, t)
    if k > 1:
        ker = np.ones(k) / k
        d, om = np.convolve(d, ker, mode="same"), np.convolve(om, ker, mode="same")
    mx = np.max(np.abs(d))
    moving = np.abs(d) > 0.1 * mx if mx > 0 else np.zeros(d.size, bool)
    if not moving.any():
        return 0.0, 0.0, 0, -1
    return (
        float(np.dot(om[moving], d[moving])),
        float(np.dot(d[moving], d[moving])),
        int(moving.sum()),
        int(np.flatnonzero(moving)[0]),
    )


@pytest.mark.parametrize("seed", range(6))
def test_kernel_equals_numpy_definition(seed):
    rng = np.random.default_rng(seed)
    for n in (2, 3, 7, 60, 1001, 20000):
        steps = rng.uniform(0.5, 1.5, n) if seed % 2 else np.ones(n)
        t = np.cumsum(steps) * 125e-6
        th = rng.uniform(0.1, 3) * np.sin(2 * np.pi * rng.uniform(0.5, 50) * t) + 1e-4 * rng.normal(size=n)
        if seed % 3 == 0:
            th = np.round(th * 2048) / 2048  # an encoder's counts
        om = np.gradient(th, t) * rng.choice([1.0, 180 / np.pi, 0.3]) + 0.01 * rng.normal(size=n)
        for k in sorted(
            {1, 2, 4, max(1, min(25, n // 50)), 25} & set(range(1, n + 1))
        ):  # the loader: k ≤ n/50
            got = unit_ratio_sums(t, th, om, k)
            ref = _reference(t, th, om, k)
            # a running sum rounds differently from np.convolve (≈ 1e-16 relative): a sample
            # exactly at the motion threshold may flip, nothing else; the ratio is what counts
            assert abs(got[2] - ref[2]) <= max(1, 1e-3 * ref[2]), (n, k)
            if ref[2] >= 10:
                assert got[0] / got[1] == pytest.approx(ref[0] / ref[1], rel=1e-9), (n, k)
                assert got[3] == ref[3] or abs(got[2] - ref[2]) > 0, (n, k)


def test_standstill_has_no_motion():
    t = np.arange(100) * 1e-3
    assert unit_ratio_sums(t, np.zeros(100), np.zeros(100), 2)[2:] == (0, -1)


# --- the loader's other compiled passes: equal to the numpy rules they replace ---------------
@pytest.mark.parametrize("seed", range(4))
def test_wrap_scan_equals_numpy_rule(seed):
    """``wrap_scan`` = (all finite, any |diff| > half) as ``unwrap_encoder`` wrote it in numpy."""
    from drivelash.io._unitcheck import wrap_scan

    rng = np.random.default_rng(seed)
    for n in (1, 2, 5, 1000):
        x = np.cumsum(rng.normal(0, 0.3, n))
        if seed == 1:
            x = np.mod(x, 1.0)  # wrapped: jumps of ≈ 1
        if seed == 2 and n > 1:
            x[n // 2] = np.nan
        if seed == 3 and n > 1:
            x[-1] = np.inf
        finite = bool(np.all(np.isfinite(x)))
        jump = bool(np.any(np.abs(np.diff(x)) > 0.5)) if finite else False
        assert wrap_scan(x, 0.5) == (finite, jump), n


def test_step_scan_and_time_check_rules():
    """``step_scan`` finds the first non-increasing step and the step range; the time check's
    shortcut gives what the full rules give: none of uniform, jittered-within-tolerance, ms
    stamps read as s, a duplicate, or a gap (negative controls: each is still refused)."""
    from drivelash.errors import DataError
    from drivelash.io._unitcheck import step_scan
    from drivelash.io.config import SamplingSection
    from drivelash.io.load import _check_time

    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.9999, 1.0001, 1000)) * 125e-6
    first, lo, hi = step_scan(t)
    d = np.diff(t)
    assert (first, lo, hi) == (-1, d.min(), d.max())
    t2 = t.copy()
    t2[500] = t2[499]
    assert step_scan(t2)[0] == 499
    sampling = SamplingSection()
    assert _check_time(t, "f", "t", sampling, []) is None  # within tolerance: the shortcut
    gap = t.copy()
    gap[700:] += 1e-3  # one interval 9× the median
    with pytest.raises(DataError, match=r"data row 701 \(1-based\): non-uniform sampling"):
        _check_time(gap, "f", "t", sampling, [])
    with pytest.raises(DataError, match="duplicated time stamp"):
        _check_time(t2, "f", "t", sampling, [])
    ms = np.arange(1000.0)  # ms stamps read as seconds: whole numbers, 1 s steps
    with pytest.raises(DataError, match="implausible sample period"):
        _check_time(ms, "f", "t", sampling, [])
    # a unit declared in [columns] is checked against the data too (it used to be trusted: the
    # KUKA recording with ms stamps declared as s gave J_m = 20161 kg·m² for 0.02)
    with pytest.raises(DataError, match='declares unit = "s"; time stamps in ms'):
        _check_time(ms, "f", "t", sampling, [], "s")
    with pytest.raises(DataError, match="implausible sample period 4 s"):
        _check_time(4.0 * ms + 0.25, "f", "t", sampling, [], "s")  # not whole seconds either
    slow = np.arange(1000.0) * 0.1  # negative control: an ISO 230-2 series at 10 Hz
    assert _check_time(slow, "f", "t", sampling, [], "s") is None
