"""Independent reference solutions for the engine (used by tests and benchmarks).

:func:`replay_solve_ivp` integrates the same plant (1)–(4) with
``scipy.integrate.solve_ivp`` (adaptive DOP853, tight tolerances) under the *same*
zero-order-hold torque sequence the engine applied, one control period at a time,
so that the input discontinuities fall on interval boundaries.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from drivelash.physics.drivetrain import rhs


def replay_solve_ivp(
    x0: np.ndarray,
    u: np.ndarray,
    delta: np.ndarray,
    delta1: np.ndarray,
    plant_p: np.ndarray,
    T_s: float,
    *,
    rtol: float = 1e-11,
    atol: float = 1e-12,
    method: str = "DOP853",
) -> np.ndarray:
    """Plant states at k·T_s under a piecewise-constant torque.

    Parameters
    ----------
    x0 : numpy.ndarray
        Initial state [ω_m, θ_m, ω_l, θ_l] [rad/s, rad, rad/s, rad].
    u, delta, delta1 : numpy.ndarray
        Torque [N·m], δ and δ1 [rad] held over each period (length n).
    plant_p : numpy.ndarray
        Plant parameter array (:func:`drivelash.physics.drivetrain.plant_params_array`).
    T_s : float
        Period [s].
    rtol, atol : float
        solve_ivp tolerances.
    method : str
        solve_ivp method.

    Returns
    -------
    numpy.ndarray
        ``(n, 4)`` states at the start of each period (row 0 = ``x0``).
    """
    n = u.size
    X = np.empty((n, 4))
    x = np.asarray(x0, dtype=np.float64).copy()
    for k in range(n):
        X[k] = x
        if k == n - 1:
            break
        args = (float(u[k]), float(delta[k]), float(delta1[k]), plant_p)
        sol = solve_ivp(
            lambda t, y, uk, d, d1, p: rhs(y, uk, d, d1, p),
            (0.0, T_s),
            x,
            method=method,
            rtol=rtol,
            atol=atol,
            args=args,
        )
        x = sol.y[:, -1].copy()
    return X
