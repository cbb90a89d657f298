"""``te import`` of passes that stand still holding the load at the stroke ends (tester H, TH12).

A CNC records the same quantised current while the axis stands at the stroke end holding the
load; that value was the column's extreme and the pass was refused as "saturated signal: …%
of samples sit at the minimum … (clipped recording?)". Now a held current at standstill is a
dwell; a current clipped while the table moves is refused as before.
"""

from __future__ import annotations

import dataclasses

from .synth import BENCH, K_T, standard_runs, write_axis
from .test_import_cli import SHORT, _invoke, _run


def _runs(**first):
    runs = [dataclasses.replace(r, **SHORT, hold=1.5) for r in standard_runs(loads=(0.0, 1500.0, 3000.0))]
    runs[0] = dataclasses.replace(runs[0], **first)
    return runs


def test_passes_that_hold_the_load_at_standstill_are_imported(tmp_path):
    axis = write_axis(tmp_path / "rec", _runs())
    text = (tmp_path / "rec" / "run00_geometric_0_pos.csv").read_text().splitlines()
    held = [line.rsplit(",", 1)[1] for line in text[1:]]
    # 2 s of one current value: 0.25 s before the 17.5 s pass and 0.25 + 1.5 s after it (10.3 %)
    assert held.count(held[-1]) == 2001 and held[0] == held[-1] and len(held) == 19500, held[-1]
    out = tmp_path / "camp"
    r = _invoke("te", "import", str(axis), "-o", str(out))
    assert r.exit_code == 0, r.output
    assert "saturated" not in r.output and (out / "manifest.json").exists()


def test_a_current_clipped_while_the_table_moves_is_still_refused(tmp_path):
    # the geometric pass's moving current is (F_CT r_eff / 0.95 + T_Cm) / K_T ± 5.6 mA: clipped
    # at its mean, half the moving samples sit at the maximum
    clip = (BENCH.F_CT * BENCH.r_eff / 0.95 + BENCH.T_Cm) / K_T
    axis = write_axis(tmp_path / "rec", _runs(clip=clip))
    out = tmp_path / "camp"
    r = _run("te", "import", str(axis), "-o", str(out))
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr, r.stderr
    line = r.stderr.strip()
    assert (
        line.startswith("drivelash: error: ")
        and "run00_geometric_0_pos.csv, column 'current_A', line " in line
    ), line
    assert "saturated signal: " in line, line
    assert f"of samples sit at the maximum {clip * K_T:.6g} (clipped recording?)" in line, line
    assert not out.exists()
