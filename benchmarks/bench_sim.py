"""Simulation engine: speed and accuracy against named baselines, bench-0A real-time factor.

Run: ``make bench`` (or ``.venv/bin/python benchmarks/bench_sim.py``). Everything below is
measured in this one run; times are CPU time of this process (``time.process_time``, one
core; the kernels are single-threaded), best of 3 unless stated, with the load average
printed because other jobs may share the cores.

Baselines, each named in the output:

* ``solve_ivp DOP853 rtol 1e-8`` — ``scipy.integrate.solve_ivp`` integrating the same plant
  under the engine's zero-order-hold torque sequence, one control period per call
  (:func:`drivelash.sim.crosscheck.replay_solve_ivp`). Goal (issue 2): engine ≥ 100× faster.
* ``plain @njit RK4 loop`` — what a competent user writes with numba: one ``@njit``
  closed loop (same sensors, the same P/PI cascade, the library's plain RK4 step
  :func:`~drivelash.physics.drivetrain.rk4_step_scalar` on the full right-hand side) but
  **without contact-event location**; at the engine's step (2 × 62.5 µs) and at 8 × 15.6 µs.
  Speed is compared kernel to kernel on the same pre-drawn noise; accuracy of each is its
  deviation from solve_ivp (rtol 1e-11) replaying *its own* torque sequence over 5 s.
* bench-0A real-time factor: 60 s simulated / CPU time of ``Scenario.simulate``. Goal ≥ 300×.
"""

from __future__ import annotations

import math
import os
import time

import numpy as np
from numba import njit

from drivelash.control.cascade import gains_array
from drivelash.physics.drivetrain import plant_params_array, rk4_step_scalar
from drivelash.sim.crosscheck import replay_solve_ivp
from drivelash.sim.engine import DEFAULT_SUBSTEPS, N_OUT, OUT_FIELDS, initial_state, run_closed_loop
from drivelash.sim.scenarios import get_scenario
from drivelash.sim.sensors import N_NOISE, NOISE_OMEGA_L, NOISE_OMEGA_M, sensor_params_array

WINDOW = 5.0  # s of bench-0A for the accuracy comparisons
PLAIN_SUBSTEPS = (DEFAULT_SUBSTEPS, 8)


@njit(cache=True)
def plain_rk4_loop(
    th_ref, om_ref, delta, delta1, noise, p, K_v, K_p, T_n, lim, k_ff, T_s, n_sub, counts, sig_w, out
):
    """Closed loop per control period: quantised encoders + noisy velocities, P/PI cascade
    with back-calculation anti-windup, ZOH torque, ``n_sub`` plain RK4 steps (no event
    location). Writes the engine's output columns (:data:`OUT_FIELDS`)."""
    q = 2.0 * math.pi / counts
    h = T_s / n_sub
    w_m = 0.0
    th_m = 0.0
    w_l = 0.0
    th_l = 0.0
    x_i = 0.0
    for k in range(th_ref.shape[0]):
        thq_m = q * np.round(th_m / q)
        thq_l = q * np.round(th_l / q)
        wq_m = w_m + sig_w * noise[k, NOISE_OMEGA_M]
        wq_l = w_l + sig_w * noise[k, NOISE_OMEGA_L]
        e_w = K_v * (th_ref[k] - thq_m) + k_ff * om_ref[k] - wq_m
        u_un = K_p * e_w + x_i
        u = min(max(u_un, -lim), lim)
        out[k, 0] = thq_m
        out[k, 1] = wq_m
        out[k, 2] = thq_l
        out[k, 3] = wq_l
        out[k, 4] = u
        out[k, 5] = u
        out[k, 6] = w_m
        out[k, 7] = th_m
        out[k, 8] = w_l
        out[k, 9] = th_l
        for _ in range(n_sub):
            w_m, th_m, w_l, th_l = rk4_step_scalar(w_m, th_m, w_l, th_l, u, delta[k], delta1[k], p, h)
        x_i += T_s / T_n * (K_p * e_w + (u - u_un))


def _cpu(fn, repeat: int = 3) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        best = min(best, time.process_time() - t0)
    return best, out


def _theta_error(
    sc, out: np.ndarray, n: int, p: np.ndarray, *, rtol: float, atol: float
) -> tuple[float, object]:
    """Max |θ − θ_ref| [rad] of a run's first n samples against solve_ivp replaying its torque."""
    col = OUT_FIELDS.index
    u = out[:n, col("u")]
    d = np.full(n, sc.plant_backlash.delta)
    d1 = np.full(n, sc.plant_backlash.delta1)
    t, X = _cpu(lambda: replay_solve_ivp(np.zeros(4), u, d, d1, p, sc.T_s, rtol=rtol, atol=atol), repeat=1)
    err = max(
        np.max(np.abs(X[:, 1] - out[:n, col("theta_m_true")])),
        np.max(np.abs(X[:, 3] - out[:n, col("theta_l_true")])),
    )
    return float(err), (t, X)


