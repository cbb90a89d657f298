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
