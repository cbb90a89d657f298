"""Plausibility of a campaign: each typical mistake of a real recording is caught, named by file.

The synthetic axis of :mod:`.synth` (known TE, exact kinematics) is clean; each test spoils
one thing the way it happens on a machine and checks the one-line finding. Negative
control: the clean campaign gives no error and no warning except the ones stated.
"""

from __future__ import annotations

import dataclasses
import math
import re

import pytest

from drivelash.errors import DataError
from drivelash.te.protocol.plausibility import check_runs

from .synth import BENCH, record, standard_runs

SHORT = {"lo": 0.05, "hi": 0.45}


def _runs(**changes):
    return [dataclasses.replace(r, **SHORT, **changes) for r in standard_runs()]


def _check(runs, max_load=3000.0):
    recs = [record(r, f"run{i:02d}.csv") for i, r in enumerate(runs)]
    return check_runs(recs, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, max_load, source="axis.toml")


def test_clean_campaign_passes():
    rep = _check(_runs())
    assert rep.errors == [] and rep.warnings == []
    assert rep.valid_range == pytest.approx((0.05, 0.45), abs=1e-3)
    for r in rep.runs:  # the slope of x_T over x_M is the rack's 5 µm/m drift, no more
        assert r["ratio"] == pytest.approx(1.0, abs=2e-5)
    assert rep.directions["pos"]["torque_per_N"] / BENCH.r_eff == pytest.approx(1 / 0.95, rel=1e-3)


def _one(rep, check):
    found = [f for f in rep.findings if f.check == check]
    assert found, [f.line() for f in rep.findings]
    return found[0]


def test_flipped_encoder_sign_is_an_error_naming_the_file():
    runs = _runs()
    runs[3] = dataclasses.replace(runs[3], sign=-1)
    f = _one(_check(runs), "ratio")
    assert f.level == "error" and f.file == "run03.csv"
    assert "encoder sign" in f.message and "scale = -1" in f.message


def test_scale_zero_offset_is_an_error_with_the_offset_to_set():
    runs = _runs(zero_mm=1234.5)  # every run: the scale's zero is 1234.5 mm from the motor's
    rep = _check(runs)
    f = _one(rep, "zero")
    assert f.level == "error" and f.file == "run00.csv"
    # the measured TE is the 1234.5 mm zero plus the true TE of the drive (-16 µm on this run); the
    # offset is the zero all ten runs share, the drive's TE cancelled between the directions
    # (session 36, TH13 b: before, this run's own -1.23448 m)
    assert re.search(r"TE is \+1234\.4\d\d mm", f.message) and "offset = -1.2345 (m)" in f.message
    with pytest.raises(DataError, match=r"run00.csv: implausible campaign: TE is \+1234\.4"):
        rep.raise_errors()


def test_mixed_zeros_between_runs_are_caught():
    runs = _runs()
    runs[5] = dataclasses.replace(runs[5], zero_mm=0.8)  # one run homed differently (0.8 mm)
    f = _one(_check(runs), "mixed-zero")
    assert f.level == "error" and f.file == "run05.csv" and re.search(r"\+0\.(79|80)\d mm", f.message)
    runs[5] = dataclasses.replace(runs[5], zero_mm=0.2)
    f = _one(_check(runs), "mixed-zero")
    assert f.level == "warning" and f.file == "run05.csv"


def test_single_training_load_is_an_error():
    runs = [dataclasses.replace(r, **SHORT) for r in standard_runs(loads=(1500.0, 4000.0))]
    f = _one(_check(runs), "loads")
    assert f.level == "error" and f.file == "axis.toml"
    assert "only 1 training load(s) (1500 N" in f.message


def test_pass_over_a_quarter_of_the_travel_is_flagged():
    runs = _runs()
    runs[4] = dataclasses.replace(runs[4], lo=0.05, hi=0.15)  # 0.1 m of the 0.4 m recorded
    f = _one(_check(runs), "coverage")
    assert f.level == "warning" and f.file == "run04.csv" and "(25%)" in f.message


def test_positions_in_micrometres_are_caught():
    runs = _runs()
    recs = [record(r, f"run{i:02d}.csv") for i, r in enumerate(runs)]
    recs[0] = dataclasses.replace(recs[0], x_T=recs[0].x_T * 1e6)  # a campaign in µm, read as m
    rep = check_runs(recs, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0, source="axis.toml")
    f = _one(rep, "ratio")
    assert f.level == "error" and "micrometres" in f.message


