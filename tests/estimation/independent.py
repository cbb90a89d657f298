"""An independent simulator of a drive train with backlash, for the estimator's robustness tests.

Nothing here shares code with :mod:`drivelash.sim` or :mod:`drivelash.physics`, so that the
estimator is not tuned to its own simulator's quirks:

* plant (1)–(4) with the deadzone shaft (10), written out again below; friction
  T_C tanh(ω/ω_reg) + β ω (a tanh regularisation, 1 mrad/s by default, where the project's
  engine uses a Stribeck/static-friction model and RK4 with contact-event location);
* an optional constant external torque ``T_ext`` on the load (gravity on a horizontal arm at
  a fixed angle; the load equation is J_l ω̇_l = T_l − T_F,l − T_ext);
* a *continuous-time* P/PI cascade with velocity feed-forward and a clamped integrator
  (the project's controller is discrete, with a zero-order hold);
* integration by ``scipy.integrate.solve_ivp`` (LSODA, adaptive, rtol 1e-7) over the whole
  run, sampled at ``T_s`` from its dense output;
* sensors applied afterwards: encoder quantisation (truncation by default, as a counter
  reads; ``reading="round"`` for a mid-tread quantiser), white velocity noise, white
  torque noise; optional encoder zero shift of the load, optional unit scaling of the
  recorded columns (degrees).

:func:`simulate_independent` returns a :class:`drivelash.io.trace.Trace` with the measured
columns, ``torque_m`` (the applied torque plus noise) and ``delta_true``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from drivelash.io.trace import Trace
from drivelash.params import DrivetrainParams


@dataclass(frozen=True)
class IndependentDrive:
    """A plant for :func:`simulate_independent` (SI units, load-side δ, δ1)."""

    J_m: float
    J_l: float
    N: float
    K_S: float
    D_S: float
    T_Cm: float
    T_Cl: float
    beta_m: float
    beta_l: float
    delta: float
    delta1: float
    T_ext: float = 0.0

    def drivetrain(self, **scale: float) -> DrivetrainParams:
        """The drive-train parameters as an estimator would be told (``scale`` multiplies fields)."""
        v = {
            k: getattr(self, k) for k in ("J_m", "J_l", "N", "K_S", "D_S", "T_Cm", "T_Cl", "beta_m", "beta_l")
        }
        for k, f in scale.items():
            v[k] = v[k] * f
        return DrivetrainParams(**v)


def draw_plant(rng: np.random.Generator) -> tuple[float, float, float, float, float, float]:
    """The first draws of a random drive in the generalisation test's ranges: N, J_l [kg·m²],
    J_m [kg·m²], ω_n [rad/s] (60–600), K_S = J_l ω_n² [N·m/rad], T_Cl [N·m] (K_S · 1e-4 … 3e-3)."""
    N = float(rng.choice([1, 2, 5, 10]))
    J_l = 10 ** rng.uniform(-4, -2)
    J_m = 10 ** rng.uniform(-4, -3)
    wn = 10 ** rng.uniform(np.log10(60), np.log10(600))
    K_S = J_l * wn**2
    T_Cl = K_S * 10 ** rng.uniform(-4, -2.5)
    return N, J_l, J_m, wn, K_S, T_Cl


def simulate_independent(
    drive: IndependentDrive,
    *,
    duration: float = 30.0,
    T_s: float = 125e-6,
    amplitude: float = 1.0,
    frequency: float = 0.5,
    bandwidth: float = 100.0,
    torque_limit: float = 20.0,
    counts: int = 2048,
    sigma_omega: float = 0.0316,
    sigma_torque: float = 0.0,
    omega_reg: float = 1e-3,
    load_zero_shift: float = 0.0,
    unit: float = 1.0,
    seed: int = 0,
    rtol: float = 1e-7,
    reading: str = "floor",
) -> Trace:
    """Closed-loop run of ``drive`` on θ_r = amplitude·N·sin(2π f t) (motor side).

    Parameters
    ----------
    drive : IndependentDrive
        Plant.
    duration, T_s : float
        Length and sample period [s].
    amplitude : float
        Load-side amplitude of the position reference [rad].
    frequency : float
        Reference frequency [Hz].
    bandwidth : float
        Velocity-loop crossover with the load engaged [rad/s] (P/PI, zero 4× lower,
        position loop a quarter of it).
    torque_limit : float
        Clamp of the motor torque [N·m].
    counts : int
        Encoder counts per revolution, both sides (0 = ideal).
    sigma_omega, sigma_torque : float
        White noise on the recorded velocities [rad/s] and motor torque [N·m].
    omega_reg : float
        Friction regularisation velocity [rad/s].
    load_zero_shift : float
        Added to the recorded load position [rad] (an encoder zero elsewhere).
    unit : float
        Recorded positions and velocities are multiplied by this (``180/π``: degrees).
    seed : int
        Noise seed.
    rtol : float
        solve_ivp relative tolerance.
    reading : {"floor", "round"}
        Encoder reading convention: the start of the count interval the angle lies in
        (truncation, a counter's reading) or its nearest count. With a gear (N ≠ 1) the two
        encoders' counts differ on the load side, so truncation offsets Δθ by
        q/2 · (1 − 1/N) against the true relative angle (q = 2π/counts).
    """
    d = drive
    J = d.J_m + d.J_l / d.N**2
    K_p = bandwidth * J
    T_n = 4.0 / bandwidth
    K_v = bandwidth / 4.0
    w = 2.0 * math.pi * frequency
    A = amplitude * d.N
    lo, hi = -d.delta1, d.delta - d.delta1

    def shaft(dth: float, dom: float) -> float:
        if dth > hi:
            return d.K_S * (dth - hi) + d.D_S * dom
        if dth < lo:
            return d.K_S * (dth - lo) + d.D_S * dom
        return 0.0

    def torque(t: float, y: np.ndarray) -> float:
        w_m, th_m, _, _, x_i = y
        e_w = K_v * (A * math.sin(w * t) - th_m) + A * w * math.cos(w * t) - w_m
        return min(max(K_p * e_w + x_i, -torque_limit), torque_limit)

    def rhs(t: float, y: np.ndarray) -> list[float]:
        w_m, th_m, w_l, th_l, x_i = y
        e_w = K_v * (A * math.sin(w * t) - th_m) + A * w * math.cos(w * t) - w_m
        u_un = K_p * e_w + x_i
        u = min(max(u_un, -torque_limit), torque_limit)
        T = shaft(th_m / d.N - th_l, w_m / d.N - w_l)
        f_m = d.T_Cm * math.tanh(w_m / omega_reg) + d.beta_m * w_m
        f_l = d.T_Cl * math.tanh(w_l / omega_reg) + d.beta_l * w_l
        dx_i = (K_p / T_n) * e_w if u == u_un else 0.0
        return [(u - f_m - T / d.N) / d.J_m, w_m, (T - f_l - d.T_ext) / d.J_l, w_l, dx_i]

    n = int(round(duration / T_s))
    t = np.arange(n) * T_s
    # start at rest with the load resting where the external load pushes it (on a flank)
    th_l0 = -(d.delta - d.delta1) if d.T_ext > 0 else (d.delta1 if d.T_ext < 0 else 0.0)
    th_l0 -= d.T_ext / d.K_S if d.T_ext else 0.0
    y0 = [0.0, 0.0, 0.0, th_l0, d.T_ext / d.N]
    sol = solve_ivp(
        rhs, (0.0, t[-1]), y0, method="LSODA", t_eval=t, rtol=rtol, atol=1e-10, max_step=0.2 / frequency
    )
    if not sol.success:  # pragma: no cover - a broken test set-up
        raise RuntimeError(sol.message)
    w_m, th_m, w_l, th_l, x_i = sol.y
    u = np.array([torque(tk, sol.y[:, k]) for k, tk in enumerate(t)])
    rng = np.random.default_rng(seed)

    def quant(x: np.ndarray) -> np.ndarray:
        if counts <= 0:
            return x
        q = 2.0 * math.pi / counts
        return (np.floor(x / q) if reading == "floor" else np.round(x / q)) * q

    cols = {
        "t": t,
        "theta_m": unit * quant(th_m),
        "omega_m": unit * (w_m + sigma_omega * rng.standard_normal(n)),
        "theta_l": unit * (quant(th_l) + load_zero_shift),
        "omega_l": unit * (w_l + sigma_omega * rng.standard_normal(n)),
        "torque_m": u + sigma_torque * rng.standard_normal(n),
        "delta_true": np.full(n, d.delta),
    }
    return Trace(cols, {"simulator": "independent (solve_ivp LSODA, continuous P/PI)"})


#: The bench rig of spec 01 §4 as an independent plant (deadzone B).
RIG = IndependentDrive(
    J_m=8.31e-4,
    J_l=8.31e-4,
    N=1.0,
    K_S=32.94,
    D_S=0.0548,
    T_Cm=0.0223,
    T_Cl=0.0232,
    beta_m=0.0016,
    beta_l=0.0016,
    delta=0.186,
    delta1=0.093,
)
