"""Helpers of the virtual-bench tests: spectral analysis of TE curves over position (independent of
the generator code) and a campaign of a few seconds."""

from __future__ import annotations

import numpy as np

from drivelash.sim.rack_campaign import CampaignConfig

#: A campaign of a few seconds: 0.15 m stroke, one velocity, two loads (tests of the bench and its figures).
TINY = CampaignConfig(
    stroke=0.15,
    velocities=(0.1,),
    loads=(0.0, 3000.0),
    sine_amplitude=0.05,
    sine_frequency=1.0,
    sine_periods=1.0,
    sine_loads=(0.0,),
    geometric_velocity=0.05,
)


def spectrum_over_position(x: np.ndarray, y: np.ndarray, x0: float, length: float, dx: float = 50e-6):
    """One-sided amplitude spectrum of y(x) on [x0, x0 + length).

    The curve is resampled on a uniform grid (linear interpolation), a cubic trend is
    removed (the drift), and a Hann window is applied; amplitudes are scaled by
    2/Σw so that a sinusoid whose period divides ``length`` shows its amplitude in
    bin k = length / period.

    Returns
    -------
    k : numpy.ndarray
        Bin index = number of periods in the window.
    amp : numpy.ndarray
        Amplitude [units of y].
    """
    n = int(round(length / dx))
    xg = x0 + dx * np.arange(n)
    order = np.argsort(x)
    yg = np.interp(xg, x[order], y[order])
    u = (xg - xg.mean()) / length
    yg = yg - np.polyval(np.polyfit(u, yg, 3), u)
    w = 0.5 - 0.5 * np.cos(2 * np.pi * np.arange(n) / n)  # periodic Hann
    Y = np.fft.rfft(yg * w)
    return np.arange(Y.size), 2.0 * np.abs(Y) / w.sum()