def test_wrong_gearbox_ratio_and_torque_sign_and_sampling():
    runs = _runs()
    recs = [record(r, f"run{i:02d}.csv") for i, r in enumerate(runs)]
    rep = check_runs(recs, BENCH.r_eff * 16 / 10, BENCH.tooth_pitch, BENCH.travel, 3000.0)
    assert _one(rep, "ratio").level == "error" and "i_PG" in _one(rep, "ratio").message
    recs[4] = dataclasses.replace(recs[4], torque_m=-recs[4].torque_m)
    f = _one(check_runs(recs, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0), "torque")
    assert f.file == "run04.csv" and "torque sign" in f.message
    # 20 Hz at 100 mm/s: 5 mm between samples, the tooth mesh (13.3 mm pitch) aliases
    r, sub = record(runs[4], "run04.csv"), slice(None, None, 50)
    recs[4] = dataclasses.replace(
        r, t=r.t[sub], x_T=r.x_T[sub], theta_m=r.theta_m[sub], torque_m=r.torque_m[sub]
    )
    f = _one(check_runs(recs, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0), "sampling")
    assert f.level == "error" and f.file == "run04.csv" and math.isfinite(float(f.message.split(" Hz")[0]))


def test_one_file_listed_for_two_runs_is_an_error_naming_both():
    runs = _runs()
    recs = [record(r, f"run{i:02d}.csv") for i, r in enumerate(runs)]
    # run06.csv (load 2000 N, +1) listed again in place of run 08 (3000 N, +1)
    twice = [*recs[:8], dataclasses.replace(recs[6], load=3000.0), *recs[9:]]
    rep = check_runs(twice, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0, source="axis.toml")
    f = _one(rep, "duplicate")
    assert f.level == "error" and f.file == "run06.csv"
    assert "run 7 (load, direction +1, 2000 N) and run 9 (load, direction +1, 3000 N)" in f.message
    # the same samples under another name: named with the first file
    copy = [*recs[:8], dataclasses.replace(recs[6], label="copy.csv", load=3000.0), *recs[9:]]
    rep = check_runs(copy, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0, source="axis.toml")
    f = _one(rep, "duplicate")
    assert f.level == "error" and f.file == "copy.csv" and "same samples as run06.csv" in f.message
    # negative control: every file once → no duplicate finding
    rep = check_runs(recs, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0, source="axis.toml")
    assert not [x for x in rep.findings if x.check == "duplicate"]


def test_torque_contradicting_the_load_labels_is_an_error_naming_both_runs():
    runs = _runs()  # 0: geo +1, 1: geo −1, 2/3: 0 N, 4/5: 1000 N, 6/7: 2000 N, 8/9: 3000 N (+1/−1)
    recs = [record(r, f"run{i:02d}.csv") for i, r in enumerate(runs)]
    swapped = list(recs)  # 1000 N ↔ 3000 N labels of direction −1
    swapped[5] = dataclasses.replace(recs[5], load=3000.0)
    swapped[9] = dataclasses.replace(recs[9], load=1000.0)
    rep = check_runs(swapped, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0, source="axis.toml")
    errs = [f for f in rep.findings if f.check == "torque-load"]
    assert len(errs) == 1 and errs[0].level == "error" and errs[0].file == "run05.csv"
    # T = d·(F + F_CT)·r_eff/0.95 + d·T_Cm
    t_at = {F: (F + BENCH.F_CT) * BENCH.r_eff / 0.95 + BENCH.T_Cm for F in (0.0, 1000.0, 3000.0)}
    m = re.search(r"torque (\S+) N·m at the stated 3000 N \(load\) is below the (\S+) N·m of run09\.csv"
                  r" at 1000 N \(load\), direction -1", errs[0].message)  # fmt: skip
    assert m, errs[0].message
    assert float(m[1]) == pytest.approx(-t_at[1000.0], abs=0.02)  # −3.71 N·m
    assert float(m[2]) == pytest.approx(-t_at[3000.0], abs=0.02)  # −9.30 N·m
    # a loaded pass listed as the geometric run (geometric ↔ 3000 N files of direction +1)
    geo = list(recs)
    geo[0] = dataclasses.replace(recs[8], kind="geometric", load=0.0)
    geo[8] = dataclasses.replace(recs[0], kind="load", load=3000.0)
    rep = check_runs(geo, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0, source="axis.toml")
    errs = [f for f in rep.findings if f.check == "torque-load"]
    assert len(errs) == 1 and errs[0].file == "run00.csv"  # the records keep their file names
    assert "at the stated 3000 N (load)" in errs[0].message
    assert "of run08.csv at 0 N (geometric), direction +1" in errs[0].message
    # negative control: the clean campaign, and loads close together (100 N apart) in the right order
    rep = check_runs(recs, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0, source="axis.toml")
    assert not [f for f in rep.findings if f.check == "torque-load"]
    assert rep.directions["pos"]["torque_order_tolerance_Nm"] == 0.5
    close = [dataclasses.replace(r, **SHORT) for r in standard_runs(loads=(0.0, 1000.0, 1100.0, 3000.0))]
    assert not [f for f in _check(close).findings if f.check == "torque-load"]


def _repeats(shift_mm: float):
    """The standard runs plus two repeats of the 1000 N pass of direction +1 (50, 80 mm/s); the
    first repeat's scale zero shifted by ``shift_mm``."""
    runs = _runs()
    extra = [dataclasses.replace(runs[4], velocity=v, zero_mm=z) for v, z in ((0.05, shift_mm), (0.08, 0.0))]
    return [*runs, *extra]


