"""``te score`` compares sections both passes cover and says why nothing was scored (tester H,
TH10 and TH11).

TH11: a compensated trace started 30 mm late was scored over the 50–150 mm section it covered in
part, a 3.5–5 % "improvement" from the positions alone. TH10: "no section scored (passes shorter
than one section?)" for 400 mm passes at other machine coordinates, and for 0.1 mm sections too
short for ``min_count`` samples. Negative control: passes of one stroke score every section
(and ``test_session31_import_score`` scores as before).
"""

from __future__ import annotations

import json

import numpy as np

from cli_runner import run_in_process

from .synth import BENCH, Run, write_axis

GAINS = "[gains]\nK_v = 230.0\nK_p = 15.7\nT_n = 0.003\ntorque_limit = 100.0\n"


def _campaign(tmp_path, capsys, tag, lo, hi, amp_mm):
    runs = [Run("load", d, 1000.0, 0.1, lo=lo, hi=hi) for d in (1, -1)]
    axis = write_axis(tmp_path / f"rec_{tag}", runs, GAINS)
    for f in axis.parent.glob("*.csv"):  # a path error on the scale, amp_mm growing along x
        head, *rows = f.read_text().splitlines()
        cells = [r.split(",") for r in rows]
        for c in cells:
            x = float(c[2])
            c[2] = f"{x + amp_mm * x / 250 * np.sin(2 * np.pi * x / (BENCH.tooth_pitch * 1e3)):.9f}"
        f.write_text("\n".join([head, *(",".join(c) for c in cells)]) + "\n")
    out = tmp_path / f"c_{tag}"
    code, _, err = run_in_process(["te", "import", str(axis), "-o", str(out), "--for-score"], capsys)
    assert code == 0, err
    return out


def _score(tmp_path, capsys, unc, comp, *extra):
    return run_in_process(
        ["te", "score", "--uncompensated", str(unc), "--compensated", str(comp), "-o", str(tmp_path / "s"),
         "--gains", "axis", *extra], capsys,
    )  # fmt: skip


def test_a_section_one_pass_covers_in_part_is_left_out_and_named(tmp_path, capsys):
    unc = _campaign(tmp_path, capsys, "unc", 0.05, 0.45, 5e-3)
    late = _campaign(tmp_path, capsys, "late", 0.08, 0.45, 5e-3)  # no compensation, started 30 mm late
    code, out, err = _score(tmp_path, capsys, unc, late)
    assert code == 0, err
    doc = json.loads((tmp_path / "s" / "score.json").read_text())
    text = out + err + json.dumps(doc)
    sections = (tmp_path / "s" / "improvement_sections.csv").read_text().splitlines()
    vals = [ln.split(",") for ln in sections if ln[:1] in ("1", "-")]
    assert vals and all(abs(float(v[-1])) < 0.01 for v in vals), vals  # the same pass: no improvement
    assert "left out: the compensated pass covers" in text, text[-2000:]


def test_no_section_scored_names_the_reason(tmp_path, capsys):
    unc = _campaign(tmp_path, capsys, "unc", 0.05, 0.45, 5e-3)
    apart = _campaign(tmp_path, capsys, "apart", 0.5, 0.9, 1e-3)
    code, out, err = _score(tmp_path, capsys, unc, apart)
    assert code == 2 and "no section scored: the compensated passes lie at other positions" in err, err
    assert "shorter than one section" not in err
    comp = _campaign(tmp_path, capsys, "comp", 0.05, 0.45, 1e-3)
    code, out, err = _score(tmp_path, capsys, unc, comp, "--section-mm", "0.1")
    assert code == 2 and "a 0.1 mm section holds at most 1 samples" in err, err
    # negative control: the same passes with 100 mm sections score every section
    code, out, err = _score(tmp_path, capsys, unc, comp)
    assert code == 0 and "left out" not in out + err, err
