"""Cost of one compensation cycle (t_s,c = 5 ms budget; goal ≤ 50 µs from Python).

Compared, per cycle (one v_c from x_d,n, x_d,n+1, torque, ω, α):

* ``Compensator.step`` — the runtime form: Python method → ``@njit`` cycle on the
  position × torque table (bilinear), flank detection, smooth step;
* the bare ``@njit`` kernel ``compensate_run`` over many cycles (cost per cycle inside a
  compiled control loop, no Python call per cycle);
* baseline: the same cycle evaluated by calling the stacked model directly from Python
  (``TEModel.predict_one`` at x_d,n and x_d,n+1, and at the flank change both
  direction models for the backlash) — what a naive integration would do.

The model is the small demo model (:func:`drivelash.te.demo.small_model`, cached in
``.venv/drivelash-cache/te-demo``). Times: ``time.perf_counter`` per call, median of
repeats; the load average is printed because other jobs may share the cores.

Run: ``make bench`` or ``.venv/bin/python benchmarks/bench_compensation.py``.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

from drivelash.te.demo import small_model
from drivelash.te.protocol.bench import ValidationConfig, compensator_for, training_torque_max
from drivelash.te.runtime.compensator import Compensator, compensate_run, init_state
from drivelash.te.runtime.persist import load_model
from drivelash.te.runtime.table import build_table

N_CYCLES = 20_000
REPEATS = 5
GOAL_US = 50.0


def _s(tau: float) -> float:
    return 0.0 if tau <= 0 else 1.0 if tau >= 1 else tau * tau * (3 - 2 * tau)


def baseline_cycle(model, st, x_n, x_next, tq, flank, t_sc=5e-3, t_ss=35e-3):
    """One cycle by direct model calls (Python): (6), and (7) with b from both models on a flank change."""
    if flank != st["flank"]:
        st["b"] = model.predict_one(x_n, tq, flank) - model.predict_one(x_n, -tq, -flank)
        st["t"] = 0.0
        st["flank"] = flank
    v = (model.predict_one(x_next, tq, flank) - model.predict_one(x_n, tq, flank)) / t_sc
    v += st["b"] * (_s((st["t"] + t_sc) / t_ss) - _s(st["t"] / t_ss)) / t_sc
    st["t"] += t_sc
    return v


def main() -> None:
    cache = Path(os.environ.get("DRIVELASH_CACHE", ".venv/drivelash-cache")) / "te-demo"
    camp_dir, model_dir = small_model(cache, print)
    from drivelash.te.protocol.campaign import load_campaign

    camp = load_campaign(camp_dir)
    bench = camp.bench
    model = load_model(model_dir)
    cfg = ValidationConfig()
    t0 = time.perf_counter()
    tq_max = training_torque_max(camp, 3000.0)
    table = build_table(model, 0.0, bench.travel, cfg.table_dx, tq_max, int(np.ceil(tq_max / 0.5)) + 1)
    t_table = time.perf_counter() - t0
    params = compensator_for(bench, table, cfg.compensator)
    # a sinusoidal plan with reversals, torque following the flank
    k = np.arange(N_CYCLES + 1)
    x_d = 0.2 + 0.1 * np.sin(2 * np.pi * k * 5e-3 / 2.0)
    tq = 3.0 * np.sign(np.cos(2 * np.pi * k[:-1] * 5e-3 / 2.0)) + 0.5
    om = np.full(N_CYCLES, 30.0)
    al = np.zeros(N_CYCLES)

    comp = Compensator(table, params, 1)
    comp.step(x_d[0], x_d[1], tq[0], om[0], al[0])  # compile / load cache
    per_step = []
    for _ in range(REPEATS):
        comp.reset(1)
        t0 = time.perf_counter()
        for i in range(N_CYCLES):
            comp.step(x_d[i], x_d[i + 1], tq[i], om[i], al[i])
        per_step.append((time.perf_counter() - t0) / N_CYCLES)
    step_us = float(np.median(per_step)) * 1e6

    p = params.as_array()
    compensate_run(init_state(1.0), table.te, table.x0, table.dx, table.torque0, table.dtorque, p,
                   x_d, tq, om, al)  # fmt: skip
    per_kernel = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        compensate_run(init_state(1.0), table.te, table.x0, table.dx, table.torque0, table.dtorque, p,
                       x_d, tq, om, al)  # fmt: skip
        per_kernel.append((time.perf_counter() - t0) / N_CYCLES)
    kernel_us = float(np.median(per_kernel)) * 1e6

    n_base = 2000
    flank = np.where(tq > 0, 1, -1)
    st = {"flank": 1, "b": 0.0, "t": 1.0}
    baseline_cycle(model, st, x_d[0], x_d[1], tq[0], 1)
    per_base = []
    for _ in range(REPEATS):
        st = {"flank": 1, "b": 0.0, "t": 1.0}
        t0 = time.perf_counter()
        for i in range(n_base):
            baseline_cycle(model, st, x_d[i], x_d[i + 1], tq[i], int(flank[i]))
        per_base.append((time.perf_counter() - t0) / n_base)
    base_us = float(np.median(per_base)) * 1e6

    load = os.getloadavg()
    print(f"table {table.te.shape[1]} x {table.te.shape[2]} x 2 built in {t_table:.2f} s "
          f"(load average {load[0]:.1f} on {os.cpu_count()} cores)")  # fmt: skip
    print(f"Compensator.step (Python -> njit table cycle): {step_us:7.2f} us/cycle "
          f"(goal <= {GOAL_US:.0f} us: {'met' if step_us <= GOAL_US else 'NOT met'})")  # fmt: skip
    print(f"compensate_run (njit loop, per cycle):        {kernel_us:7.3f} us/cycle")
    print(f"baseline: stacked model called directly:      {base_us:7.2f} us/cycle")
    print(f"speed-up of Compensator.step vs baseline: {base_us / step_us:.1f}x; "
          f"njit loop vs baseline: {base_us / kernel_us:.0f}x")  # fmt: skip


if __name__ == "__main__":
    main()
