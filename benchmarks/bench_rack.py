"""Virtual rack-and-pinion bench (issue 5): campaign time and the eq. (3) path-error check.

1. The full measurement campaign (``drivelash te campaign``: 70 runs, ≈ 4200 s of
   simulated time at 8 kHz, stored at 1 kHz) on 2 threads: wall time, CPU time,
   real-time factor, data volume. Goal: ≤ 300 s on 2 cores (ratio to that budget).
2. One pass alone on one thread: real-time factor of the engine, against the baseline
   a competent user would write: a **plain ``@njit`` fixed-step RK4 loop of the same
   closed loop** (same P/PI cascade, T_s, 4 substeps, friction) with a linear mesh
   spring — no backlash contact, no TE tables, no load drive, no sensor noise. The ratio
   is what the rack physics costs (the baseline does less work, so expect < 1).
3. Eq. (3) applied to the TE measured along no-load passes predicts the simulated path
   error: MAE at 10 mm/s (goal < 0.1 µm, the paper's figure) and at the three campaign
   velocities.

Times are wall and process CPU time; the load average is printed because other jobs may
share the cores. Run: ``make bench`` or ``.venv/bin/python benchmarks/bench_rack.py``.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

import numpy as np
from numba import njit

from drivelash.control.path_error import predict_path_error
from drivelash.physics.rack_pinion import RackPinionBench, TransmissionErrorModel
from drivelash.sim.rack_axis import RackAxisSimulator, constant_velocity_pass
from drivelash.sim.rack_campaign import CampaignConfig, run_campaign

BUDGET_S = 300.0


def _dir_size(d: Path) -> int:
    return sum(p.stat().st_size for p in d.iterdir() if p.is_file())


@njit(cache=True, inline="always")
def _rhs(th, w, x, v, T, c):
    r, J_M, m_T, k, d, T_Cm, beta_m, F_CT, beta_T, v_reg = c
    Fc = k * (r * th - x) + d * (r * w - v)
    dw = (T - T_Cm * np.tanh(w * r / v_reg) - beta_m * w - r * Fc) / J_M
    dv = (Fc - F_CT * np.tanh(v / v_reg) - beta_T * v) / m_T
    return w, dw, v, dv


@njit(cache=True)
def plain_rk4_axis(x_d, v_d, r, J_M, m_T, k, d, T_Cm, beta_m, F_CT, beta_T, v_reg, K_v, K_p, T_n, T_s, n_sub):
    """Baseline: the closed-loop two-mass axis, fixed-step RK4 in scalars, linear mesh spring;
    returns x_T [m] per sample."""
    th, w, x, v, xi = x_d[0] / r, 0.0, x_d[0], 0.0, 0.0
    h = T_s / n_sub
    out = np.empty(x_d.size)
    c = (r, J_M, m_T, k, d, T_Cm, beta_m, F_CT, beta_T, v_reg)
    for kk in range(x_d.size):
        e_w = (v_d[kk] + K_v * (x_d[kk] - x)) / r - w
        T = K_p * e_w + xi
        xi += T_s / T_n * K_p * e_w
        out[kk] = x
        for _ in range(n_sub):
            a1, b1, c1, d1 = _rhs(th, w, x, v, T, c)
            a2, b2, c2, d2 = _rhs(
                th + 0.5 * h * a1, w + 0.5 * h * b1, x + 0.5 * h * c1, v + 0.5 * h * d1, T, c
            )
            a3, b3, c3, d3 = _rhs(
                th + 0.5 * h * a2, w + 0.5 * h * b2, x + 0.5 * h * c2, v + 0.5 * h * d2, T, c
            )
            a4, b4, c4, d4 = _rhs(th + h * a3, w + h * b3, x + h * c3, v + h * d3, T, c)
            th += h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
            w += h / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4)
            x += h / 6.0 * (c1 + 2.0 * c2 + 2.0 * c3 + c4)
            v += h / 6.0 * (d1 + 2.0 * d2 + 2.0 * d3 + d4)
    return out


def main() -> None:
    print(f"load average: {os.getloadavg()}")
    bench = RackPinionBench()
    model = TransmissionErrorModel.generate(bench, 0)
    sim = RackAxisSimulator(bench, model)
    sim.run(np.zeros(8), np.zeros(8))  # compile / load the cache

    # 1. full campaign
    with tempfile.TemporaryDirectory() as tmp:
        c0 = time.process_time()
        m = run_campaign(tmp, seed=0, config=CampaignConfig(), workers=2)
        cpu = time.process_time() - c0
        tm = m["timing"]
        size = _dir_size(Path(tmp))
        print(
            f"campaign: {len(m['runs'])} runs, {tm['simulated_s']:.0f} s simulated, "
            f"wall {tm['wall_s']:.1f} s, CPU {cpu:.1f} s, real-time factor {tm['real_time_factor']:.0f}, "
            f"{size / 1e6:.0f} MB; wall / goal {tm['wall_s'] / BUDGET_S:.3f} "
            f"(goal {BUDGET_S:.0f} s, not a baseline)"
        )

    # 2. + 3. single passes, eq. (3); the engine against the plain @njit RK4 loop
    c_mean = float(np.mean(model.c))
    base_args = (bench.r_eff, bench.J_M, bench.m_T, 1.0 / c_mean, bench.d_mesh(c_mean), bench.T_Cm,
                 bench.beta_m, bench.F_CT, bench.beta_T, sim.config.v_reg, sim.gains.K_v, sim.gains.K_p,
                 sim.gains.T_n, sim.T_s, int(sim.config.n_sub))  # fmt: skip
    plain_rk4_axis(np.zeros(8), np.zeros(8), *base_args)  # compile / load the cache
    for v in (0.01, 0.02, 0.05, 0.1):
        t, xd, vd = constant_velocity_pass(0.05, bench.travel - 0.05, v)
        w0 = time.perf_counter()
        tr = sim.run(xd, vd, 0.0)
        wall = time.perf_counter() - w0
        w0 = time.perf_counter()
        plain_rk4_axis(xd, vd, *base_args)
        wall_b = time.perf_counter() - w0
        e = tr["x_d"] - tr["x_T"]
        te = bench.te_from_measurement(tr["x_T"], tr["theta_m"])
        e_hat = predict_path_error(te, tr["t"], bench.J_s, sim.gains)
        t_a = max(np.pi * v / (2 * 0.5), 0.05)
        sel = (tr["t"] > 0.1 + t_a + 0.3) & (tr["t"] < tr["t"][-1] - 0.1 - t_a - 0.01)
        mae = np.mean(np.abs(e - e_hat)[sel])
        print(
            f"v = {v * 1e3:5.0f} mm/s: engine real-time factor {t[-1] / wall:6.0f} (1 thread); baseline "
            f"'plain @njit RK4 loop, linear mesh, no TE/backlash' {t[-1] / wall_b:6.0f}; "
            f"ratio engine/baseline speed {wall_b / wall:.2f}x; "
            f"path error mean |e_x| {np.mean(np.abs(e[sel])) * 1e6:.3f} µm, "
            f"eq. (3) MAE {mae * 1e6:.5f} µm (goal < 0.1 µm)"
        )


if __name__ == "__main__":
    main()
