"""The stated loads against the measured motor torque: one rule (findings TH1, TH2, TH8 of tester H).

TH1: a 2500 N pass listed as the geometric (no-load) run was accepted (its torque equals the
2500 N runs', so the old order check, which only caught a reversed order, passed it) and put
+10.3 µm into the exported BACKLASH column. TH2: one pass labelled 0 N (or 2500 N) with the
torque of 2500 N (5000 N) passed silently. TH8: loads in kN were a warning blaming the torque
constant, and the 5000 N passes counted as 5 N training loads. Each case is one error naming
the file; the negative controls keep good campaigns (other efficiencies, friction growing with
speed, close loads) free of it.
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from pathlib import Path

import numpy as np

from drivelash.te.protocol.plausibility import check_runs

from .synth import BENCH, Run, record, standard_runs, write_axis

SHORT = {"lo": 0.05, "hi": 0.45}
EXE = Path(sys.executable).parent / "drivelash"


def _recs(loads=(0.0, 1000.0, 2000.0, 3000.0)):
    # 0: geo +1, 1: geo −1 (20 mm/s), then per load +1/−1 at 100 mm/s
    runs = [dataclasses.replace(r, **SHORT) for r in standard_runs(loads=loads)]
    return [record(r, f"run{i:02d}.csv") for i, r in enumerate(runs)]


def _check(recs):
    return check_runs(recs, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0, source="axis.toml")


def _torque_findings(rep):
    return [f for f in rep.findings if f.check in ("torque-load", "torque")]


def test_a_loaded_pass_listed_as_the_geometric_run_is_an_error_naming_it():
    recs = _recs()
    # TH1: the 2000 N pass of direction −1 (run07.csv) listed as the geometric run, the real one gone
    bad = [r for i, r in enumerate(recs) if i not in (1, 7)]
    bad.append(dataclasses.replace(recs[7], kind="geometric", load=0.0))
    errs = _torque_findings(_check(bad))
    assert len(errs) == 1 and errs[0].level == "error" and errs[0].file == "run07.csv", errs
    m = errs[0].message
    assert "at the stated 0 N (geometric)" in m and "a loaded pass listed as the geometric (no-load) run" in m
    # the lever puts it at its true load: (2000 N + friction F_CT)/0.95 on top of the 0 N runs' torque
    implied = float(m.split("puts it at about ")[1].split(" N")[0])
    assert abs(implied - 2000.0 / 0.95) < 5.0, m
    # negative control: the same campaign with its own geometric run
    assert _torque_findings(_check(recs)) == []


def test_a_single_mislabelled_load_is_an_error_naming_it():
    recs = _recs()
    # TH2: the 2000 N pass of direction +1 labelled 0 N; the 3000 N pass of direction −1 labelled 2000 N
    for i, load, true in ((6, 0.0, 2000.0), (9, 2000.0, 3000.0)):
        bad = list(recs)
        bad[i] = dataclasses.replace(recs[i], load=load)
        errs = _torque_findings(_check(bad))
        assert len(errs) == 1 and errs[0].level == "error" and errs[0].file == f"run{i:02d}.csv", errs
        m = errs[0].message
        assert f"at the stated {load:g} N (load)" in m and "the load label contradicts the torque" in m
        implied = float(m.split("puts it at about ")[1].split(" N")[0])
        assert abs(implied - true / 0.95) < 5.0, m


def test_loads_in_kN_are_one_error_naming_the_unit():
    recs = [dataclasses.replace(r, load=r.load / 1e3) for r in _recs()]  # TH8
    rep = _check(recs)
    errs = _torque_findings(rep)
    assert len(errs) == 2 and {f.level for f in errs} == {"error"}, errs  # one per direction
    assert all(f.file == "axis.toml" and "loads look like kN given as N" in f.message for f in errs)
    assert "per kN of the stated loads (0, 1, 2, 3 N)" in errs[0].message


def test_good_campaigns_are_not_flagged():
    # another efficiency (η = 0.6: slope 1.58 × the synthetic 0.95's), inside the slope band
    recs = _recs()
    low_eta = [dataclasses.replace(r, torque_m=r.torque_m * 0.95 / 0.6) for r in recs]
    assert _torque_findings(_check(low_eta)) == []
    # friction growing with speed: the 0 N runs at 100 mm/s 0.9 N·m above the geometric runs at
    # 20 mm/s (more than the 0.5 N·m noise term): equal loads at other speeds are not compared
    fast = [
        dataclasses.replace(r, torque_m=r.torque_m + r.direction * 0.9 * (np.abs(r.torque_m) > 0))
        if r.kind == "load"
        else r
        for r in recs
    ]
    assert _torque_findings(_check(fast)) == []
    # loads 100 N apart, repeats of one load at one speed
    close = _recs(loads=(0.0, 1000.0, 1100.0, 3000.0))
    rep = _check([*close, dataclasses.replace(close[4], label="again.csv", t=close[4].t + 0.0)])
    assert not [f for f in _torque_findings(rep) if f.check == "torque-load"]
    # a torque constant 3× off is still the warning it was (not a unit slip)
    three = [dataclasses.replace(r, torque_m=r.torque_m * 3.0) for r in recs]
    found = _torque_findings(_check(three))
    assert found and all(f.level == "warning" and "torque constant" in f.message for f in found), found


def test_te_import_refuses_a_loaded_geometric_run_with_one_line_and_nothing_written(tmp_path):
    runs = [dataclasses.replace(r, **SHORT) for r in standard_runs(loads=(0.0, 1500.0, 3000.0))]
    # the geometric run of direction −1 is a 1500 N pass recorded at the geometric run's speed
    runs[1] = Run("load", -1, 1500.0, 0.02, name="loaded.csv", **SHORT)
    axis = write_axis(tmp_path / "rec", runs)
    block = 'kind = "load"\ndirection = -1\nload = 1500.0\nvelocity = 0.02\nfile = "loaded.csv"'
    assert block in axis.read_text()
    geo = block.replace('"load"', '"geometric"').replace("1500.0", "0.0")
    axis.write_text(axis.read_text().replace(block, geo))
    out = tmp_path / "camp"
    r = subprocess.run([str(EXE), "te", "import", str(axis), "-o", str(out)], capture_output=True, text=True)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr, r.stderr
    assert "loaded.csv: implausible campaign" in r.stderr
    assert "a loaded pass listed as the geometric (no-load) run" in r.stderr
    assert not out.exists()
