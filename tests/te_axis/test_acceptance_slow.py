"""Acceptance of issue 12 items 1-3 and 7 on the virtual bench (``make test-slow``).

* Round trip: the seed-0 campaign written as CNC traces (ms, mm, encoder counts, current in A)
  and brought back with ``te import`` fits a model whose held-out and extrapolation MAE are
  within 2 % of the model fitted on the simulator campaign.
* The quick path with every default improves the path error by >= 60 % on average and makes
  no section worse.
* A custom axis (3 mm module, 24 teeth, i = 10, 1.2 m travel) runs campaign -> fit -> validate
  with >= 75 % average improvement.
* A model directory moved elsewhere, its campaign deleted: export, the compensator and validate
  give identical results.
"""

from __future__ import annotations

import csv
import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.slow

EXE = [sys.executable, "-m", "drivelash.cli"]


def _cli(*args: str, cwd: Path) -> None:
    r = subprocess.run([*EXE, *args], capture_output=True, text=True, cwd=cwd)
    assert r.returncode == 0, r.stderr[-3000:]


def _summary(v: Path) -> dict:
    return json.loads((v / "summary.json").read_text())


def _sections(v: Path) -> list[float]:
    with (v / "improvement_sections.csv").open() as fh:
        return [float(r["improvement"]) for r in csv.DictReader(fh)]


def test_quick_path_with_defaults(te_quick):
    s = _summary(te_quick["V"])["passes"]
    sections = _sections(te_quick["V"])
    print(f"quick path: average {s['average_improvement']:.3f}, worst section {min(sections):.3f}")
    assert s["average_improvement"] >= 0.60
    assert min(sections) > 0.0  # no section made worse
    meta = json.loads((te_quick["M"] / "model.json").read_text())
    assert meta["campaign"]["holdout_loads"] == []  # 0/2500 N both train (2 in-range loads)
    assert meta["valid_range"]["x_max"] - meta["valid_range"]["x_min"] == pytest.approx(0.4, abs=1e-3)
    # the passes ran inside the 0.4 m the campaign recorded, not 0.6 m
    edges = [r for r in csv.DictReader((te_quick["V"] / "improvement_sections.csv").open())]
    assert max(float(r["x_end"]) for r in edges) <= meta["valid_range"]["x_max"] + 1e-9


def test_custom_axis_campaign_fit_validate(te_custom_axis):
    man = json.loads((te_custom_axis["C"] / "manifest.json").read_text())
    g = man["axis"]["geometry"]
    assert (g["m_n"], g["n_t"], g["i_PG"], g["travel"]) == (0.003, 24, 10.0, 1.2)
    s = _summary(te_custom_axis["V"])["passes"]
    avg, inr, out = (s[k] for k in ("average_improvement", "min_in_range_pass_average",
                                    "min_beyond_range_pass_average"))  # fmt: skip
    print(f"custom axis: average {avg:.3f}, worst in-range pass {inr:.3f}, worst beyond {out:.3f}")
    assert s["average_improvement"] >= 0.75


def test_custom_axis_sine_reversals(te_custom_axis):
    """te validate's own sine goals on the custom axis (was a known miss, -124 % / 5.4x: the
    compensator's release threshold was the paper's bench's motor torque; converted to the
    axis' r_eff in compensator_for, the ideal model gives -90 % / 0.32x, tests/te_comp/test_validate.py)."""
    sine = _summary(te_custom_axis["V"])["sine"]
    red, hf = sine["reversal_reduction"], sine["hf_ratio"]
    print(f"custom axis sine: reversal reduction {red:.3f}, hf ratio {hf:.2f}")
    assert red >= 0.80
    assert hf <= 1.0


def test_moved_model_gives_identical_results(te_quick, tmp_path):
    from drivelash.te.runtime import Compensator, build_table, load_model

    src = te_quick["M"]
    moved = tmp_path / "elsewhere" / "model"
    shutil.copytree(src, moved)
    # exports from both places, the campaign only in the original's neighbourhood
    _cli("te", "export", str(src), "-o", str(tmp_path / "a.json"), cwd=tmp_path)
    camp_copy = tmp_path / "C"  # the campaign is gone from the moved model's world
    assert not camp_copy.exists()
    _cli("te", "export", "model", "-o", "../b.json", cwd=moved.parent)
    a = json.loads((tmp_path / "a.json").read_text())
    b = json.loads((tmp_path / "b.json").read_text())
    for k in ("grid", "compensator", "te_um"):
        assert a[k] == b[k]
    assert a["compensator"]["J_flank"] > 0 and a["compensator"]["T_C"] > 0  # drive data, not zeros
    # the compensator on both loaded models: identical outputs
    outs = []
    for d in (src, moved):
        m = load_model(d)
        vr = m.context.valid_range
        tab = build_table(m, vr.x_min, vr.x_max, 0.2e-3, vr.torque_max, 9)
        c = Compensator(tab, m.context.compensator, 1)
        x = np.linspace(vr.x_min, vr.x_max, 2001)
        n = x.size - 1
        outs.append(c.run(x, np.full(n, 3.0), np.full(n, 5.0), np.zeros(n)))
    for u, v in zip(outs[0], outs[1], strict=True):
        assert np.array_equal(u, v)
    # validate without any campaign: the drive is rebuilt from the model (and its training
    # campaign regenerated for the update demo)
    _cli("te", "validate", "model", "-o", "../V", "--quick", cwd=moved.parent)
    s0, s1 = _summary(te_quick["V"]), _summary(tmp_path / "V")  # -o ../V from elsewhere/
    assert s0["passes"] == s1["passes"]
    assert s0["sine"] == s1["sine"]
    assert s0["monitoring"]["defect_covered"] == s1["monitoring"]["defect_covered"]
    assert s1["monitoring"]["improvement_defect_section_after_update"] == pytest.approx(
        s0["monitoring"]["improvement_defect_section_after_update"], abs=1e-9
    )


def test_round_trip_through_cnc_traces(te_seed0, tmp_path):
    """The seed-0 campaign as CNC traces -> te import -> te fit: MAE within 2 % of the simulator model."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from drivelash.te.protocol.campaign import load_campaign
    from te_axis.cnc import export_cnc

    axis = export_cnc(load_campaign(te_seed0["C"]), tmp_path / "cnc")
    _cli("te", "import", str(axis), "-o", "C2", cwd=tmp_path)
    _cli("te", "fit", "C2", "-o", "M2", cwd=tmp_path)
    _cli("te", "evaluate", "M2", "C2", "-o", "E2", cwd=tmp_path)
    e1 = json.loads((te_seed0["E"] / "evaluation.json").read_text())["summary"]
    e2 = json.loads((tmp_path / "E2" / "evaluation.json").read_text())["summary"]
    for split in ("held-out", "extrapolation"):
        m1, m2 = e1[split]["mae"]["stacked"], e2[split]["mae"]["stacked"]
        print(
            f"{split}: simulator campaign {m1:.4f} um, imported CNC traces {m2:.4f} um ({m2 / m1 - 1:+.2%})"
        )
        assert abs(m2 / m1 - 1) <= 0.02
    meta = json.loads((tmp_path / "M2" / "model.json").read_text())
    assert meta["campaign"]["source"] == "imported" and meta["simulator"] is None
    assert meta["campaign"]["holdout_loads"] == [1000.0, 2500.0]
