"""Named scenarios: registry, contents, trace contract, TOML configuration."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from drivelash.errors import ConfigError, DrivelashError
from drivelash.io.trace import Trace
from drivelash.sim.scenarios import get_scenario, list_scenarios, scenario_from_toml

NAMES = ["paper-sim"] + [f"bench-{k}{x}" for k in range(6) for x in "ABC"]


def test_registry_names_and_unknown_name() -> None:
    assert [s.name for s in list_scenarios()] == NAMES
    with pytest.raises(DrivelashError) as ei:
        get_scenario("bench-9Z")
    msg = str(ei.value)
    assert "bench-9Z" in msg and "bench-0A" in msg and "paper-sim" in msg and "\n" not in msg


@pytest.mark.parametrize("name", NAMES)
def test_scenario_contents(name: str) -> None:
    sc = get_scenario(name)
    assert sc.description and "\n" not in sc.description
    assert sc.gains.T_s == 125e-6 and sc.gains.torque_limit == 13.0
    if name == "paper-sim":
        assert sc.plant_backlash.delta == 0.2 and sc.plant_backlash.delta1 == 0.1
        t = np.array([2.999875, 3.0])
        np.testing.assert_allclose(sc.delta_true(t), [0.2, 0.21])
        assert sc.sensors.sigma_omega_l == 0.0316 and sc.sensors.counts_l == 0
        assert sc.estimator_drivetrain == sc.plant_drivetrain
        return
    k, x = int(name[6]), name[7]
    assert sc.plant_backlash.delta == {"A": 1.027, "B": 0.186, "C": 0.105}[x]
    assert sc.duration >= 60.0
    assert sc.sensors.counts_m == sc.sensors.counts_l == 2048
    assert sc.sensors.sigma_omega_m == sc.sensors.sigma_omega_l == 0.0316
    p, e = sc.plant_drivetrain, sc.estimator_drivetrain
    assert (p.J_m, p.J_l, p.N, p.K_S, p.D_S) == (8.31e-4, 8.31e-4, 1.0, 32.94, 0.0548)
    assert (p.T_Cm, p.T_Cl, p.beta_m, p.beta_l) == (0.0223, 0.0232, 0.0016, 0.0016)
    doubled = {1: {"K_S"}, 2: {"D_S"}, 3: {"T_Cl"}, 4: {"beta_l"}, 5: {"K_S", "D_S", "T_Cl", "beta_l"}}.get(
        k, set()
    )
    for f in ("J_m", "J_l", "N", "K_S", "D_S", "T_Cm", "T_Cl", "beta_m", "beta_l"):
        factor = 2.0 if f in doubled else 1.0
        assert getattr(e, f) == pytest.approx(factor * getattr(p, f)), f
    assert sc.estimator_backlash.delta1 == sc.plant_backlash.delta1


def test_bench_trace_contract_and_meta(tmp_path: Path) -> None:
    sc = get_scenario("bench-3B")
    tr = sc.simulate(duration=0.5)
    for c in ("t", "theta_m", "omega_m", "theta_l", "omega_l", "torque_m", "delta_true", "theta_ref"):
        assert c in tr
    assert len(tr) == 4000 and tr.T_s == pytest.approx(125e-6)
    assert tr.meta["scenario"] == "bench-3B" and tr.meta["seed"] == sc.seed
    assert tr.meta["estimator_drivetrain"]["T_Cl"] == pytest.approx(2 * 0.0232)
    json.dumps(tr.meta)
    back = Trace.from_parquet(tr.save(tmp_path / "x.parquet"))
    assert back.meta == tr.meta
    np.testing.assert_array_equal(back["theta_l"], tr["theta_l"])


def test_bench_motion_crosses_both_flanks() -> None:
    """bench-0C: the load is driven through the whole gap on every reversal (excitation)."""
    sc = get_scenario("bench-0C")
    tr = sc.simulate(duration=4.0, return_states=True)
    dth = tr["theta_m_true"] - tr["theta_l_true"]
    d, d1 = sc.plant_backlash.delta, sc.plant_backlash.delta1
    assert np.min(dth) < -d1 and np.max(dth) > d - d1
    # motor tracks the sine reference within a few mrad away from the impacts
    assert np.median(np.abs(tr["theta_ref"] - tr["theta_m_true"])) < 5e-3
    # 11-bit quantised outputs
    q = 2 * math.pi / 2048
    assert np.allclose(tr["theta_l"] / q, np.round(tr["theta_l"] / q))


def test_toml_overrides(tmp_path: Path) -> None:
    cfg = tmp_path / "wear.toml"
    cfg.write_text(
        'base = "bench-0B"\nduration = 0.25\nseed = 9\n'
        "[backlash]\ndelta = 0.3\ndelta1 = 0.1\n"
        '[deadzone]\nkind = "ramp"\ndelta_end = 0.4\nt0 = 0.05\nt1 = 0.15\n'
    )
    sc = scenario_from_toml(cfg)
    assert sc.name == "wear" and sc.plant_backlash.delta == 0.3
    tr = sc.simulate()
    assert len(tr) == 2000 and tr.meta["seed"] == 9
    assert tr["delta_true"][0] == 0.3 and tr["delta_true"][-1] == pytest.approx(0.4)


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("durashun = 3\n", "top-level key 'durashun': unknown key; did you mean 'duration'?"),
        ("[plant]\nJ_x = 1.0\n", "table [plant], key 'J_x': unknown key; did you mean 'J_m'?"),
        ("[plant]\nJ_m = -1.0\n", "table [plant], key 'J_m': must be > 0, got -1.0"),
        ("[backlash]\ndelta1 = 5.0\n", "table [backlash], key 'delta1': must lie in [0, delta]"),
        ('base = "nope"\n', "top-level key 'base': unknown scenario 'nope'"),
        ("duration = -2.0\n", "top-level key 'duration': must be finite and > 0, got -2.0"),
        ("seed = 1.5\n", "top-level key 'seed': Input should be a valid integer"),
        ('model = "spline"\n', "top-level key 'model': Input should be 'deadzone' or 'smooth'"),
        ('[plant]\nK_S = "stiff"\n', "table [plant], key 'K_S': Input should be a valid number"),
        ('[reference]\nkind = "square"\n', "table [reference], key 'kind'"),
        ("[gains]\nk_ff = 2.0\n", "table [gains], key 'k_ff': must lie in [0, 1]"),
        ("[estimator]\ngamma = -1.0\n", "table [estimator], key 'gamma': must be finite and > 0"),
        ("[estimator]\nK_S = 65.9\n", "[estimator], key 'K_S': unknown key; it is a key of [plant] and"),
        ("this is = not toml [\n", "TOML syntax error"),
    ],
)  # fmt: skip
def test_toml_errors_are_one_line(tmp_path: Path, text: str, needle: str) -> None:
    """One line naming the file, the table and the key (the one schema of drivelash.io.config)."""
    cfg = tmp_path / "wear.toml"
    cfg.write_text(text)
    with pytest.raises(ConfigError) as ei:
        scenario_from_toml(cfg)
    assert str(ei.value).startswith(f"{cfg}: "), str(ei.value)
    assert needle in str(ei.value) and "\n" not in str(ei.value)


def test_toml_tables_mean_the_same_as_in_every_file(tmp_path: Path) -> None:
    """[drivetrain] is the drive train the estimator is told, [plant] the true one, and
    [estimator] the estimator gains — as in an ``estimate`` configuration."""
    from drivelash.estimation.reproduce import estimator_for
    from drivelash.params import EstimatorConfig

    cfg = tmp_path / "told.toml"
    cfg.write_text(
        'base = "bench-0A"\n[plant]\nK_S = 40.0\n[drivetrain]\nK_S = 65.88\n'
        '[estimator]\ngamma = 7.0\ndelta_max = 1.5\nmethod = "paper"\n'
    )
    sc = scenario_from_toml(cfg)
    base = get_scenario("bench-0A")
    assert sc.plant_drivetrain.K_S == 40.0 and sc.estimator_drivetrain.K_S == 65.88
    assert sc.plant_drivetrain.J_m == base.plant_drivetrain.J_m  # the rest from the base
    assert sc.estimator_overrides == {"gamma": 7.0, "delta_max": 1.5, "method": "paper"}
    est = estimator_for(sc, "default")
    assert est.config.gamma == 7.0 and est.config.delta_max == 1.5
    assert est.config.method == "default"  # the caller's method wins
    rule = EstimatorConfig.tuned(sc.estimator_drivetrain, sc.T_s, f_exc=0.5)  # on the drive it is told
    assert est.config.k1 == rule.k1 and est.config.k1 != estimator_for(base, "default").config.k1


def test_toml_tables_are_generated_from_the_dataclasses() -> None:
    import dataclasses

    from drivelash.params import BacklashParams, CascadeGains, DrivetrainParams, SensorParams
    from drivelash.sim.scenarios import DeadzoneProfile, ReferenceSpec, Scenario, ScenarioFile

    for table, cls in (
        ("plant", DrivetrainParams),
        ("drivetrain", DrivetrainParams),
        ("backlash", BacklashParams),
        ("gains", CascadeGains),
        ("sensors", SensorParams),
        ("reference", ReferenceSpec),
        ("deadzone", DeadzoneProfile),
    ):
        model = ScenarioFile.model_fields[table].annotation.__args__[0]
        assert model.__params__ is cls
        assert list(model.model_fields) == [f.name for f in dataclasses.fields(cls)]
    top = set(ScenarioFile.model_fields) - {"base", "plant", "drivetrain", "backlash", "gains"}
    top -= {"sensors", "reference", "deadzone", "estimator"}
    assert top == {f.name for f in dataclasses.fields(Scenario)} - {
        "plant_drivetrain", "plant_backlash", "estimator_drivetrain", "estimator_backlash", "gains",
        "sensors", "reference", "deadzone_profile", "estimator",
    }  # fmt: skip
