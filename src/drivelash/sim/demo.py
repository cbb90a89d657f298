"""Demo step: simulate the bench replica 0A, write its trace and a figure."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from rich.console import Console


def demo_simulate(out_dir: Path, console: Console) -> None:
    """Simulate ``bench-0A``; write ``bench-0A.parquet`` and ``bench-0A.png`` to ``out_dir``."""
    from drivelash.report.sim_figures import plot_backlash_trace
    from drivelash.sim.scenarios import get_scenario

    sc = get_scenario("bench-0A")
    t0 = time.perf_counter()
    trace = sc.simulate()
    wall = time.perf_counter() - t0
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    trace_path = trace.save(out_dir / f"{sc.name}.parquet")
    png = plot_backlash_trace(trace, out_dir / f"{sc.name}.png", title=f"{sc.name}: {sc.description}")
    dth = trace["theta_m"] - trace["theta_l"]
    console.print(
        f"simulate: {sc.name} {trace.duration:.0f} s in {wall:.2f} s "
        f"(≈{(trace.duration) / max(wall, 1e-9):.0f}× real time incl. compile), "
        f"Δθ span {np.ptp(dth):.3f} rad vs δ = {sc.plant_backlash.delta} rad -> {trace_path}, {png}"
    )
