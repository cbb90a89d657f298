"""``te update`` refuses passes beyond the model's trained torque range (tester H, TH3).

A 3000 N model updated on the same plan's 5000 N passes (−15.8 N·m, torque_max 8.84 N·m) refitted
stage 2 on loads it was never trained on, silently: ±2.2 µm of ripple over the whole no-load CNC
table. Now the passes are refused before any training, one line naming the file; passes at the
trained loads are not (negative control, without a refit: the check runs when the passes are read).
"""

from __future__ import annotations

from pathlib import Path

import pytest

import drivelash.te.learn.update as upd
from cli_runner import run_in_process
from drivelash.errors import DataError
from drivelash.te.protocol.campaign import load_campaign
from drivelash.te.runtime.persist import load_model, save_model

from .conftest import torque_of
from .test_update_cli import write_campaign


@pytest.fixture(scope="module")
def model_dir(small_trained, tmp_path_factory) -> Path:
    return save_model(small_trained, tmp_path_factory.mktemp("upd_t") / "m1")


def test_passes_above_the_trained_torque_are_refused_naming_them(model_dir, tmp_path, capsys):
    camp = write_campaign(tmp_path / "worn", load_model(model_dir), (0.0, 1500.0, 3000.0, 5000.0), 3.0)
    out = tmp_path / "m2"
    code, stdout, stderr = run_in_process(["te", "update", str(model_dir), str(camp), "-o", str(out)], capsys)
    text = stdout + stderr
    assert code == 2 and "Traceback" not in text and len(text.strip().splitlines()) == 1, text
    assert "pos_F5000.parquet: 2 pass(es) beyond the model's trained torque range" in text
    assert "|torque| ≤ 9 N·m" in text and "neg_F5000.parquet (5000 N" in text
    assert not out.exists()


def test_passes_at_the_trained_loads_are_accepted(model_dir, tmp_path):
    import numpy as np

    # the synthetic model's torque_max is 9 N·m, its training plan's heaviest passes (3000 N)
    # have 8.78 N·m: every pass of the plan is kept
    x = np.arange(0.01, 0.29, 5e-5)
    assert float(np.median(torque_of(3000.0, x))) < 9.0
    assert float(np.median(torque_of(3500.0, x))) > 9.0 * (1 + upd.UPDATE_TORQUE_SLACK)
    camp = write_campaign(tmp_path / "worn", load_model(model_dir), (0.0, 1500.0, 3000.0), 3.0)
    _, trained = upd.restore_trained(model_dir)
    runs = upd.runs_for_update(load_campaign(camp), trained)
    assert [len(runs[k]) for k in ("pos", "neg")] == [3, 3]
    # one load step beyond (3500 N: 10.2 N·m, 13 % above) is refused
    camp = write_campaign(tmp_path / "next", load_model(model_dir), (0.0, 3500.0), 3.0)
    with pytest.raises(DataError, match=r"2 pass\(es\) beyond the model's trained torque range"):
        upd.runs_for_update(load_campaign(camp), trained)
