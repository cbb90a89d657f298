"""A Parquet recording whose ``[columns]`` table converts only some of its columns (B1).

Zero-copy Parquet columns arrive read-only, a converted column (a unit, an offset, an int
column made float) as a writable copy; the estimator's compiled kernel must accept the mix.
Reference: the same samples in one unconverted file (the estimate must be the same number).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import tomli_w

from cli_runner import run_in_process

COLS = ["t", "theta_m", "omega_m", "theta_l", "omega_l", "torque_m"]
OFFSET = 0.3  # [rad] encoder zero offset of θ_l, the case `identify` advises to correct in [columns]


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    """bench-0B, 6 s (true δ = 186 mrad, δ1 = 93 mrad), its SI file and the estimator config."""
    from drivelash.sim.scenarios import get_scenario

    tr = get_scenario("bench-0B").simulate(duration=6.0, seed=3)
    d = tmp_path_factory.mktemp("partial")
    frame = pd.DataFrame({c: np.asarray(tr[c]) for c in COLS})
    frame.to_parquet(d / "si.parquet")
    cfg = {
        "drivetrain": dict(tr.meta["estimator_drivetrain"]),
        "backlash": {"delta1": tr.meta["estimator_backlash"]["delta1"]},
    }
    (d / "si.toml").write_text(tomli_w.dumps(cfg))
    return d, frame, cfg


def _estimate(path, cfg_path, capsys, *extra):
    code, out, err = run_in_process(
        ["estimate", str(path), "-c", str(cfg_path), "--json", str(path) + ".json", *extra], capsys
    )
    return code, out, err


def test_one_column_in_degrees_gives_the_si_estimate(bench, capsys):
    import json

    import drivelash as dl

    d, frame, cfg = bench
    deg = frame.copy()
    deg["theta_l"] = np.degrees(deg["theta_l"])
    deg.to_parquet(d / "deg.parquet")
    (d / "deg.toml").write_text(
        tomli_w.dumps({**cfg, "columns": {"theta_l": {"column": "theta_l", "unit": "deg"}}})
    )
    code, _, err = _estimate(d / "si.parquet", d / "si.toml", capsys)
    assert code == 0, err
    ref = json.loads((d / "si.parquet.json").read_text())
    code, _, err = _estimate(d / "deg.parquet", d / "deg.toml", capsys)
    assert code == 0, err  # was 1: numba TypingError on a (writable, read-only) tuple
    assert "Traceback" not in err and "TypingError" not in err
    got = json.loads((d / "deg.parquet.json").read_text())
    assert got["delta"] == pytest.approx(ref["delta"], abs=1e-9)
    assert abs(ref["delta"] - 0.186) < 1e-3  # the simulator's truth
    api = dl.estimate_backlash(d / "deg.parquet", d / "deg.toml")
    assert api.delta == pytest.approx(ref["delta"], abs=1e-9)


def test_int_column_unmapped_does_not_crash(bench, capsys):
    d, frame, cfg = bench
    x = frame.copy()
    x["torque_m"] = np.round(x["torque_m"] * 1000).astype(np.int32)  # a torque in mN·m as int
    x.to_parquet(d / "int.parquet")
    (d / "int.toml").write_text(
        tomli_w.dumps({**cfg, "columns": {"torque_m": {"column": "torque_m", "unit": "N·m", "scale": 0.001}}})
    )
    code, _, err = _estimate(d / "int.parquet", d / "int.toml", capsys)
    assert code == 0, err
    # and an int column with no mapping at all (the loader converts it to float on its own)
    x.to_parquet(d / "int_raw.parquet")
    code, _, err = _estimate(d / "int_raw.parquet", d / "si.toml", capsys)
    assert "Traceback" not in err and "TypingError" not in err
    assert code in (0, 2), err


def test_offset_advised_by_identify_followed_literally(bench, capsys):
    """θ_l with a +0.3 rad zero offset, corrected by ``[columns.theta_l] offset = -0.3`` as `identify`
    advises, through ``estimate --identify`` (CLI) and ``estimate_backlash(identify=True)``."""
    import drivelash as dl

    d, frame, _ = bench
    x = frame.copy()
    x["theta_l"] = x["theta_l"] + OFFSET
    x.to_parquet(d / "loff.parquet")
    fix = {
        "drivetrain": {"N": 1.0},
        "columns": {"theta_l": {"column": "theta_l", "unit": "rad", "offset": -OFFSET}},
    }
    (d / "loff_fix.toml").write_text(tomli_w.dumps(fix))
    code, _, err = _estimate(d / "loff.parquet", d / "loff_fix.toml", capsys, "--identify")
    assert code == 0, err  # was 1: the same TypingError
    api = dl.estimate_backlash(d / "loff.parquet", d / "loff_fix.toml", identify=True)
    assert abs(api.delta - 0.186) < 2e-3  # the simulator's truth, δ = 186 mrad
