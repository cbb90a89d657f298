"""Throughput of the online deadzone estimator (default law) on a 10-minute 8 kHz trace.

Compares, in one run:

* the ``@njit`` kernel streaming the trace in blocks of 65 536 samples into a reused output
  buffer (how an online estimator runs), and the same kernel on the whole trace at once
  (its output array of 4.8 M × 9 floats is allocated and first touched inside the timing);
* two baselines a competent user would write for the same law from its equations, both
  from one source (:func:`plain_loop` below: one function, scalar state, constants hoisted):
  the **plain @njit loop** (``numba.njit`` of it, on the whole trace) and the **NumPy/Python
  loop, constants hoisted** (the same function in the interpreter with :mod:`math` on
  Python floats), timed on a 20 000-sample slice and scaled linearly to the full trace — it
  runs at a constant cost per sample, so the scaling is exact up to timer noise.

Each baseline's δ̂ is checked against the kernel's (≤ 1e-12 rad, else the run fails: the same law, not
just a similar speed): the @njit loop on the whole trace, the Python loop on the slice.

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
from numba import njit

from drivelash.estimation import deadzone as dz
from drivelash.estimation.estimator import INPUT_COLUMNS, DeadzoneEstimator
from drivelash.estimation.reproduce import estimator_for
from drivelash.sim.scenarios import get_scenario

DURATION_S = 600.0  # 10 minutes at 8 kHz = 4.8 M samples
BLOCK = 1 << 16
BASELINE_SLICE = 20_000
REPEATS = 3
#: agreement required between each baseline's δ̂ and the kernel's [rad] (rounding only)
AGREE_TOL = 1e-12


def plain_loop(theta_m, omega_m, theta_l, omega_l, p, ring, out):  # noqa: PLR0915
    """δ̂ of the default law, per sample, scalar state: the baseline a competent user writes.

    Written from the equations (module docstring of :mod:`drivelash.estimation.deadzone`)
    for the configuration the benchmark runs (load observer, known δ1, θ = [δ, κ]):
    complementary filter on Δθ, STSMO on ω_l, model (12) with the two ``atan`` of (11) and
    sensitivity (50), gap-learnt torque offsets, κ gate, filtered residual/regressor,
    normalised least squares with leakage and gain reset, projection (65), contact bound,
    σ ring buffer. Constants (filter coefficients, P0, reciprocals) are computed once,
    before the loop. It does less than the kernel (no traversal monitor, no verdict
    accumulators, one output column instead of nine), so the ratios are conservative.

    The same source runs twice: compiled with ``numba.njit`` on NumPy arrays (the "plain
    @njit loop") and in the interpreter on Python lists with :mod:`math` (the "NumPy/Python
    loop, constants hoisted"; a NumPy user keeps scalars out of arrays in a per-sample loop).

    Parameters
    ----------
    theta_m, omega_m, theta_l, omega_l : sequence of float
        Motor and load positions [rad] and velocities [rad/s] at T_s.
    p : sequence of float
        Parameter array of :func:`drivelash.estimation.estimator.build_params` (raw entries only).
    ring : sequence of float
        W zeros: σ ring buffer.
    out : sequence of float
        Receives δ̂ [rad] after each sample.
    """
    # constants, hoisted
    J_l, N, K_S, D_S = p[dz.P_J_L], p[dz.P_N], p[dz.P_K_S], p[dz.P_D_S]
    T_cl, beta_l, delta1, alpha = p[dz.P_T_CL], p[dz.P_BETA_L], p[dz.P_DELTA1], p[dz.P_ALPHA]
    k1, k2, d_max, eps, T_s = p[dz.P_K1], p[dz.P_K2], p[dz.P_DELTA_MAX], p[dz.P_EPS_DELTA], p[dz.P_TS]
    tau_f, lam, thr, theta_def = p[dz.P_TAU_F], p[dz.P_LAMBDA], p[dz.P_T_THR], p[dz.P_THETA_DEF]
    est_k, reset_e, reset_t = p[dz.P_EST_K], p[dz.P_RESET_E], p[dz.P_RESET_T]
    lam_g, omega_g, gap_m, bound = p[dz.P_LAM_G], p[dz.P_OMEGA_G], p[dz.P_GAP_M], p[dz.P_BOUND]
    W = len(ring)
    c_pos = 1.0 - math.exp(-p[dz.P_OMEGA_C] * T_s)
    a_f = 1.0 - math.exp(-T_s / tau_f)
    a_q = 1.0 - math.exp(-T_s / max(tau_f, 2e-3))
    P0_d = p[dz.P_P_MAX]
    P0_k = p[dz.P_Q_AUX] * P0_d / (theta_def * theta_def)
    proj_den = eps * d_max * d_max
    # state
    xhat = dth_min = dth_max = w_hat = z_s = delta = ef = f0 = f1 = 0.0
    tqf = gap_t = f_p = f_n = reset_timer = sig_sum = 0.0
    kappa = 1.0
    P00, P01, P11 = P0_d, 0.0, P0_k
    idx = 0
    for k in range(len(out)):
        # relative coordinates and complementary filter
        dth_meas = theta_m[k] / N - theta_l[k]
        dom = omega_m[k] / N - omega_l[k]
        if k == 0:
            xhat = dth_min = dth_max = dth_meas
        xhat = xhat + c_pos * (dth_meas - xhat)
        dth = xhat
        xhat = xhat + T_s * dom
        dth_min = min(dth_min, dth)
        dth_max = max(dth_max, dth)
        # STSMO on ω_l
        w_l = omega_l[k]
        sg = 1.0 if w_l > 0.0 else (-1.0 if w_l < 0.0 else 0.0)
        err = w_l - w_hat
        s = 1.0 if err > 0.0 else (-1.0 if err < 0.0 else 0.0)
        phi = k1 * math.sqrt(abs(err)) * s + z_s
        w_hat = w_hat + T_s * (-(T_cl * sg + beta_l * w_l) / J_l + phi)
        z_s = z_s + T_s * k2 * s
        T_raw = J_l * phi
        # model torque (12), sensitivity (50)
        zz = alpha * (dth - delta + delta1)
        B = math.pi + math.atan(zz) - math.atan(alpha * (dth + delta1))
        pos = 1.0 if dth > 0.0 else (0.0 if dth < 0.0 else 0.5)
        arg = dth + delta1 - delta * pos + D_S / K_S * dom
        T_hat = arg * K_S / math.pi * B
        g = -(pos * B + arg * alpha / (1.0 + zz * zz)) / math.pi
        # filtered shaft torque, torque offsets learnt in the gap
        tqf = tqf + a_q * (T_raw - tqf)
        m = max(gap_m * delta, 3.0 * theta_def)
        if -delta1 + m < dth < delta - delta1 - m:
            gap_t += T_s
        else:
            gap_t = 0.0
        if gap_t > 3.0 * tau_f:
            if w_l > omega_g:
                f_p += lam_g * T_s * (tqf - f_p)
            elif w_l < -omega_g:
                f_n += lam_g * T_s * (tqf - f_n)
        sp = 0.5 * (1.0 + math.tanh(w_l / omega_g))
        f_hat = sp * f_p + (1.0 - sp) * f_n
        T_meas = T_raw - f_hat
        tq = tqf - f_hat
        # regressor [κ g, T_hat/K_S (gated)], residual, first-order filter
        gate = 0.0
        if tq * T_hat > 0.0 and abs(tq) > thr and abs(T_hat) > thr and 0.5 < tq / (kappa * T_hat) < 2.0:
            gate = est_k
        e = T_meas / K_S - kappa * T_hat / K_S
        ef = ef + a_f * (e - ef)
        f0 = f0 + a_f * (kappa * g - f0)
        f1 = f1 + a_f * (T_hat / K_S * gate - f1)
        # gain reset on a persistent residual
        if reset_e > 0.0:
            if abs(ef) > reset_e * theta_def and f0 * f0 > 0.25:
                reset_timer += T_s
            else:
                reset_timer = 0.0
            if reset_timer > reset_t:
                reset_timer = 0.0
                P00, P01, P11 = P0_d, 0.0, P0_k
        # normalised least squares with leakage, projection (65) on δ
        ph0 = P00 * f0 + P01 * f1
        ph1 = P01 * f0 + P11 * f1
        inv_den = 1.0 / (1.0 + T_s * (f0 * ph0 + f1 * ph1))
        tau = ph0 * ef * inv_den
        h = ((eps + 1.0) * delta * delta - d_max * d_max) / proj_den
        rate = tau if (h < 0.0 or delta * tau <= 0.0) else tau * (1.0 - h)
        kappa = min(max(kappa + T_s * ph1 * ef * inv_den, 0.25), 4.0)
        c = T_s * inv_den
        P00, P01, P11 = (
            P00 + lam * T_s * (P0_d - P00) - c * ph0 * ph0,
            P01 - lam * T_s * P01 - c * ph0 * ph1,
            P11 + lam * T_s * (P0_k - P11) - c * ph1 * ph1,
        )
        delta = delta + T_s * rate
        # contact bound, hard bounds
        if bound > 0.5 and tq > 2.0 * thr and delta - delta1 > dth_max:
            delta = dth_max + delta1
        delta = min(max(delta, 0.0), d_max)
        # σ window
        sig_sum += g * g - ring[idx]
        ring[idx] = g * g
        idx = idx + 1 if idx + 1 < W else 0
        out[k] = delta
    return sig_sum * T_s


plain_njit = njit(plain_loop)


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

    for flag, name in ((dz.P_EST_D1, "estimate_offset"), (dz.P_TSRC, "motor torque source")):
        if p[flag] > 0.5 or p[dz.P_METHOD] < 0.5 or p[dz.P_OMEGA_EPS] > 0.0 or p[dz.P_OMEGA_C] <= 0.0:
            raise SystemExit(f"baseline written for the default law without {name}; config differs")
    W = int(p[dz.P_WINDOW])
    cols = [np.ascontiguousarray(x[:, j]) for j in range(4)]
    d_njit = np.empty(n)
    plain_njit(*[c[:BLOCK] for c in cols], p, np.zeros(W), d_njit[:BLOCK])  # compile

    def baseline_njit() -> None:
        plain_njit(*cols, p, np.zeros(W), d_njit)

    c_njit, w_njit = _timed(baseline_njit)

    # agreement with the kernel: @njit loop on the whole trace, Python loop on the slice
    _, ref = dz.deadzone_run(s0, x, p)
    agree_njit = float(np.max(np.abs(d_njit - ref[:, dz.O_DELTA])))
    lists = [c[:BASELINE_SLICE].tolist() for c in cols]
    d_py = [0.0] * BASELINE_SLICE
    p_list = p.tolist()
    c0, w0 = time.process_time(), time.perf_counter()
    plain_loop(*lists, p_list, [0.0] * W, d_py)
    c_py = (time.process_time() - c0) * n / BASELINE_SLICE
    w_py = (time.perf_counter() - w0) * n / BASELINE_SLICE
    agree_py = float(np.max(np.abs(np.array(d_py) - ref[:BASELINE_SLICE, dz.O_DELTA])))

    fs = 1.0 / sc.T_s
    load = os.getloadavg()
    print(
        f"trace: {sc.name}, {DURATION_S:.0f} s at {fs:.0f} Hz = {n / 1e6:.2f} M samples; "
        f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} ({os.cpu_count()} cores)"
    )
    print(f"plain @njit loop agrees with the kernel on {n} samples: max |Δδ̂| = {agree_njit:.2e} rad")
    print(
        f"NumPy/Python loop agrees with the kernel on {BASELINE_SLICE} samples: max |Δδ̂| = {agree_py:.2e} rad"
    )
    rows = [
        ("kernel, streaming 64 k blocks", c_stream, w_stream),
        ("kernel, whole trace (+ output allocation)", c_whole, w_whole),
        ("baseline: plain @njit loop", c_njit, w_njit),
        (f"baseline: NumPy/Python loop, hoisted (x{n // BASELINE_SLICE})", c_py, w_py),
    ]
    print(f"{'':46s} {'CPU s':>8s} {'M samp/s':>9s} {'x real':>8s} {'wall s':>8s} {'M samp/s':>9s}")
    for name, c, w in rows:
        print(f"{name:46s} {c:8.3f} {n / c / 1e6:9.2f} {n / fs / c:8.0f} {w:8.3f} {n / w / 1e6:9.2f}")
    speed = n / c_stream / 1e6
    r_njit, r_py = c_njit / c_stream, c_py / c_stream
    print(
        f"ratio kernel (streaming) vs plain @njit loop (CPU time): {r_njit:.2f}x "
        f"(whole trace: {c_njit / c_whole:.2f}x)"
    )
    print(
        f"ratio kernel (streaming) vs NumPy/Python loop, hoisted (CPU time): {r_py:.0f}x "
        f"(whole trace: {c_py / c_whole:.0f}x)"
    )
    print(f"goal >= 20 M samples/s on one core: {'met' if speed >= 20.0 else 'NOT met'} ({speed:.1f})")
    for name, r in (("plain @njit loop", r_njit), ("NumPy/Python loop, hoisted", r_py)):
        print(f"goal >= 100x baseline, against the {name}: {'met' if r >= 100.0 else 'NOT met'} ({r:.2f}x)")
    worst = max(agree_njit, agree_py)
    if not worst <= AGREE_TOL:
        raise SystemExit(
            f"baseline and kernel disagree by {worst:.3g} rad (> {AGREE_TOL:g}) — not the same law"
        )


if __name__ == "__main__":
    main()
