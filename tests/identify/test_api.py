"""Issue 11 item 6: one notebook API — ``drivelash.estimate_backlash`` gives the command's numbers.

The command (``drivelash estimate``) and the API call the same computation
(:func:`drivelash.estimation.backlash_api.estimate_from_config`); these tests hold them to
1e-12 on ``paper-sim`` and a bench scenario, from a DataFrame and from a path, and check
the curated namespaces.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import tomli_w

import drivelash as dl
from drivelash.sim.scenarios import get_scenario


def _config(tmp_path: Path, name: str) -> Path:
    sc = get_scenario(name)
    dt = {k: float(v) for k, v in asdict(sc.estimator_drivetrain).items() if v is not None}
    p = tmp_path / f"{name}.toml"
    p.write_text(
        tomli_w.dumps({"drivetrain": dt, "backlash": {"delta1": float(sc.estimator_backlash.delta1)}})
    )
    return p


def _equal(a, b, path="") -> None:
    """Recursive equality with floats to 1e-12 (relative) — the acceptance tolerance."""
    if isinstance(a, dict):
        assert set(a) == set(b), (path, set(a) ^ set(b))
        for k in a:
            _equal(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _equal(x, y, f"{path}[{i}]")
    elif isinstance(a, float) or isinstance(b, float):
        if a is None or b is None:
            assert a is None and b is None, path
        elif math.isfinite(a):
            assert abs(a - b) <= 1e-12 * max(1.0, abs(a)), (path, a, b)
        else:
            assert not math.isfinite(b), path
    else:
        assert a == b, (path, a, b)


@pytest.mark.parametrize(("name", "duration"), [("paper-sim", 4.0), ("bench-0C", 6.0)])
def test_estimate_backlash_equals_the_command_json(tmp_path, name, duration):
    from drivelash.commands.estimate import run_estimate

    run = get_scenario(name).simulate(duration=duration, seed=3)
    pq = tmp_path / "run.parquet"
    run.to_parquet(pq)
    cfg = _config(tmp_path, name)
    js = tmp_path / "out.json"
    run_estimate(pq, cfg, json_out=js, quiet=True)
    cmd = json.loads(js.read_text())
    cmd.pop("generator", None)

    def as_json(res):
        return json.loads(json.dumps({"trace": str(pq), "config": str(cfg), **res.summary}, default=float))

    # from the path: the same input as the command, the same JSON
    _equal(cmd, as_json(dl.estimate_backlash(pq, cfg)))
    # from a DataFrame read back by pandas: the same numbers; only the file's metadata is gone —
    # the encoder-reading convention the simulator's Parquet states (s20 B7: the JSON now says
    # which convention was applied and where it came from)
    df = pd.read_parquet(pq)
    api = dl.estimate_backlash(df, cfg)
    api_json = as_json(api)
    assert (cmd["encoder_reading"], cmd["encoder_reading_from"]) == ("nearest", "recording metadata")
    assert (api_json["encoder_reading"], api_json["encoder_reading_from"]) == ("unknown", "none")
    _equal(cmd, {**api_json, "encoder_reading": "nearest", "encoder_reading_from": "recording metadata"})
    assert api.delta == cmd["delta"]
    assert dl.estimate_backlash(run, cfg).delta == api.delta
    # the low-level kernel wrapper as the README shows it: the same δ̂
    sc = get_scenario(name)
    low = dl.estimation.DeadzoneEstimator(sc.estimator_drivetrain, sc.estimator_backlash.delta1, run.T_s)
    assert abs(low.run(run).delta - api.delta) <= 1e-12
    # negative control: the comparison sees a changed number
    with pytest.raises(AssertionError):
        _equal(cmd, {**api_json, "delta": api_json["delta"] * (1 + 1e-9)})


def test_drivetrain_params_and_delta1_form(tmp_path):
    """``estimate_backlash(trace, DrivetrainParams, delta1)`` = the config form (same tuning)."""
    sc = get_scenario("bench-0C")
    run = sc.simulate(duration=4.0, seed=1)
    a = dl.estimate_backlash(run, sc.estimator_drivetrain, sc.estimator_backlash.delta1)
    b = dl.estimate_backlash(run, _config(tmp_path, "bench-0C"))
    assert a.delta == b.delta and a.summary["gains"] == b.summary["gains"]
    with pytest.raises(dl.ParameterError, match="delta1"):
        dl.estimate_backlash(run, sc.estimator_drivetrain)
    with pytest.raises(dl.ParameterError, match="data"):
        dl.estimate_backlash(np.zeros(3), sc.estimator_drivetrain, 0.0)


def test_delta1_argument_takes_numpy_scalars(tmp_path):
    """Tester finding (session 14): ``delta1=np.float32(0.0525)`` was refused as "must be a finite
    number >= 0, got np.float32(0.0525)"; a numpy scalar is a number. NaN, a negative value and a
    boolean stay refused (negative controls)."""
    sc = get_scenario("bench-0C")
    run = sc.simulate(duration=2.0, seed=1)
    cfg = _config(tmp_path, "bench-0C")
    d1 = np.float32(sc.estimator_backlash.delta1)
    a = dl.estimate_backlash(run, cfg, d1)
    b = dl.estimate_backlash(run, cfg, float(d1))
    assert a.delta == b.delta and a.summary["delta1"] == b.summary["delta1"]
    for bad in (np.float64("nan"), np.float32(-0.01), np.bool_(True), True):
        with pytest.raises(dl.ParameterError, match="delta1.*finite number >= 0"):
            dl.estimate_backlash(run, cfg, bad)


def test_curated_namespaces():
    """Top level and each subpackage list their public names; every listed name resolves."""
    import importlib
    import pkgutil

    import drivelash

    # every public subpackage (commands and migrations are not an API) plus params
    mods = ["drivelash", "drivelash.params"] + [
        info.name
        for info in pkgutil.walk_packages(drivelash.__path__, prefix="drivelash.")
        if info.ispkg and ".commands" not in info.name and ".migrations" not in info.name
    ]
    assert {"drivelash.sim", "drivelash.physics", "drivelash.wear", "drivelash.te.runtime"} <= set(mods)
    for mod in mods:
        m = importlib.import_module(mod)
        assert hasattr(m, "__all__"), f"{mod} has no curated __all__"
        assert m.__all__ == sorted(m.__all__, key=str.lower) or len(m.__all__) > 0
        for n in m.__all__:
            assert getattr(m, n) is not None, (mod, n)
    for n in ("estimate_backlash", "identify_drive", "BacklashEstimate", "Trace", "load_trace"):
        assert n in dl.__all__


def test_estimate_identify_fills_the_drive_and_reports_both_deltas(tmp_path):
    """``estimate --identify`` with only N in the config: the drive and δ1 come from the
    identification; the JSON carries the offline δ with its interval and the online δ̂; both
    agree with the truth (bench-0C, δ = 105 mrad) and with each other."""
    from drivelash.commands.estimate import run_estimate

    pq = tmp_path / "run.parquet"
    get_scenario("bench-0C").simulate(duration=6.0, seed=11).to_parquet(pq)
    cfg = tmp_path / "n_only.toml"
    cfg.write_text("[drivetrain]\nN = 1.0\n")
    js = tmp_path / "e.json"
    s = run_estimate(pq, cfg, json_out=js, quiet=True, identify=True)
    doc = json.loads(js.read_text())
    assert doc["online_run"] and doc["delta1_source"] == "identification"
    off = doc["identification"]["delta"]
    assert off["identifiable"] and off["ci95"][0] < 0.105 < off["ci95"][1]
    assert abs(doc["delta"] - 0.105) < 2e-3 and abs(s["delta"] - doc["delta"]) == 0.0
    ag = doc["agreement"]
    sig = math.hypot(off["std"], ag["online_std"] or 0.0)
    assert ag["disagree"] == (abs(doc["delta"] - off["value"]) > 1.959963984540054 * sig)
    assert any("disagree" in w for w in doc["warnings"]) == ag["disagree"]
    assert set(doc["drivetrain_used"]) >= {"J_m", "J_l", "K_S", "D_S"}
    # without --identify the same config is refused with the key named (negative control)
    with pytest.raises(dl.ConfigError, match="backlash"):
        run_estimate(pq, cfg, quiet=True)
