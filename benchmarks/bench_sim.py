"""Simulation engine: speed vs scipy solve_ivp, accuracy, and bench-0A real-time factor.

Run: ``make bench`` (or ``.venv/bin/python benchmarks/bench_sim.py``).

* Baseline: ``scipy.integrate.solve_ivp`` (DOP853) integrating the same plant under the
  same zero-order-hold torque sequence, one control period per call
  (:func:`drivelash.sim.crosscheck.replay_solve_ivp`). The engine additionally runs the
  controller and sensor model. Goal: engine ≥ 100× faster.
* Accuracy: engine vs solve_ivp at rtol 1e-11 (reference) on the noiseless plant states.
* bench-0A: 60 s simulated; real-time factor = simulated time / CPU time of the process
  (the kernel is single-threaded; CPU time is robust against other load on the machine).
  Goal ≥ 300×.
"""

from __future__ import annotations

import time

import numpy as np

from drivelash.physics.drivetrain import plant_params_array
from drivelash.sim.crosscheck import replay_solve_ivp
from drivelash.sim.scenarios import get_scenario

WINDOW = 5.0  # s of bench-0A for the solve_ivp comparison


def _cpu(fn, repeat: int = 3) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        best = min(best, time.process_time() - t0)
    return best, out


def main() -> None:
    sc = get_scenario("bench-0A")
    sc.simulate(duration=0.1)  # compile / load the numba cache

    # --- engine vs solve_ivp on the same scenario window -------------------------------
    t_eng, tr = _cpu(lambda: sc.simulate(duration=WINDOW, return_states=True))
    p = plant_params_array(sc.plant_drivetrain, sc.plant_backlash, model=sc.model, omega_reg=sc.omega_reg)
    args = (np.zeros(4), tr["u"], tr["delta_true"], tr["delta1_true"], p, sc.T_s)
    t_ref, X_ref = _cpu(lambda: replay_solve_ivp(*args, rtol=1e-11, atol=1e-12), repeat=1)
    t_ivp, X_ivp = _cpu(lambda: replay_solve_ivp(*args, rtol=1e-8, atol=1e-10), repeat=1)
    err_eng = max(
        np.max(np.abs(X_ref[:, 1] - tr["theta_m_true"])), np.max(np.abs(X_ref[:, 3] - tr["theta_l_true"]))
    )
    err_ivp = max(np.max(np.abs(X_ref[:, 1] - X_ivp[:, 1])), np.max(np.abs(X_ref[:, 3] - X_ivp[:, 3])))
    print(f"bench-0A {WINDOW:g} s, same ZOH torque, CPU seconds (best of 3 for the engine):")
    print(f"  engine (closed loop + sensors, RK4 2x62.5us) {t_eng:8.4f} s  max|theta err| {err_eng:.1e} rad")
    print(f"  solve_ivp DOP853 rtol 1e-8  (baseline)       {t_ivp:8.4f} s  max|theta err| {err_ivp:.1e} rad")
    print(f"  solve_ivp DOP853 rtol 1e-11 (reference)      {t_ref:8.4f} s")
    ratio = t_ivp / t_eng
    verdict = "OK" if ratio >= 100 else "MISSED"
    print(f"  speed-up vs solve_ivp rtol 1e-8: {ratio:6.0f}x  (goal >= 100x) {verdict}")
    print(f"  speed-up vs solve_ivp rtol 1e-11: {t_ref / t_eng:5.0f}x")

    # --- bench-0A real-time factor ----------------------------------------------------
    t_full, full = _cpu(lambda: sc.simulate())
    wall0 = time.perf_counter()
    sc.simulate()
    wall = time.perf_counter() - wall0
    rtf = full.duration / t_full
    print(
        f"bench-0A {full.duration:.0f} s ({len(full)} samples): CPU {t_full:.3f} s, wall {wall:.3f} s -> "
        f"real-time factor {rtf:.0f}x on one core (goal >= 300x) {'OK' if rtf >= 300 else 'MISSED'}"
    )


if __name__ == "__main__":
    main()
