"""Analytic transmission-error functions with known derivatives (independent references)."""

from __future__ import annotations

import numpy as np

PITCH = 0.0133333  # tooth pitch [m]


class SineTE:
    """TE = A sin(2π x/λ) + c·T + offset(direction)  [m].

    The backlash (TE(−1) − TE(+1) at equal |T|) is ``b0 + b1 sin(2π x / L)``.
    """

    def __init__(self, A=5e-6, lam=PITCH, c=1e-7, b0=20e-6, b1=4e-6, L=0.5):
        self.A, self.lam, self.c, self.b0, self.b1, self.L = A, lam, c, b0, b1, L

    def backlash(self, x):
        return self.b0 + self.b1 * np.sin(2 * np.pi * np.asarray(x) / self.L)

    def predict(self, x_T, torque, direction):
        x = np.asarray(x_T, dtype=float)
        t = np.asarray(torque, dtype=float)
        base = self.A * np.sin(2 * np.pi * x / self.lam) + self.c * np.abs(t)
        return base + (self.backlash(x) if direction == -1 else 0.0)

    def dte_dx(self, x):
        return self.A * 2 * np.pi / self.lam * np.cos(2 * np.pi * np.asarray(x) / self.lam)


class BilinearTE:
    """TE linear in x and T per direction: bilinear interpolation reproduces it exactly."""

    def predict(self, x_T, torque, direction):
        x = np.asarray(x_T, dtype=float)
        t = np.asarray(torque, dtype=float)
        if direction == 1:
            return 3e-6 * x + 2e-7 * t + 1e-8 * x * t
        return -1e-6 * x - 3e-7 * t + 15e-6 - 2e-8 * x * t


class BenchTE:
    """The virtual bench's own true TE as a model of motor torque (an ideal learned model).

    Mesh force F = (|T| − T_C,m) / r_eff (nominal friction), then the generator's
    ``te(x, F, direction)``: the meshing amplitude shrinks with load and the compliance
    varies with the mesh position, so ∂TE/∂T varies along the travel.
    """

    def __init__(self, bench, te_model):
        self.te, self.b = te_model, bench

    def predict(self, x, torque, d):
        F = np.clip(np.abs(np.asarray(torque, float)) - self.b.T_Cm, 0, None) / self.b.r_eff
        return self.te.te(np.asarray(x, float), F, d)


class MeshAmplitudeTE:
    """TE = (A0 + kappa |T|) sin(2π x / λ): a meshing error whose amplitude grows with torque.

    ∂²TE/∂x∂T = kappa 2π/λ cos(2π x/λ); the torque-path gain of the compensator is
    ≈ v · kappa · 2π/λ. Large ``kappa`` is the negative control of the loop analysis.
    """

    def __init__(self, kappa, A0=4e-6, lam=PITCH):
        self.kappa, self.A0, self.lam = kappa, A0, lam

    def predict(self, x_T, torque, direction):
        x = np.asarray(x_T, dtype=float)
        t = np.abs(np.asarray(torque, dtype=float))
        return (self.A0 + self.kappa * t) * np.sin(2 * np.pi * x / self.lam)
