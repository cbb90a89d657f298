"""Full-length runs of every scenario (slow) and the demo step."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rich.console import Console

from drivelash.io.trace import Trace
from drivelash.sim.demo import demo_simulate
from drivelash.sim.scenarios import list_scenarios


@pytest.mark.slow
@pytest.mark.parametrize("name", [s.name for s in list_scenarios()])
def test_full_scenario_run_is_sane(name: str) -> None:
    from drivelash.sim.scenarios import get_scenario

    sc = get_scenario(name)
    tr = sc.simulate(return_states=True)
    assert len(tr) == round(sc.duration / sc.T_s)
    for c in tr.names:
        assert np.all(np.isfinite(tr[c])), c
    assert np.max(np.abs(tr["u"])) < sc.gains.torque_limit  # never saturates
    dth = tr["theta_m_true"] - tr["theta_l_true"]
    d1 = sc.plant_backlash.delta1
    d_end = tr["delta_true"][-1]
    # both flanks are reached in the last 10 s (the motion keeps exciting the deadzone)
    last = tr["t"] > tr["t"][-1] - 10.0
    assert np.min(dth[last]) < -d1 and np.max(dth[last]) > d_end - d1
    # the motor follows its reference (impacts cause the largest deviations)
    assert np.max(np.abs(tr["theta_ref"] - tr["theta_m_true"])) < 0.06


def test_demo_step_writes_trace_and_figure(tmp_path: Path) -> None:
    console = Console(record=True, width=200)
    demo_simulate(tmp_path, console)
    tr = Trace.from_parquet(tmp_path / "bench-0A.parquet")
    assert tr.meta["scenario"] == "bench-0A" and len(tr) == 480_000
    png = (tmp_path / "bench-0A.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 20_000
    assert "bench-0A" in console.export_text()
