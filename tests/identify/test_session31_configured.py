"""Session 31: ``estimate --identify`` names a configured drive value the recording contradicts
(session 30 tester A, L6: K_S stated at twice the truth sat in the JSON next to the identified
32.68 [31.40, 33.96] N·m/rad without a remark; δ̂ itself was right — the online law is robust to
it — so this is a note, not a verdict). Reference: the simulator's K_S (bench-0B, 32.94)."""

from __future__ import annotations

import pytest

import drivelash as dl
from drivelash.estimation.backlash_api import CONFIG_DISAGREE_FACTOR
from drivelash.sim.scenarios import get_scenario


@pytest.fixture(scope="module")
def bench_0b():
    sc = get_scenario("bench-0B")
    return sc, sc.simulate(duration=6.0, seed=5)


def _cfg(tmp_path, K_S: float):
    p = tmp_path / f"ks_{K_S:g}.toml"
    p.write_text(f"[drivetrain]\nN = 1.0\nK_S = {K_S!r}\n")
    return p


def test_a_configured_stiffness_twice_the_identified_is_named(bench_0b, tmp_path):
    sc, tr = bench_0b
    K_true = sc.plant_drivetrain.K_S
    est = dl.estimate_backlash(tr, _cfg(tmp_path, 2.0 * K_true), identify=True)
    p = est.identification["K_S"]
    assert p.covers(K_true) and not p.covers(2.0 * K_true)  # the reference: the fit holds the truth
    notes = [w for w in est.summary["warnings"] if w.startswith("note: [drivetrain] K_S")]
    assert len(notes) == 1, est.summary["warnings"]
    assert "is used as configured, but the recording gives" in notes[0] and "× the identified" in notes[0]
    assert est.summary["drivetrain_used"]["K_S"] == 2.0 * K_true  # the configuration's value still wins
    # negative control: the true K_S (inside the interval) and one within the factor get no note
    for k in (1.0, 1.0 + 0.5 * (CONFIG_DISAGREE_FACTOR - 1.0)):
        est = dl.estimate_backlash(tr, _cfg(tmp_path, k * K_true), identify=True)
        assert not [w for w in est.summary["warnings"] if "[drivetrain] K_S" in w], est.summary["warnings"]
