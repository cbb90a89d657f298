"""Super-twisting sliding-mode observer (STSMO) of a perturbation, spec 01 eqs (16), (19), (21).

Generic form, for any measured velocity ω with a known part of its acceleration::

    dω̂/dt = a_known + v,        ω̃ = ω − ω̂
    v      = k1 |ω̃|^½ sgn ω̃ + k2 ∫ sgn ω̃ dτ,        φ̂ = v

so that φ̂ estimates the unknown part φ = ω̇ − a_known [rad/s²]. For the load side of a
drive train, ``a_known = −T_F,l(ω_l)/J_l`` and ``J_l φ̂`` estimates the shaft torque.

Discretisation (what the kernel does at every sample k, sample time T_s)
-----------------------------------------------------------------------
Explicit (forward) Euler with a zero-order hold of the measurement, i.e. the
standard "one-step" discrete super-twisting algorithm::

    ω̃_k   = ω_k − ω̂_k
    v_k    = k1 √|ω̃_k| sgn ω̃_k + z_k                    (output φ̂_k = v_k)
    ω̂_k+1 = ω̂_k + T_s (a_known,k + v_k)
    z_k+1  = z_k + T_s k2 sgn ω̃_k

The output at sample k uses only measurements up to k (causal, no look-ahead). Euler
discretisation of the sign term chatters: in steady state ω̃ stays in a band of order
(k1 T_s)² and z (hence φ̂) in a band of order k2 T_s — which is why k2 T_s must stay
small against the perturbation one wants to see (k2 T_s ≪ |φ|). The chattering of φ̂
is the main noise source of the adaptive deadzone law; :mod:`drivelash.estimation.deadzone`
low-pass filters the residual built from it in its default method.

State layout (float64 array of length 2): ``[ω̂, z]``; parameter layout (length 3):
``[k1, k2, T_s]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from drivelash.errors import DataError, ParameterError
from drivelash.physics.backlash import sgn

STATE_SIZE = 2


@njit(cache=True)
def stsmo_step(state, omega_meas, known_accel, k1, k2, T_s):
    """Advance the STSMO by one sample, in place.

    Parameters
    ----------
    state : numpy.ndarray
        ``[ω̂, z]`` [rad/s, rad/s²]; updated in place.
    omega_meas : float
        Measured velocity ω_k [rad/s].
    known_accel : float
        Known part of the acceleration a_known,k [rad/s²].
    k1 : float
        Proportional gain [rad^½/s^{3/2}].
    k2 : float
        Integral gain [rad/s³].
    T_s : float
        Sample time [s].

    Returns
    -------
    omega_hat : float
        Velocity estimate ω̂_k before the update [rad/s].
    phi_hat : float
        Perturbation estimate φ̂_k = v_k [rad/s²].
    """
    w_hat = state[0]
    err = omega_meas - w_hat
    s = sgn(err)
    v = k1 * math.sqrt(abs(err)) * s + state[1]
    state[0] = w_hat + T_s * (known_accel + v)
    state[1] = state[1] + T_s * k2 * s
    return w_hat, v


@njit(cache=True)
def stsmo_run(state, omega_meas, known_accel, params):
    """Run the STSMO over a block of samples (explicit state in and out).

    Parameters
    ----------
    state : numpy.ndarray
        ``[ω̂, z]`` at the first sample [rad/s, rad/s²]; not modified.
    omega_meas : numpy.ndarray
        Measured velocity, shape (n,) [rad/s].
    known_accel : numpy.ndarray
        Known acceleration, shape (n,) [rad/s²].
    params : numpy.ndarray
        ``[k1, k2, T_s]``.

    Returns
    -------
    state : numpy.ndarray
        State after the last sample (a new array).
    omega_hat : numpy.ndarray
        ω̂_k, shape (n,) [rad/s].
    phi_hat : numpy.ndarray
        φ̂_k, shape (n,) [rad/s²].
    """
    st = state.copy()
    n = omega_meas.shape[0]
    omega_hat = np.empty(n)
    phi_hat = np.empty(n)
    k1 = params[0]
    k2 = params[1]
    T_s = params[2]
    for i in range(n):
        w, v = stsmo_step(st, omega_meas[i], known_accel[i], k1, k2, T_s)
        omega_hat[i] = w
        phi_hat[i] = v
    return st, omega_hat, phi_hat


@dataclass(frozen=True)
class STSMOParams:
    """Gains of the super-twisting observer.

    Parameters
    ----------
    k1 : float
        Proportional gain [rad^½/s^{3/2}], > 0.
    k2 : float
        Integral gain [rad/s³], > 0.
    T_s : float
        Sample time [s], > 0.
    """

    k1: float
    k2: float
    T_s: float

    def __post_init__(self) -> None:
        for n in ("k1", "k2", "T_s"):
            v = getattr(self, n)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(type(self).__name__, n, f"must be finite and > 0, got {v!r}")

    @classmethod
    def from_rho(cls, rho: float, T_s: float) -> STSMOParams:
        """Gains from a bound ρ on |dφ/dt| [rad/s³] (Levant's rule k2 = 1.1 ρ, k1 = 1.5 √ρ).

        Parameters
        ----------
        rho : float
            Bound on the rate of change of the perturbation [rad/s³].
        T_s : float
            Sample time [s].
        """
        return cls(k1=1.5 * math.sqrt(rho), k2=1.1 * rho, T_s=T_s)

    def as_array(self) -> np.ndarray:
        """``[k1, k2, T_s]`` for :func:`stsmo_run`."""
        return np.array([self.k1, self.k2, self.T_s], dtype=np.float64)


def check_finite_inputs(omega_meas: np.ndarray, known_accel: np.ndarray) -> None:
    """Refuse a non-finite measured velocity or known acceleration: one-line
    :class:`~drivelash.errors.DataError` naming the input and the 0-based sample of its first
    NaN/inf in this call (a NaN would stay in the observer state ``[ω̂, z]`` for good), as
    :func:`drivelash.estimation.deadzone.check_finite` does for the deadzone estimator."""
    from drivelash.estimation.deadzone import nonfinite_message

    for name, a in (("omega_meas", omega_meas), ("known_accel", known_accel)):
        finite = np.isfinite(a)
        if not finite.all():
            i = int(np.argmin(finite))
            raise DataError(nonfinite_message(float(a.flat[i]), i, name, "observer"), column=name)


class SuperTwistingObserver:
    """Stateful wrapper of :func:`stsmo_run` (chunk-able: run block after block).

    Parameters
    ----------
    params : STSMOParams
        Gains and sample time.
    omega0 : float
        Initial velocity estimate ω̂(0) [rad/s].
    phi0 : float
        Initial integral state z(0), i.e. initial perturbation guess [rad/s²].
    """

    def __init__(self, params: STSMOParams, omega0: float = 0.0, phi0: float = 0.0) -> None:
        self.params = params
        self._p = params.as_array()
        self.state = np.array([omega0, phi0], dtype=np.float64)

    def run(
        self, omega_meas: np.ndarray, known_accel: np.ndarray | float = 0.0
    ) -> tuple[np.ndarray, np.ndarray]:
        """Process a block; returns (ω̂ [rad/s], φ̂ [rad/s²]) and keeps the state.

        Parameters
        ----------
        omega_meas : numpy.ndarray
            Measured velocity [rad/s], one value per sample period T_s.
        known_accel : numpy.ndarray or float
            Known part of the acceleration [rad/s²] (scalar or per sample).

        Raises
        ------
        DataError
            A NaN/inf in either input (:func:`check_finite_inputs`); the state is unchanged.
        """
        w = np.ascontiguousarray(omega_meas, dtype=np.float64)
        a = np.broadcast_to(np.asarray(known_accel, dtype=np.float64), w.shape)
        check_finite_inputs(w, a)
        self.state, omega_hat, phi_hat = stsmo_run(self.state, w, np.ascontiguousarray(a), self._p)
        return omega_hat, phi_hat

    def step(self, omega_meas: float, known_accel: float = 0.0) -> tuple[float, float]:
        """Process one sample; returns (ω̂_k [rad/s], φ̂_k [rad/s²]) and keeps the state.

        Parameters
        ----------
        omega_meas : float
            Measured velocity [rad/s].
        known_accel : float
            Known part of the acceleration [rad/s²].

        Raises
        ------
        DataError
            A NaN/inf input (:func:`check_finite_inputs`); the state is unchanged.
        """
        w, a = float(omega_meas), float(known_accel)
        if not (math.isfinite(w) and math.isfinite(a)):
            check_finite_inputs(np.array([w]), np.array([a]))
        p = self._p
        return stsmo_step(self.state, w, a, p[0], p[1], p[2])
