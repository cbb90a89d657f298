"""The loader's velocity-scale check: the position against the integral of its velocity.

θ(t) ≈ a + s·Ω(t), Ω(t) = ∫ω dt (trapezoid rule), fitted by least squares over the whole
recording; a consistent recording gives s ≈ 1. Unlike the derivative ratio of the unit check
(:func:`drivelash.io._unitcheck.unit_ratio_sums`, which selects samples by the size of
dθ/dt and so reads a coarse encoder on a small motion as a velocity 0.47× too small), the
integral averages the encoder's quantisation and the velocity's noise out. Accumulated over
chunks (merged means and co-moments, Chan et al.), so the streaming reader and the whole-file
loader compute the same fit.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["VelocityScaleFit"]


class VelocityScaleFit:
    """Least-squares fit of θ on Ω = ∫ω dt, fed chunk by chunk in time order."""

    def __init__(self) -> None:
        self.n = 0
        self.mean = np.zeros(2)  # (Ω, θ)
        self.M = np.zeros((2, 2))  # co-moments about the mean
        self._last: tuple[float, float, float] | None = None  # (t, ω, Ω) of the previous sample
        self._theta0: float | None = None

    def feed(self, t: np.ndarray, theta: np.ndarray, omega: np.ndarray) -> None:
        """Add samples (time [s], position, velocity in the same unit per second)."""
        t = np.asarray(t, dtype=np.float64)
        theta = np.asarray(theta, dtype=np.float64)
        omega = np.asarray(omega, dtype=np.float64)
        if t.size == 0:
            return
        if self._theta0 is None:
            self._theta0 = float(theta[0])
        if self._last is None:
            tt, ww, w0 = t, omega, 0.0
        else:
            t_p, w_p, w0 = self._last
            tt, ww = np.concatenate(([t_p], t)), np.concatenate(([w_p], omega))
        steps = np.diff(tt) * 0.5 * (ww[1:] + ww[:-1])
        Om = w0 + np.cumsum(steps)
        if self._last is None:
            Om = np.concatenate(([0.0], Om))
        self._last = (float(t[-1]), float(omega[-1]), float(Om[-1]))
        X = np.column_stack((Om, theta - self._theta0))
        nb = X.shape[0]
        mb = X.mean(axis=0)
        C = (X - mb).T @ (X - mb)
        na = self.n
        delta = mb - self.mean
        self.n = na + nb
        self.M = self.M + C + np.outer(delta, delta) * (na * nb / self.n)
        self.mean = self.mean + delta * (nb / self.n)

    def result(self) -> tuple[float, float]:
        """(s, R²): the scale of θ against ∫ω dt and the share of θ's variance it explains;
        (nan, 0) when Ω or θ does not vary."""
        s_oo, s_ot, s_tt = self.M[0, 0], self.M[0, 1], self.M[1, 1]
        if self.n < 3 or not (s_oo > 0 and s_tt > 0):
            return math.nan, 0.0
        s = s_ot / s_oo
        return float(s), float(s_ot * s_ot / (s_oo * s_tt))
