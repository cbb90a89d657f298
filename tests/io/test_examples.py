"""Every configuration under examples/ loads with the one schema (and a scenario file simulates)."""

from __future__ import annotations

from pathlib import Path

import pytest

from drivelash.io import load_config

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize("name", ["drive_bench.toml", "emps.toml", "emps_pulses.toml"])
def test_drive_configs_load(name: str) -> None:
    cfg = load_config(EXAMPLES / name)
    assert cfg.source.endswith(name)


def test_drive_bench_example_maps_to_params() -> None:
    cfg = load_config(EXAMPLES / "drive_bench.toml")
    assert cfg.to_drivetrain_params().K_S == 32.94
    assert cfg.estimator.given() == {"delta_max": 2.0, "delta0": 0.0}


def test_scenario_example_loads_and_simulates() -> None:
    from drivelash.sim.scenarios import scenario_from_toml

    sc = scenario_from_toml(EXAMPLES / "wear_scenario.toml")
    assert sc.name == "wear_scenario" and sc.deadzone_profile.kind == "ramp"
    tr = sc.simulate(duration=0.2)
    assert tr["delta_true"][0] == sc.plant_backlash.delta
