"""Figures of merit of spec 01 §3: MAEE (61), steady-state peak (60), convergence time.

All errors are |δ* − δ̂| in rad (report in mrad by multiplying by 1e3).
"""

from __future__ import annotations

import numpy as np

from drivelash.errors import DataError


def _check(
    t: np.ndarray, est: np.ndarray, ref: np.ndarray | float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.asarray(t, dtype=np.float64)
    est = np.asarray(est, dtype=np.float64)
    ref = np.broadcast_to(np.asarray(ref, dtype=np.float64), est.shape)
    if t.shape != est.shape:
        raise DataError(f"time has {t.size} samples, estimate {est.size}", column="t")
    return t, est, ref


def maee(t: np.ndarray, est: np.ndarray, ref: np.ndarray | float, t0: float, T: float | None = None) -> float:
    """Maximum absolute estimation error over [t0, t0 + T], eq (61) [rad].

    Parameters
    ----------
    t : numpy.ndarray
        Time [s].
    est : numpy.ndarray
        Estimate δ̂(t) [rad].
    ref : numpy.ndarray or float
        Truth δ*(t) [rad].
    t0 : float
        Start of the interval [s].
    T : float, optional
        Length of the interval [s]; default to the end.
    """
    t, est, ref = _check(t, est, ref)
    m = t >= t0
    if T is not None:
        m &= t <= t0 + T
    if not m.any():
        raise DataError(f"no samples in [{t0}, {t0 + (T or 0)}]", column="t")
    return float(np.max(np.abs(ref[m] - est[m])))


def steady_state_peak(t: np.ndarray, est: np.ndarray, ref: np.ndarray | float, T_p: float) -> float:
    """Steady-state peak error δ_SS: max |δ* − δ̂| over the last ``T_p`` seconds, eq (60) [rad]."""
    t, est, ref = _check(t, est, ref)
    return maee(t, est, ref, float(t[-1]) - T_p)


def convergence_time(
    t: np.ndarray,
    est: np.ndarray,
    ref: np.ndarray | float,
    band: float,
    t_start: float | None = None,
    hold: float = 0.0,
) -> float | None:
    """First time after which |δ* − δ̂| stays ≤ ``band`` to the end [s], measured from ``t_start``.

    Parameters
    ----------
    t, est, ref
        Time [s], estimate and truth [rad].
    band : float
        Error band [rad].
    t_start : float, optional
        Only consider samples from this time on and return the time relative to it
        (default: from the first sample, returned as absolute time minus t[0]).
    hold : float
        Minimum time [s] the error must then stay in the band before the last sample; a run
        that enters the band for good later than ``hold`` before its end has not settled.

    Returns
    -------
    float or None
        Convergence time [s]; None (not settled) when the error is outside the band at the
        last sample, or stays inside it for less than ``hold`` before the end.
    """
    t, est, ref = _check(t, est, ref)
    if t.size == 0:
        return None
    t0 = float(t[0]) if t_start is None else float(t_start)
    m = t >= t0
    tt, err = t[m], np.abs(ref[m] - est[m])
    if tt.size == 0 or err[-1] > band:
        return None
    outside = np.nonzero(err > band)[0]
    k = 0 if outside.size == 0 else outside[-1] + 1
    if float(tt[-1] - tt[k]) < hold:
        return None
    return 0.0 if outside.size == 0 else float(tt[k] - t0)
