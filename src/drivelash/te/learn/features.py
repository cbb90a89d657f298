"""Tooth-meshing features of the stage-1 network, eqs (4)–(5) of spec 02 §3.

η_j = (2/ε)·mod(x n_t/(π d_p) − j, n_t) − 1 and the bump function
M_j = exp(η_j²/(η_j² − 1)) on |η_j| < 1, for pinion teeth j = 1 … n_t: a smooth
indicator of where each pinion tooth is in its mesh cycle at table position x.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["bump_features", "bump_row"]


@njit(cache=True)
def bump_row(x: float, n_t: int, d_p: float, eps: float, out: np.ndarray) -> None:  # pragma: no cover - njit
    """Bump features M_1 … M_nt at one position ``x`` [m] into ``out`` (njit)."""
    u = x * n_t / (np.pi * d_p)
    for j in range(n_t):
        m = (u - (j + 1)) % n_t
        eta = (2.0 / eps) * m - 1.0
        if -1.0 < eta < 1.0:
            e2 = eta * eta
            out[j] = np.exp(e2 / (e2 - 1.0))
        else:
            out[j] = 0.0


def bump_features(x: np.ndarray, n_t: int, d_p: float, eps: float) -> np.ndarray:
    """Tooth-meshing features, eqs (4)–(5).

    η_j = (2/ε)·mod(x n_t/(π d_p) − j, n_t) − 1,  M_j = exp(η_j²/(η_j² − 1)) for |η_j| < 1 else 0,
    for pinion teeth j = 1 … n_t.

    Parameters
    ----------
    x : numpy.ndarray
        Table position [m].
    n_t : int
        Number of pinion teeth.
    d_p : float
        Pitch diameter [m].
    eps : float
        Contact ratio ε [-].

    Returns
    -------
    numpy.ndarray
        Shape ``(len(x), n_t)``; values in [0, 1] (1 at η_j = 0).
    """
    x = np.asarray(x, dtype=np.float64).reshape(-1)
    u = x[:, None] * n_t / (np.pi * d_p) - np.arange(1, n_t + 1)[None, :]
    eta = (2.0 / eps) * np.mod(u, n_t) - 1.0
    inside = np.abs(eta) < 1.0
    e2 = np.where(inside, eta * eta, 0.0)
    return np.where(inside, np.exp(e2 / np.where(inside, e2 - 1.0, -1.0)), 0.0)
