"""Cost of one compensation cycle (t_s,c = 5 ms budget; goal ≤ 50 µs from Python).

Compared, per cycle (one v_c from x_d,n, x_d,n+1, torque, ω, α), each against the
baseline a competent user would write, measured in the same run:

* from Python, one call per cycle: ``Compensator.step`` (Python method → ``@njit``
  cycle on the position × torque table: bilinear lookup, flank detection, smooth step)
  against **baseline A: an ``@njit`` cycle that evaluates the stacked model directly with
  ``te_point``** (eq. (6) at x_d,n and x_d,n+1; on a flank change the backlash from both
  direction models; the smooth step (7)), also called once per cycle from Python;
* inside a compiled control loop, no Python per cycle: the kernel ``compensate_run``
  against **baseline B: the same ``te_point`` cycle in an ``@njit`` loop**.

The baselines do *less* than the runtime kernel (the flank is given by the torque sign,
no mesh-torque estimate, hysteresis, release rule or clamp), so the ratios favour them.
What the table buys is the cost of the model evaluation: two bilinear lookups instead of
two network + tree evaluations. The two are also compared for accuracy (the table's
interpolation error along the plan, in µm of TE).

The model is the small demo model (:func:`drivelash.te.demo.small_model`, cached in
``.venv/drivelash-cache/te-demo``). Times: ``time.perf_counter``, median of repeats; the
load average is printed because other jobs may share the cores.

Run: ``make bench`` or ``.venv/bin/python benchmarks/bench_compensation.py``.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
from numba import njit

from drivelash.te.demo import small_model
from drivelash.te.protocol.bench import ValidationConfig, compensator_for, training_torque_max
from drivelash.te.runtime.compensator import Compensator, compensate_run, init_state, smooth_step
from drivelash.te.runtime.persist import load_model
from drivelash.te.runtime.predictor import te_point
from drivelash.te.runtime.table import build_table, measured_range

N_CYCLES = 20_000
REPEATS = 5
GOAL_US = 50.0


@njit(cache=True)
def baseline_cycle(st, fp, ip, fn, i_n, x_n, x_next, tq, t_sc, t_ss):
    """One cycle with the model evaluated directly (``te_point``), state ``st`` =
    [flank, b, t since change]; the flank is the torque sign. Returns v_c [m/s]."""
    flank = 1.0 if tq >= 0.0 else -1.0
    if flank != st[0]:
        if flank > 0:
            st[1] = te_point(x_n, tq, fp, ip) - te_point(x_n, -tq, fn, i_n)
        else:
            st[1] = te_point(x_n, tq, fn, i_n) - te_point(x_n, -tq, fp, ip)
        st[2] = 0.0
        st[0] = flank
    if flank > 0:
        v = (te_point(x_next, tq, fp, ip) - te_point(x_n, tq, fp, ip)) / t_sc
    else:
        v = (te_point(x_next, tq, fn, i_n) - te_point(x_n, tq, fn, i_n)) / t_sc
    v += st[1] * (smooth_step((st[2] + t_sc) / t_ss) - smooth_step(st[2] / t_ss)) / t_sc
    st[2] += t_sc
    return v


@njit(cache=True)
def baseline_run(fp, ip, fn, i_n, x_d, tq, t_sc, t_ss):
    """Baseline B: :func:`baseline_cycle` over all cycles inside one compiled loop."""
    st = np.array([1.0, 0.0, 1.0])
    out = np.empty(tq.size)
    for k in range(tq.size):
        out[k] = baseline_cycle(st, fp, ip, fn, i_n, x_d[k], x_d[k + 1], tq[k], t_sc, t_ss)
    return out


def _median_per_cycle(fn, n: int) -> float:
    ts = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        fn()
        ts.append((time.perf_counter() - t0) / n)
    return float(np.median(ts)) * 1e6


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
    # the table over the positions where the model was measured (build_table refuses more)
    x_lo, x_hi = measured_range(model)
    table = build_table(model, x_lo, x_hi, cfg.table_dx, tq_max, int(np.ceil(tq_max / 0.5)) + 1)
    t_table = time.perf_counter() - t0
    params = compensator_for(bench, table, cfg.compensator)
    # a sinusoidal plan with reversals, torque following the flank (inside the table's range)
    k = np.arange(N_CYCLES + 1)
    x_d = 0.2 + 0.1 * np.sin(2 * np.pi * k * 5e-3 / 2.0)
    tq = 3.0 * np.sign(np.cos(2 * np.pi * k[:-1] * 5e-3 / 2.0)) + 0.5
    om = np.full(N_CYCLES, 30.0)
    al = np.zeros(N_CYCLES)
    fp, ip = model.kernel_arrays(1)
    fn, i_n = model.kernel_arrays(-1)
    t_sc, t_ss = params.t_sc, params.t_ss_sign

    # -- from Python, one call per cycle ----------------------------------------------
    comp = Compensator(table, params, 1)
    comp.step(x_d[0], x_d[1], tq[0], om[0], al[0])  # compile / load the cache

    def run_step():
        comp.reset(1)
        for i in range(N_CYCLES):
            comp.step(x_d[i], x_d[i + 1], tq[i], om[i], al[i])

    step_us = _median_per_cycle(run_step, N_CYCLES)
    st = np.array([1.0, 0.0, 1.0])
    baseline_cycle(st, fp, ip, fn, i_n, x_d[0], x_d[1], tq[0], t_sc, t_ss)

    def run_base_a():
        s = np.array([1.0, 0.0, 1.0])
        for i in range(N_CYCLES):
            baseline_cycle(s, fp, ip, fn, i_n, x_d[i], x_d[i + 1], tq[i], t_sc, t_ss)

    base_a_us = _median_per_cycle(run_base_a, N_CYCLES)

    # -- inside a compiled loop -----------------------------------------------------------
    p = params.as_array()

    def run_kernel():
        compensate_run(init_state(1.0), table.te, table.x0, table.dx, table.torque0, table.dtorque, p,
                       x_d, tq, om, al)  # fmt: skip

    run_kernel()
    kernel_us = _median_per_cycle(run_kernel, N_CYCLES)
    baseline_run(fp, ip, fn, i_n, x_d, tq, t_sc, t_ss)
    base_b_us = _median_per_cycle(lambda: baseline_run(fp, ip, fn, i_n, x_d, tq, t_sc, t_ss), N_CYCLES)

    # -- what the table costs in accuracy: TE along the plan, table vs model ----------------
    # (each flank at its own torque sign: the table is clamped to the training torque range)
    err_um = 0.0
    for d in (1, -1):
        m = np.sign(tq) == d
        te_tab = table.predict(x_d[:-1][m], tq[m], d)
        err_um = max(err_um, float(np.max(np.abs(te_tab - model.predict(x_d[:-1][m], tq[m], d))) * 1e6))

    load = os.getloadavg()
    print(f"table {table.te.shape[1]} x {table.te.shape[2]} x 2 built in {t_table:.2f} s "
          f"(load average {load[0]:.1f} on {os.cpu_count()} cores)")  # fmt: skip
    print(f"from Python, per cycle: Compensator.step {step_us:.2f} us (goal <= {GOAL_US:.0f} us: "
          f"{'met' if step_us <= GOAL_US else 'NOT met'}); baseline A '@njit cycle with te_point, "
          f"called from Python' {base_a_us:.2f} us; ratio {base_a_us / step_us:.1f}x")  # fmt: skip
    print(f"inside a compiled loop, per cycle: compensate_run {kernel_us:.3f} us; baseline B '@njit loop "
          f"over the te_point cycle' {base_b_us:.3f} us; ratio {base_b_us / kernel_us:.1f}x")  # fmt: skip
    print(f"table vs model along the plan: max |TE_table - TE_model| {err_um:.4f} um (0.2 mm x 0.5 N*m grid)")


if __name__ == "__main__":
    main()