def main() -> None:
    sc = get_scenario("bench-0A")
    sc.simulate(duration=0.1)  # compile / load the numba cache
    print(f"load average {os.getloadavg()[0]:.1f}; CPU seconds of this process")

    # --- the same inputs for every kernel -------------------------------------------------
    ref = sc.reference.build(sc.duration, sc.T_s)
    n = ref.t.size
    th_r = np.ascontiguousarray(ref.theta_ref)
    om_r = np.ascontiguousarray(ref.omega_ref)
    d = np.full(n, sc.plant_backlash.delta)
    d1 = np.full(n, sc.plant_backlash.delta1)
    noise = np.random.default_rng(sc.seed).standard_normal((n, N_NOISE))
    p = plant_params_array(sc.plant_drivetrain, sc.plant_backlash, model=sc.model, omega_reg=sc.omega_reg)
    ctrl = gains_array(sc.gains)
    sens = sensor_params_array(sc.sensors)
    g, s = sc.gains, sc.sensors
    assert s.counts_m == s.counts_l and s.sigma_omega_m == s.sigma_omega_l  # what the plain loop models
    out_eng = np.empty((n, N_OUT))
    out_plain = {m: np.empty((n, N_OUT)) for m in PLAIN_SUBSTEPS}

    def engine() -> None:
        run_closed_loop(
            initial_state(), th_r, om_r, d, d1, noise, p, ctrl, sens, DEFAULT_SUBSTEPS, 1, out_eng
        )

    def plain(m: int):
        return lambda: plain_rk4_loop(
            th_r, om_r, d, d1, noise, p, g.K_v, g.K_p, g.T_n, g.torque_limit, g.k_ff, g.T_s, m,
            float(s.counts_m), s.sigma_omega_m, out_plain[m],
        )  # fmt: skip

    for m in PLAIN_SUBSTEPS:
        plain(m)()  # compile
    t_eng, _ = _cpu(engine)
    t_plain = {m: _cpu(plain(m))[0] for m in PLAIN_SUBSTEPS}

    # --- accuracy: each against solve_ivp replaying its own torque over WINDOW -----------
    nw = int(round(WINDOW / sc.T_s))
    err_eng, (t_ref, X_ref) = _theta_error(sc, out_eng, nw, p, rtol=1e-11, atol=1e-12)
    err_plain = {m: _theta_error(sc, out_plain[m], nw, p, rtol=1e-11, atol=1e-12)[0] for m in PLAIN_SUBSTEPS}
    u = out_eng[:nw, OUT_FIELDS.index("u")]
    t_ivp, X_ivp = _cpu(
        lambda: replay_solve_ivp(np.zeros(4), u, d[:nw], d1[:nw], p, sc.T_s, rtol=1e-8, atol=1e-10), repeat=1
    )
    err_ivp = max(np.max(np.abs(X_ref[:, 1] - X_ivp[:, 1])), np.max(np.abs(X_ref[:, 3] - X_ivp[:, 3])))
    t_eng_w = t_eng * nw / n  # the engine's cost is constant per period

    print(f"bench-0A, {sc.duration:.0f} s = {n} periods (speed) and first {WINDOW:g} s (accuracy):")
    print(f"  {'':52s} {'CPU s (60 s)':>12s} {'x real':>8s} {'max|theta err| [rad]':>21s}")
    name = "engine (RK4 2x62.5 us, contact-event location)"
    print(f"  {name:52s} {t_eng:12.3f} {sc.duration / t_eng:8.0f} {err_eng:21.1e}")
    for m in PLAIN_SUBSTEPS:
        name = f"baseline: plain @njit RK4 loop {m}x{1e6 * sc.T_s / m:.1f} us, no event location"
        print(f"  {name:52s} {t_plain[m]:12.3f} {sc.duration / t_plain[m]:8.0f} {err_plain[m]:21.1e}")
    for m in PLAIN_SUBSTEPS:
        print(
            f"  ratio engine vs 'plain @njit RK4 loop {m}x': speed {t_plain[m] / t_eng:.2f}x, "
            f"error {err_plain[m] / err_eng:.0f}x smaller"
        )
    ratio = t_ivp / t_eng_w
    print(
        f"  baseline: solve_ivp DOP853 rtol 1e-8 on {WINDOW:g} s: {t_ivp:.2f} s, max|theta err| {err_ivp:.1e}"
    )
    print(
        f"  ratio engine vs 'solve_ivp DOP853 rtol 1e-8': {ratio:.0f}x (goal >= 100x) "
        f"{'OK' if ratio >= 100 else 'MISSED'}; vs rtol 1e-11 (reference): {t_ref / t_eng_w:.0f}x"
    )

    # --- bench-0A real-time factor (user-facing call: noise, kernel, Trace) ---------------
    t_full, full = _cpu(lambda: sc.simulate())
    rtf = full.duration / t_full
    print(
        f"bench-0A Scenario.simulate(), {full.duration:.0f} s ({len(full)} samples): CPU {t_full:.3f} s -> "
        f"real-time factor {rtf:.0f}x on one core (goal >= 300x) {'OK' if rtf >= 300 else 'MISSED'}"
    )


if __name__ == "__main__":
    main()
