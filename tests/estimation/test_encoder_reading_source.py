"""Which encoder reading convention `estimate` applied, and where it came from (B7).

The same samples gave "converged ± 0.23 mrad" from the simulator's Parquet (metadata: nearest)
and "do not use ± 2.68 mrad" re-saved by pandas (metadata gone); both JSONs said "unknown" and
the warning did not name the key that resolves it. Drive: the tester's geared N = 5 scenario.
"""

from __future__ import annotations

import numpy as np
import pytest

import drivelash as dl

#: The geared drive of tester B's findings (session 20): bench-0B's rig with a 5:1 gear.
GEARED_BODY = """[plant]
N = 5.0
J_l = 0.0207
K_S = 823.5
D_S = 1.37
T_Cl = 0.58
T_Sl = 1.1
beta_l = 0.04
[drivetrain]
N = 5.0
J_l = 0.0207
K_S = 823.5
D_S = 1.37
T_Cl = 0.58
beta_l = 0.04
[backlash]
delta = 0.04
delta1 = 0.02
"""


def geared_toml(duration: float, seed: int = 5) -> str:
    """The geared drive's scenario TOML (δ = 40 mrad, δ1 = 20 mrad) over ``duration`` [s]."""
    return f'base = "bench-0B"\nduration = {duration}\nseed = {seed}\n' + GEARED_BODY


GEARED = geared_toml(6.0)
COLS = ["t", "theta_m", "omega_m", "theta_l", "omega_l", "torque_m"]


@pytest.fixture(scope="module")
def geared(tmp_path_factory):
    from drivelash.sim.scenarios import scenario_from_toml

    p = tmp_path_factory.mktemp("geared") / "geared.toml"
    p.write_text(GEARED)
    sc = scenario_from_toml(p)
    return sc, sc.simulate()


def test_source_of_the_convention_is_stated(geared):
    sc, tr = geared
    params, d1 = sc.estimator_drivetrain, sc.estimator_backlash.delta1
    assert tr.meta.get("encoder_reading") == "nearest"  # the simulator's statement
    a = dl.estimate_backlash(tr, params, d1)
    assert a.summary["encoder_reading"] == "nearest"
    assert a.summary["encoder_reading_from"] == "recording metadata"
    bare = dl.Trace({c: np.asarray(tr[c]) for c in COLS})  # the same samples, no metadata
    b = dl.estimate_backlash(bare, params, d1)
    assert b.summary["encoder_reading"] == "unknown"
    assert b.summary["encoder_reading_from"] == "none"
    assert b.delta == pytest.approx(a.delta, abs=1e-12)  # same samples, same δ̂
    assert a.summary["gains"]["encoder_reading"] == b.summary["gains"]["encoder_reading"] == "unknown"
    # the widening warning names the key that resolves it
    w = [x for x in b.warnings if "depending on how they round" in x]
    assert w and '[estimator] encoder_reading = "nearest" or "truncate"' in w[0]
