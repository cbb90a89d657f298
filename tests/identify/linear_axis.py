"""A two-mass linear (prismatic) axis with lost motion, simulated for the identification tests.

An independent simulator (numba, no drivelash code) after the exploratory tester's ``sim_lin.py``
(session 34, finding G1): a 20 kg carriage driving a 100 kg table through a 2e7 N/m coupling with a
gap δ, Coulomb and viscous friction on both masses, a cascade position-P / velocity-PI controller
on the motor side and a sine reference. The sensors are a 0.1 µm motor encoder, a 0.05 µm linear
scale and velocities with 2e-5 m/s white noise. Numbers in SI (m, m/s, N): the recording a
linear-axis user gives ``identify``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from drivelash.io.trace import Trace

#: The simulated drive: masses [kg], stiffness [N/m], damping [N·s/m], Coulomb [N], viscous [N·s/m].
TRUTH = {
    "J_m": 20.0,
    "J_l": 100.0,
    "K_S": 2e7,
    "D_S": 2000.0,
    "T_Cm": 20.0,
    "T_Cl": 60.0,
    "beta_m": 50.0,
    "beta_l": 300.0,
}


@njit(cache=True)
def _run(T, fs, nsub, mm, ml, k, d, delta, delta1, Fcm, Fcl, bm, bl, A, f, Kv, Kp, Ti):  # pragma: no cover
    n = int(T * fs)
    h = 1.0 / fs / nsub
    xm = 0.0
    vm = 0.0
    xl = 0.0
    vl = 0.0
    integ = 0.0
    out = np.zeros((n, 6))
    for i in range(n):
        t = i / fs
        out[i, 0] = t
        out[i, 1] = xm
        out[i, 2] = vm
        out[i, 3] = xl
        out[i, 4] = vl
        xr = A * np.sin(2 * np.pi * f * t)
        vcmd = Kv * (xr - xm) + A * 2 * np.pi * f * np.cos(2 * np.pi * f * t)
        e = vcmd - vm
        integ += e / fs
        F = Kp * (e + integ / Ti)
        out[i, 5] = F
        for _ in range(nsub):
            dx = xm - xl
            dv = vm - vl
            if dx < -delta1:
                Fs = k * (dx + delta1) + d * dv
            elif dx > delta - delta1:
                Fs = k * (dx + delta1 - delta) + d * dv
            else:
                Fs = 0.0
            am = (F - Fs - Fcm * np.tanh(vm / 1e-4) - bm * vm) / mm
            al = (Fs - Fcl * np.tanh(vl / 1e-4) - bl * vl) / ml
            vm += h * am
            vl += h * al
            xm += h * vm
            xl += h * vl
    return out


def linear_axis_trace(
    delta: float = 20e-6, delta1: float = 10e-6, duration: float = 3.0, freq: float = 1.0, seed: int = 0
) -> Trace:
    """A recording of the linear axis in SI units, ``meta["axis"] = "prismatic"``.

    Parameters
    ----------
    delta, delta1 : float
        Gap and its lower flank [m].
    duration : float
        Length [s] (8 kHz).
    freq : float
        Frequency of the ±10 mm sine reference [Hz] (the gap is crossed twice per period).
    seed : int
        Seed of the velocity noise.
    """
    p = TRUTH
    fs = 8000.0
    out = _run(duration, fs, 20, p["J_m"], p["J_l"], p["K_S"], p["D_S"], delta, delta1, p["T_Cm"], p["T_Cl"],
               p["beta_m"], p["beta_l"], 0.01, freq, 30.0, 12000.0, 0.02)  # fmt: skip
    rng = np.random.default_rng(seed)
    t, xm, vm, xl, vl, F = out.T
    cols = {
        "t": t,
        "theta_m": np.round(xm / 1e-7) * 1e-7,
        "omega_m": vm + rng.normal(0.0, 2e-5, t.size),
        "theta_l": np.round(xl / 5e-8) * 5e-8,
        "omega_l": vl + rng.normal(0.0, 2e-5, t.size),
        "torque_m": F,
    }
    return Trace(cols, {"axis": "prismatic", "source": "linear_axis_trace"})


def as_rotary(trace: Trace, k: float = 1e3) -> Trace:
    """The same recording with its positions and velocities ×``k`` declared as an angle (rad): the
    tester's "mm columns read as rad". Same physics, so the identification must scale exactly:
    masses, stiffness, damping and viscous friction /k, the gap ×k, forces unchanged."""
    cols = {n: np.asarray(trace[n]) * (k if n.startswith(("theta", "omega")) else 1.0) for n in trace.names}
    return Trace(cols, {"axis": "rotary", "source": "linear_axis_trace ×1e3 as rad"})
