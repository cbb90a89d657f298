"""Sensor model: encoder quantisation, white noise, measured or differentiated velocity.

Per sample k (period T_s):

* positions: θ_q = q · round(θ/q) with q = 2π / counts (mid-tread quantiser, i.e. the
  error is uniform in [−q/2, q/2] and zero-mean), then + N(0, σ_θ²);
  counts = 0 means no quantisation;
* velocities, ``"measured"``: ω + N(0, σ_ω²) (as a drive reports its speed signal);
  ``"differentiated"``: (θ_q[k] − θ_q[k−1]) / T_s from the quantised, noisy position
  (0 at the first sample), no extra noise;
* torque: u + N(0, σ_T²).

Noise is drawn outside the kernel from ``numpy.random.default_rng(seed)`` in blocks
(:func:`draw_noise`), so a run is reproducible for a seed and a chunked run equals one run.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from drivelash.params import SensorParams

#: Layout of the sensor parameter array.
SENS_FIELDS = (
    "counts_m",
    "counts_l",
    "sigma_theta_m",
    "sigma_theta_l",
    "sigma_omega_m",
    "sigma_omega_l",
    "sigma_torque",
    "differentiated",
)
S_COUNTS_M, S_COUNTS_L, S_SIG_TH_M, S_SIG_TH_L, S_SIG_OM_M, S_SIG_OM_L, S_SIG_T, S_DIFF = range(8)

#: Noise columns (standard normal draws): θ_m, θ_l, ω_m, ω_l, torque.
N_NOISE = 5
NOISE_THETA_M, NOISE_THETA_L, NOISE_OMEGA_M, NOISE_OMEGA_L, NOISE_TORQUE = range(N_NOISE)


def sensor_params_array(sensors: SensorParams) -> np.ndarray:
    """Pack :class:`SensorParams` for the kernels (layout :data:`SENS_FIELDS`)."""
    return np.array(
        [
            sensors.counts_m,
            sensors.counts_l,
            sensors.sigma_theta_m,
            sensors.sigma_theta_l,
            sensors.sigma_omega_m,
            sensors.sigma_omega_l,
            sensors.sigma_torque,
            1.0 if sensors.velocity_source == "differentiated" else 0.0,
        ],
        dtype=np.float64,
    )


def needs_noise(sensors: SensorParams) -> bool:
    """True if any noise standard deviation is non-zero."""
    return any(
        getattr(sensors, n) > 0
        for n in (
            "sigma_theta_m",
            "sigma_theta_l",
            "sigma_omega_m",
            "sigma_omega_l",
            "sigma_torque",
        )
    )


def draw_noise(rng: np.random.Generator, n: int, enabled: bool = True) -> np.ndarray:
    """``(n, N_NOISE)`` standard-normal draws (zeros when ``enabled`` is False)."""
    if not enabled:
        return np.zeros((n, N_NOISE))
    return rng.standard_normal((n, N_NOISE))


@njit(cache=True)
def quantise_scalar(theta, counts):
    """Mid-tread encoder quantisation of ``theta`` [rad] to ``counts`` per revolution (0 = none)."""
    if counts <= 0.0:
        return theta
    q = 2.0 * math.pi / counts
    return q * np.round(theta / q)


def quantise(theta: np.ndarray, counts: int) -> np.ndarray:
    """Array form of :func:`quantise_scalar` [rad]."""
    if counts <= 0:
        return np.asarray(theta, dtype=np.float64).copy()
    q = 2.0 * math.pi / counts
    return q * np.round(np.asarray(theta, dtype=np.float64) / q)
