"""Position-loop transfer functions of spec 02 §2 (eqs 2–3) and path-error prediction.

    G_pc,OL(s) = x_T/x_d |_(TE=0) = K_v K_p (T_n s + 1) / ( s (J_s T_n s² + K_p T_n s + K_p) )     (2)
    G_d,CL(s)  = e_x / TE = −( a s³ + T_n s² + s ) / ( a s³ + T_n s² + (1 + K_v T_n) s + K_v ),
                 a = J_s T_n / K_p                                                                 (3)

with e_x = x_d − x_T the path (following) error and TE = x_T − x_M an output
disturbance. (2) is the open loop of the position control (P position controller,
PI velocity loop on J_s, ideal current loop); (3) follows from it as
−1/(1 + G_pc,OL) and is high-pass: tooth-meshing errors pass, drift is suppressed.

Functions
---------
``g_pc_ol(J_s, gains)``, ``g_d_cl(J_s, gains)``: :class:`control.TransferFunction`;
``g_pc_ol_closed_form`` / ``g_d_cl_closed_form``: the same evaluated directly (for tests);
``predict_path_error(te, t, J_s, gains)``: e_x(t) predicted from a TE time series;
The Bode plot of both is :func:`drivelash.report.te_figures.bode_figure`.
"""

from __future__ import annotations

import numpy as np

from drivelash.errors import DataError
from drivelash.params import CascadeGains


def g_pc_ol(J_s: float, gains: CascadeGains):  # noqa: ANN201 - control.TransferFunction
    """Open-loop position-control transfer function (2) as a python-control object.

    Parameters
    ----------
    J_s : float
        Combined inertia at the motor [kg·m²].
    gains : CascadeGains
        K_v [1/s], K_p [N·m·s/rad], T_n [s].
    """
    import control

    Kv, Kp, Tn = gains.K_v, gains.K_p, gains.T_n
    return control.tf([Kv * Kp * Tn, Kv * Kp], [J_s * Tn, Kp * Tn, Kp, 0.0])


def g_d_cl(J_s: float, gains: CascadeGains):  # noqa: ANN201 - control.TransferFunction
    """Closed-loop TE → path-error transfer function (3) as a python-control object."""
    import control

    Kv, Kp, Tn = gains.K_v, gains.K_p, gains.T_n
    a = J_s * Tn / Kp
    return control.tf([-a, -Tn, -1.0, 0.0], [a, Tn, 1.0 + Kv * Tn, Kv])


def g_pc_ol_closed_form(s: np.ndarray, J_s: float, gains: CascadeGains) -> np.ndarray:
    """Eq (2) evaluated directly at complex frequencies ``s`` [rad/s]."""
    Kv, Kp, Tn = gains.K_v, gains.K_p, gains.T_n
    s = np.asarray(s, dtype=complex)
    return Kv * Kp * (Tn * s + 1) / (s * (J_s * Tn * s**2 + Kp * Tn * s + Kp))


def g_d_cl_closed_form(s: np.ndarray, J_s: float, gains: CascadeGains) -> np.ndarray:
    """Eq (3) evaluated directly at complex frequencies ``s`` [rad/s]."""
    Kv, Tn, Kp = gains.K_v, gains.T_n, gains.K_p
    s = np.asarray(s, dtype=complex)
    a = J_s * Tn / Kp
    return -(a * s**3 + Tn * s**2 + s) / (a * s**3 + Tn * s**2 + (1 + Kv * Tn) * s + Kv)


def predict_path_error(
    te: np.ndarray, t: np.ndarray, J_s: float, gains: CascadeGains, remove_initial: bool = True
) -> np.ndarray:
    """Path error e_x = x_d − x_T predicted by (3) from a TE time series.

    Parameters
    ----------
    te : numpy.ndarray
        Transmission error along the run, TE(x_T(t)) [m] (measured as x_T − x_M, or
        the TE model evaluated at the table positions).
    t : numpy.ndarray
        Sample times [s], uniformly spaced.
    J_s : float
        Combined inertia [kg·m²].
    gains : CascadeGains
        Loop gains.
    remove_initial : bool
        Subtract te[0] first (the loop is at rest with zero error at t[0]; a constant
        TE gives no path error because (3) has a zero at s = 0).

    Returns
    -------
    numpy.ndarray
        Predicted e_x(t) [m] (Tustin discretisation of (3) at the sample rate of ``t``).

    Raises
    ------
    DataError
        ``te`` and ``t`` not 1-D of one length ≥ 2, or ``t`` not uniformly spaced.
    """
    from scipy import signal

    te = np.asarray(te, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    if te.shape != t.shape or te.ndim != 1:
        raise DataError("te and t must be 1-D arrays of equal length", column="te")
    if t.size < 2:
        raise DataError("need at least two samples", column="t")
    steps = np.diff(t)
    if np.ptp(steps) > 1e-6 * steps.mean():
        raise DataError("samples must be uniformly spaced", column="t")
    Kv, Kp, Tn = gains.K_v, gains.K_p, gains.T_n
    a = J_s * Tn / Kp
    u = te - te[0] if remove_initial else te
    # bilinear (Tustin) discretisation of (3) in zero-pole-gain form, run as second-order sections
    z, p, k = signal.tf2zpk([-a, -Tn, -1.0, 0.0], [a, Tn, 1.0 + Kv * Tn, Kv])
    zd, pd, kd = signal.bilinear_zpk(z, p, k, fs=1.0 / float(steps.mean()))
    return signal.sosfilt(signal.zpk2sos(zd, pd, kd), u)
