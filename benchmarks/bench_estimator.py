"""Throughput of the online deadzone estimator (default law) on a 10-minute 8 kHz trace.

Compares, in one run:

* the ``@njit`` kernel streaming the trace in blocks of 65 536 samples into a reused output
  buffer (how an online estimator runs), and the same kernel on the whole trace at once
  (its output array of 4.8 M × 8 floats is allocated and first touched inside the timing);
* a straightforward per-sample NumPy/Python implementation of the same law
  (:class:`NumpyDeadzoneEstimator` below: NumPy arrays for the gain matrix, ``np.arctan``
  etc.), timed on a 20 000-sample slice and scaled linearly to the full trace — it runs at a
  constant cost per sample, so the scaling is exact up to timer noise. Its δ̂ is checked
  against the kernel's on that slice first (same law, not just similar speed).

Times are CPU time of this process (``time.process_time``) — "one core" — and wall time;
both are printed, with the machine's load average, because other jobs may share the cores.
Goals (issue 3): ≥ 20 M samples/s on one core (≥ 2500× real time at 8 kHz) and ≥ 100× the
baseline.

Run: ``make bench`` or ``.venv/bin/python benchmarks/bench_estimator.py``.
"""

from __future__ import annotations

import math
import os
import time

import numpy as np

from drivelash.estimation import deadzone as dz
from drivelash.estimation.estimator import INPUT_COLUMNS, DeadzoneEstimator
from drivelash.estimation.reproduce import estimator_for
from drivelash.sim.scenarios import get_scenario

DURATION_S = 600.0  # 10 minutes at 8 kHz = 4.8 M samples
BLOCK = 1 << 16
BASELINE_SLICE = 20_000
REPEATS = 3


class NumpyDeadzoneEstimator:
    """Per-sample NumPy/Python implementation of the default law (the baseline).

    Written from the equations (module docstring of :mod:`drivelash.estimation.deadzone`),
    not from the kernel: complementary filter on Δθ, STSMO, model (12) and sensitivity (50)
    with two ``np.arctan``, filtered residual/regressor, least squares with leakage and
    gain reset on θ = [δ, κ], projection (65), σ ring buffer.
    """

    def __init__(self, params: np.ndarray) -> None:
        self.p = params
        p = params
        self.W = int(p[dz.P_WINDOW])
        self.ring = np.zeros(self.W)
        self.ring_i = 0
        self.sig_sum = 0.0
        self.w_hat = 0.0
        self.z = 0.0
        self.delta = 0.0
        self.kappa = 1.0
        self.x_pred = None
        self.ef = 0.0
        self.hf = np.zeros(2)
        self.P = np.diag([p[dz.P_P0], p[dz.P_P0 + 1]])
        self.P0 = self.P.copy()
        self.tqf = 0.0
        self.reset_timer = 0.0

    def step(self, theta_m: float, omega_m: float, theta_l: float, omega_l: float) -> float:
        p = self.p
        T_s, N, J_l, K_S, D_S = p[dz.P_TS], p[dz.P_N], p[dz.P_J_L], p[dz.P_K_S], p[dz.P_D_S]
        d1, a = p[dz.P_DELTA1], p[dz.P_ALPHA]
        dth_meas = theta_m / N - theta_l
        dom = omega_m / N - omega_l
        c = 1.0 - np.exp(-p[dz.P_OMEGA_C] * T_s)
        x = dth_meas if self.x_pred is None else self.x_pred
        x = x + c * (dth_meas - x)
        self.x_pred = x + T_s * dom
        dth = x
        sg = np.sign(omega_l)
        err = omega_l - self.w_hat
        s = np.sign(err)
        phi = p[dz.P_K1] * np.sqrt(abs(err)) * s + self.z
        w_prev = self.w_hat
        self.w_hat = w_prev + T_s * (-(p[dz.P_T_CL] * sg + p[dz.P_BETA_L] * omega_l) / J_l + phi)
        self.z += T_s * p[dz.P_K2] * s
        d = self.delta
        B = np.pi + np.arctan(a * (dth - d + d1)) - np.arctan(a * (dth + d1))
        arg = dth + d1 - 0.5 * d * (1 + np.sign(dth)) + D_S / K_S * dom
        T_hat = arg * K_S / np.pi * B
        chi1 = 0.5 * (1 + np.sign(dth)) * B
        chi2 = arg * a / (1 + (a * (dth + d1 - d)) ** 2)
        g = -(chi1 + chi2) / np.pi
        T_meas = J_l * phi
        thr = p[dz.P_T_THR]
        gate = 0.0
        if (
            self.tqf * T_hat > 0
            and abs(self.tqf) > thr
            and abs(T_hat) > thr
            and 0.5 < self.tqf / (self.kappa * T_hat) < 2.0
        ):
            gate = 1.0
        h = np.array([self.kappa * g, T_hat / K_S * gate])
        e = T_meas / K_S - self.kappa * T_hat / K_S
        af = 1.0 - np.exp(-T_s / p[dz.P_TAU_F])
        self.ef += af * (e - self.ef)
        self.hf += af * (h - self.hf)
        if p[dz.P_RESET_E] > 0:  # gain reset on a persistent residual
            big = abs(self.ef) > p[dz.P_RESET_E] * p[dz.P_THETA_DEF] and self.hf[0] ** 2 > 0.25
            self.reset_timer = self.reset_timer + T_s if big else 0.0
            if self.reset_timer > p[dz.P_RESET_T]:
                self.reset_timer = 0.0
                self.P = self.P0.copy()
        Ph = self.P @ self.hf
        eps, dmax = p[dz.P_EPS_DELTA], p[dz.P_DELTA_MAX]
        tau = Ph[0] * self.ef
        hh = ((eps + 1) * d * d - dmax**2) / (eps * dmax**2)
        rate = tau if (hh < 0 or 2 * (eps + 1) * d * tau <= 0) else tau * (1 - hh)
        self.kappa = float(np.clip(self.kappa + T_s * Ph[1] * self.ef, 0.25, 4.0))
        self.P = self.P + T_s * p[dz.P_LAMBDA] * (self.P0 - self.P) - T_s * np.outer(Ph, Ph)
        self.delta = float(np.clip(d + T_s * rate, 0.0, dmax))
        aq = 1.0 - np.exp(-T_s / max(p[dz.P_TAU_F], 2e-3))
        self.tqf += aq * (T_meas - self.tqf)
        self.sig_sum += g * g - self.ring[self.ring_i]
        self.ring[self.ring_i] = g * g
        self.ring_i = (self.ring_i + 1) % self.W
        return self.delta


