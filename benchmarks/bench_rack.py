"""Virtual rack-and-pinion bench (issue 5): campaign time and the eq. (3) path-error check.

1. The full measurement campaign (``drivelash te campaign``: 70 runs, ≈ 4200 s of
   simulated time at 8 kHz, stored at 1 kHz) on 2 threads: wall time, CPU time,
   real-time factor, data volume. Goal: ≤ 300 s on 2 cores (ratio to that budget).
2. One 10 mm/s pass alone on one thread: real-time factor of the engine.
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

from drivelash.control.path_error import predict_path_error
from drivelash.physics.rack_pinion import RackPinionBench, TransmissionErrorModel
from drivelash.sim.rack_axis import RackAxisSimulator, constant_velocity_pass
from drivelash.sim.rack_campaign import CampaignConfig, run_campaign

BUDGET_S = 300.0


def _dir_size(d: Path) -> int:
    return sum(p.stat().st_size for p in d.iterdir() if p.is_file())


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
            f"{size / 1e6:.0f} MB; budget ratio {tm['wall_s'] / BUDGET_S:.3f} of {BUDGET_S:.0f} s"
        )

    # 2. + 3. single passes, eq. (3)
    for v in (0.01, 0.02, 0.05, 0.1):
        t, xd, vd = constant_velocity_pass(0.05, bench.travel - 0.05, v)
        w0 = time.perf_counter()
        tr = sim.run(xd, vd, 0.0)
        wall = time.perf_counter() - w0
        e = tr["x_d"] - tr["x_T"]
        te = bench.te_from_measurement(tr["x_T"], tr["theta_m"])
        e_hat = predict_path_error(te, tr["t"], bench.J_s, sim.gains)
        t_a = max(np.pi * v / (2 * 0.5), 0.05)
        sel = (tr["t"] > 0.1 + t_a + 0.3) & (tr["t"] < tr["t"][-1] - 0.1 - t_a - 0.01)
        mae = np.mean(np.abs(e - e_hat)[sel])
        print(
            f"v = {v * 1e3:5.0f} mm/s: engine real-time factor {t[-1] / wall:6.0f} (1 thread); "
            f"path error mean |e_x| {np.mean(np.abs(e[sel])) * 1e6:.3f} µm, "
            f"eq. (3) MAE {mae * 1e6:.5f} µm (goal < 0.1 µm)"
        )


if __name__ == "__main__":
    main()
