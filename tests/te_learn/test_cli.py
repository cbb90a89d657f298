"""``drivelash te fit`` / ``te evaluate`` through the console script."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

EXE = Path(sys.executable).parent / "drivelash"


#: A guard against a hung subprocess, not a speed check (no absolute-time asserts): ``te evaluate``
#: on the quick campaign takes ≈ 1 min alone but exceeded 600 s under ``make test-slow``'s two
#: xdist workers while the other one trained (session 5: thread oversubscription on 2 cores).
HANG_GUARD_S = 3600.0


def _run(*args: str, timeout: float = HANG_GUARD_S) -> subprocess.CompletedProcess:
    return subprocess.run([str(EXE), *args], capture_output=True, text=True, timeout=timeout)


def test_fit_on_missing_campaign_is_a_one_line_error(tmp_path):
    r = _run("te", "fit", str(tmp_path / "nope"), "-o", str(tmp_path / "m"))
    assert r.returncode == 2, r.stderr
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert not (tmp_path / "m").exists()


def test_evaluate_refuses_a_pickle_model_dir(tmp_path):
    d = tmp_path / "m"
    d.mkdir()
    (d / "model.pkl").write_bytes(b"\x80\x04N.")
    r = _run("te", "evaluate", str(d), str(tmp_path / "camp"))
    assert r.returncode == 2 and "pickle" in r.stderr and "Traceback" not in r.stderr


@pytest.mark.slow
def test_fit_and_evaluate_on_a_quick_campaign(tmp_path):
    from drivelash.sim.rack_campaign import CampaignConfig, run_campaign

    camp = tmp_path / "camp"
    cfg = CampaignConfig.quick()
    run_campaign(camp, seed=3, config=cfg)
    model = tmp_path / "model"
    r = _run(
        "te", "fit", str(camp), "-o", str(model), "--holdout-loads", "", "--trials", "2", "--epochs", "6"
    )
    assert r.returncode == 0, r.stderr
    meta = json.loads((model / "model.json").read_text())
    assert meta["info"]["max_load"] == 3000.0
    # the CPU code path of the training is pinned, recorded and told (tests/te_learn/test_numerics.py)
    assert meta["info"]["numerics"]["pinned"] is True, meta["info"]["numerics"]
    assert "torch code path: ATen AVX2, MKL_CBWR=AVX2 (pinned" in r.stdout + r.stderr
    r = _run("te", "evaluate", str(model), str(camp))
    assert r.returncode == 0, r.stderr
    assert "stacked" in r.stdout and "hgb" in r.stdout
    ev = json.loads((model / "evaluation" / "evaluation.json").read_text())
    assert {"train", "extrapolation"} <= set(ev["summary"])
    assert (model / "evaluation" / "fig6_pos.png").stat().st_size > 10_000
