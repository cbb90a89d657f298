"""The whole protocol on a small drive (demo campaign + small model): `make test-slow`.

The acceptance figures of the issue are measured by ``drivelash te validate`` on the full
campaign (closing note, docs/assumptions.md); this test runs the same code end to end on
the 0.4 m demo drive and checks the criteria that do not depend on the model's quality
beyond the training range (the demo model has no hyperparameter search).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def summary(tmp_path_factory):
    from drivelash.te.demo import small_model
    from drivelash.te.protocol.bench import ValidationConfig
    from drivelash.te.protocol.campaign import load_campaign
    from drivelash.te.protocol.validate import validate
    from drivelash.te.protocol.wear_demo import TreesUpdater
    from drivelash.te.runtime.persist import load_model

    cache = Path(os.environ.get("DRIVELASH_CACHE", tmp_path_factory.mktemp("cache"))) / "te-demo"
    camp_dir, model_dir = small_model(cache)
    out = tmp_path_factory.mktemp("validate")
    cfg = ValidationConfig(stroke=0.4, sine_amplitude=0.1, sine_periods=1.0, defect_center=0.30)
    from drivelash.report import te_figures

    s = validate(
        load_model(model_dir),
        load_campaign(camp_dir),
        out,
        cfg,
        TreesUpdater(n_trials=1, max_epochs=10),
        figures=te_figures,
    )
    assert json.loads((out / "summary.json").read_text())["acceptance"]
    for name in ("fig8_sine.png", "fig9_improvement.png", "monitoring.png", "improvement_sections.csv",
                 "te_table.json"):  # fmt: skip
        assert (out / name).is_file()
    return s


def test_in_range_improvement(summary):
    assert summary["passes"]["min_in_range_pass_average"] >= 0.60
    assert summary["passes"]["mean_in_range"] >= 0.75


def test_reversal_without_oscillation(summary):
    s = summary["sine"]
    assert s["reversal_reduction"] >= 0.80
    assert s["hf_ratio"] <= 1.0
    assert s["peak_v_c_mm_s"] <= s["v_c_limit_mm_s"]
    assert s["peak_v_c_torque_Nm"] < 0.1 * s["torque_limit_Nm"]


def test_monitoring_finds_the_defect_and_update_restores(summary):
    m = summary["monitoring"]
    assert m["defect_covered"]
    assert m["false_sections_per_m"] <= 1.0
    assert m["improvement_defect_section_after_update"] > m["improvement_defect_section_before_update"]
    assert m["improvement_defect_section_after_update"] >= m["improvement_mean_before_update"] - 0.1
