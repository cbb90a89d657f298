"""The loader's unit check as one ``@njit`` pass (``load._check_units``).

Kept apart from :mod:`drivelash.io.load` so that importing the loader does not import numba;
the kernel is compiled (and cached) on the first recording checked.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["unit_ratio_sums"]


@njit(cache=True)
def _moving_mean_same(x: np.ndarray, k: int) -> np.ndarray:
    """``np.convolve(x, np.ones(k) / k, mode="same")``: the mean over the window
    [i − k//2, i + (k − 1)//2] clipped to the signal, divided by k (a running sum)."""
    n = x.size
    out = np.empty(n)
    a = k // 2
    b = (k - 1) // 2
    s = 0.0
    for j in range(min(b + 1, n)):  # window of i = 0: [−a, b]
        s += x[j]
    for i in range(n):
        out[i] = s / k
        j_in = i + b + 1
        if j_in < n:
            s += x[j_in]
        j_out = i - a
        if j_out >= 0:
            s -= x[j_out]
    return out


@njit(cache=True)
def unit_ratio_sums(t: np.ndarray, th: np.ndarray, om: np.ndarray, k: int) -> tuple[float, float, int, int]:
    """Σ ω̄·d̄, Σ d̄², their count and the first row over the samples with motion.

    d = dθ/dt as ``np.gradient(th, t)`` (second order inside, first order at the ends),
    d̄ and ω̄ its and ω's moving means over ``k`` samples (none for k ≤ 1); a sample moves
    when |d̄| > 0.1 · max |d̄|.

    Parameters
    ----------
    t : numpy.ndarray
        Time [s], increasing, at least 2 samples.
    th : numpy.ndarray
        Position [rad].
    om : numpy.ndarray
        Velocity [rad/s].
    k : int
        Moving-mean window [samples].

    Returns
    -------
    (float, float, int, int)
        Σ ω̄ d̄ [rad²/s²], Σ d̄² [rad²/s²], number of moving samples, first moving row (−1: none).
    """
    n = t.size
    d = np.empty(n)
    if n < 2:
        return 0.0, 0.0, 0, -1
    d[0] = (th[1] - th[0]) / (t[1] - t[0])
    d[n - 1] = (th[n - 1] - th[n - 2]) / (t[n - 1] - t[n - 2])
    for i in range(1, n - 1):
        h1 = t[i] - t[i - 1]
        h2 = t[i + 1] - t[i]
        a = -h2 / (h1 * (h1 + h2))
        b = (h2 - h1) / (h1 * h2)
        c = h1 / (h2 * (h1 + h2))
        d[i] = a * th[i - 1] + b * th[i] + c * th[i + 1]
    if k > 1:
        d = _moving_mean_same(d, k)
        w = _moving_mean_same(om, k)
    else:
        w = om
    mx = 0.0
    for i in range(n):
        mx = max(mx, abs(d[i]))
    if not mx > 0:
        return 0.0, 0.0, 0, -1
    thr = 0.1 * mx
    s_od = 0.0
    s_dd = 0.0
    cnt = 0
    first = -1
    for i in range(n):
        if abs(d[i]) > thr:
            s_od += w[i] * d[i]
            s_dd += d[i] * d[i]
            cnt += 1
            if first < 0:
                first = i
    return s_od, s_dd, cnt, first


@njit(cache=True)
def wrap_scan(x: np.ndarray, half: float) -> tuple[bool, bool]:
    """(every sample finite, some step |x[i+1] − x[i]| > ``half``) in one pass: the loader's
    test whether a position column may have wrapped (``load.unwrap_encoder`` goes on only then)."""
    finite = True
    jump = False
    n = x.size
    for i in range(n):
        if not np.isfinite(x[i]):
            finite = False
            break
    if not finite:
        return False, False
    for i in range(n - 1):
        if abs(x[i + 1] - x[i]) > half:
            jump = True
            break
    return finite, jump


@njit(cache=True)
def step_scan(t: np.ndarray) -> tuple[int, float, float]:
    """First row whose time step ``t[i+1] − t[i]`` is ≤ 0 (−1: none), and the smallest and
    largest step (``load._check_time`` without the step array)."""
    lo = np.inf
    hi = -np.inf
    for i in range(t.size - 1):
        d = t[i + 1] - t[i]
        if not d > 0:
            return i, lo, hi
        if d < lo:
            lo = d
        if d > hi:
            hi = d
    return -1, lo, hi