def test_a_zero_offset_against_repeats_at_the_same_load_is_an_error():
    rep = _check(_repeats(0.03))  # 30 µm: below the 0.1 mm of the load-trend check, 1.5× the 20 µm limit
    f = _one(rep, "mixed-zero")
    assert f.level == "error" and f.file == "run10.csv"
    m = re.search(r"TE offset \+(\d+\.\d) um from the 2 other runs of direction \+1 at 1000 N", f.message)
    assert m and float(m[1]) == pytest.approx(30.0, abs=0.5), f.message
    assert "limit 20 um" in f.message
    with pytest.raises(DataError, match="run10.csv: implausible campaign: TE offset"):
        rep.raise_errors()
    f = _one(_check(_repeats(0.01)), "mixed-zero")  # 10 µm: doubtful
    assert f.level == "warning" and f.file == "run10.csv" and "+10.0 um" in f.message
    # negative control: repeats that agree give no finding at all
    rep = _check(_repeats(0.0))
    assert rep.errors == [] and rep.warnings == []


def test_the_refusal_names_the_further_errors():
    runs = _runs()
    runs[3] = dataclasses.replace(runs[3], sign=-1)
    runs[5] = dataclasses.replace(runs[5], sign=-1)
    rep = _check(runs)
    with pytest.raises(DataError) as exc:
        rep.raise_errors()
    msg = str(exc.value)
    assert msg.startswith("run03.csv: implausible campaign:")
    assert "(and 1 more error(s): run05.csv: ratio)" in msg
    # negative control: one error, no tail
    runs[5] = dataclasses.replace(runs[5], sign=1)
    with pytest.raises(DataError) as exc:
        _check(runs).raise_errors()
    assert "more error" not in str(exc.value)


def test_a_wrong_direction_label_is_named_as_such():
    runs = _runs()
    recs = [record(r, f"run{i:02d}.csv") for i, r in enumerate(runs)]
    recs[4] = dataclasses.replace(recs[4], direction=-1)  # a +1 pass (50 → 450 mm) listed as −1
    rep = check_runs(recs, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0, source="axis.toml")
    f = _one(rep, "direction")
    assert f.level == "error" and f.file == "run04.csv"
    assert "moves in direction +1 (x_T from 50.0 to 450.0 mm), the run is listed as direction -1" in f.message
    assert not [x for x in rep.findings if x.check == "torque"]  # no torque-sign advice for it
    # negative control: the clean campaign has no direction finding
    assert not [x for x in _check(_runs()).findings if x.check == "direction"]


def test_sign_advice_accounts_for_a_scale_already_set():
    runs = _runs()
    recs = [record(r, f"run{i:02d}.csv") for i, r in enumerate(runs)]
    recs[3] = dataclasses.replace(recs[3], theta_m=-recs[3].theta_m)
    recs[4] = dataclasses.replace(recs[4], torque_m=-recs[4].torque_m)
    args = (recs, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0)
    rep = check_runs(*args, column_scales={"theta_m": -1.0, "torque_m": -1.0})
    flipped = "already has scale = -1, which flips it: set scale = 1 on the {} column"
    assert flipped.format("theta_m") in _one(rep, "ratio").message
    assert flipped.format("torque_m") in _one(rep, "torque").message
    # negative control: without a scale in the mapping, the plain advice
    rep = check_runs(*args, column_scales={"theta_m": 1.0})
    assert "set scale = -1 on the theta_m column in [columns]" in _one(rep, "ratio").message
    assert "set scale = -1 on the torque_m column in [columns]" in _one(rep, "torque").message


def test_a_run_moving_more_than_10_percent_off_its_listed_velocity_is_a_warning():
    """docs/te-formats.md §2 lists "the listed velocity" among the checks: a run that moves more
    than 10 % (docs/assumptions.md, "TE campaign plausibility") off its [[runs]] velocity is a warning naming
    both speeds; 5 % off is not (negative control)."""
    runs = _runs()
    recs = [record(r, f"run{i:02d}.csv") for i, r in enumerate(runs)]
    v = recs[4].velocity
    off = list(recs)
    off[4] = dataclasses.replace(recs[4], velocity=1.25 * v)  # measured / listed = 0.8
    rep = check_runs(off, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0, source="axis.toml")
    f = _one(rep, "velocity")
    assert f.level == "warning" and f.file == "run04.csv" and rep.errors == []
    assert f"moves at {v * 1e3:.4g} mm/s, listed as {1.25 * v * 1e3:.4g} mm/s" in f.message
    near = list(recs)
    near[4] = dataclasses.replace(recs[4], velocity=1.05 * v)
    rep = check_runs(near, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0, source="axis.toml")
    assert not [x for x in rep.findings if x.check == "velocity"]