def _timed(fn) -> tuple[float, float]:
    """Best (CPU, wall) seconds of ``REPEATS`` calls."""
    best_c, best_w = math.inf, math.inf
    for _ in range(REPEATS):
        c0, w0 = time.process_time(), time.perf_counter()
        fn()
        best_c = min(best_c, time.process_time() - c0)
        best_w = min(best_w, time.perf_counter() - w0)
    return best_c, best_w


def main() -> None:
    sc = get_scenario("bench-0B")
    trace = sc.simulate(duration=DURATION_S)
    x = np.ascontiguousarray(np.column_stack([trace[c] for c in INPUT_COLUMNS]))
    n = x.shape[0]
    est: DeadzoneEstimator = estimator_for(sc, "default")
    p = est.params
    s0 = dz.initial_state(p)
    out = np.empty((BLOCK, dz.N_OUT))
    dz.deadzone_run_into(s0, x[:BLOCK], p, out)  # compile / load cache outside the timing

    def stream() -> None:
        st = s0
        for a in range(0, n, BLOCK):
            blk = x[a : a + BLOCK]
            st = dz.deadzone_run_into(st, blk, p, out[: blk.shape[0]])

    def whole() -> None:
        dz.deadzone_run(s0, x, p)

    c_stream, w_stream = _timed(stream)
    c_whole, w_whole = _timed(whole)

    # baseline: same law, per sample, NumPy/Python; check it first
    xs = x[:BASELINE_SLICE]
    _, ref = dz.deadzone_run(s0, xs, p)
    base = NumpyDeadzoneEstimator(p)
    c0, w0 = time.process_time(), time.perf_counter()
    d_base = np.array([base.step(*row) for row in xs])
    c_base = (time.process_time() - c0) * n / BASELINE_SLICE
    w_base = (time.perf_counter() - w0) * n / BASELINE_SLICE
    agree = float(np.max(np.abs(d_base - ref[:, dz.O_DELTA])))

    fs = 1.0 / sc.T_s
    load = os.getloadavg()[0]
    print(
        f"trace: {sc.name}, {DURATION_S:.0f} s at {fs:.0f} Hz = {n / 1e6:.2f} M samples; "
        f"load average {load:.1f}"
    )
    print(f"baseline agrees with the kernel on {BASELINE_SLICE} samples: max |Δδ̂| = {agree:.2e} rad")
    rows = [
        ("kernel, streaming 64 k blocks", c_stream, w_stream),
        ("kernel, whole trace (+ output allocation)", c_whole, w_whole),
        (f"NumPy/Python baseline (scaled from {BASELINE_SLICE})", c_base, w_base),
    ]
    print(f"{'':46s} {'CPU s':>8s} {'M samp/s':>9s} {'x real':>8s} {'wall s':>8s} {'M samp/s':>9s}")
    for name, c, w in rows:
        print(f"{name:46s} {c:8.3f} {n / c / 1e6:9.2f} {n / fs / c:8.0f} {w:8.3f} {n / w / 1e6:9.2f}")
    speed = n / c_stream / 1e6
    ratio = c_base / c_stream
    print(f"speed-up vs baseline (CPU time): {ratio:.0f}x (streaming), {c_base / c_whole:.0f}x (whole trace)")
    ok1 = speed >= 20.0
    ok2 = ratio >= 100.0
    print(f"goal >= 20 M samples/s on one core: {'met' if ok1 else 'NOT met'} ({speed:.1f})")
    print(f"goal >= 100x baseline: {'met' if ok2 else 'NOT met'} ({ratio:.0f}x)")
    if agree > 1e-9:
        raise SystemExit(f"baseline and kernel disagree by {agree:.3g} rad — not the same law")


if __name__ == "__main__":
    main()
