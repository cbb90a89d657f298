"""The zero advice says what it rests on (session 36, tester H, TH13 b).

Before, a zero error advised ``set offset = … (rad) on the theta_m column`` from the one run it
was found on — an offset in ``[columns]`` applies to every file, so for one run of ten homed 2 mm
off the advice would have moved the nine others 2 mm off; and the TE's constant part of a single
scored pass was called "mean of both directions' no-load TE" with an offset to add. Now the
offset is the zero the runs share (named with their number), a run alone says so, and a run at
another zero than the others is mixed zeros without an offset.
"""

from __future__ import annotations

import dataclasses
import re

import pytest

from drivelash.te.protocol.plausibility import check_runs

from .synth import BENCH, record, standard_runs

SHORT = {"lo": 0.05, "hi": 0.45}


def _check(zeros: dict[int, float], runs=None, for_score: bool = False):
    runs = runs or standard_runs()
    runs = [dataclasses.replace(r, **SHORT, zero_mm=zeros.get(i, 0.0)) for i, r in enumerate(runs)]
    recs = [record(r, f"run{i:02d}.csv") for i, r in enumerate(runs)]
    return check_runs(
        recs, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0, source="axis.toml", for_score=for_score
    )


def _zero(rep):
    return [f for f in rep.findings if f.check == "zero"]


def test_one_run_homed_off_gets_no_offset_for_every_file():
    rep = _check({3: 2.0})
    (err,) = [f for f in _zero(rep) if f.level == "error"]
    assert err.file == "run03.csv" and rep.errors[0] is err
    assert "set offset" not in err.message, err.message
    assert re.fullmatch(
        r"TE is \+2\.0\d\d mm \(limit 1 mm, te export's for a no-load TE\): this run's zero differs from"
        r" the 9 other run\(s\) \(median TE -0\.0\d\d … \+0\.0\d\d mm\): mixed position zeros \(homed in"
        r" between\?\) — an offset in \[columns\] applies to every file: home and record this run again,"
        r" or leave it out of \[\[runs\]\]",
        err.message,
    ), err.message


def test_a_zero_all_runs_share_is_advised_from_all_of_them():
    """Negative control: every run 2 mm off — one offset, named with the runs it rests on; set,
    the campaign has no zero finding left."""
    rep = _check(dict.fromkeys(range(10), 2.0))
    zero = _zero(rep)
    assert len(zero) == 10 and all(f.level == "error" for f in zero)
    offs = set()
    for f in zero:
        m = re.search(r"set offset = (-?\d+\.\d+) \(rad\) on the theta_m column", f.message)
        assert m and "(the zero of the 10 runs that share it, median TE +1.9" in f.message, f.message
        offs.add(m.group(1))
    assert len(offs) == 1  # one offset for every file, not one per run
    off = float(offs.pop())
    assert off * BENCH.r_eff == pytest.approx(2.0e-3, abs=5e-6)  # the common zero, backlash cancelled
    runs = [dataclasses.replace(r, **SHORT, zero_mm=2.0) for r in standard_runs()]
    recs = [record(r, f"run{i:02d}.csv") for i, r in enumerate(runs)]
    fixed = [dataclasses.replace(rc, theta_m=rc.theta_m + off) for rc in recs]
    rep = check_runs(fixed, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0, source="axis.toml")
    assert rep.errors == [] and not _zero(rep), [f.line() for f in rep.findings]


def test_a_single_pass_says_its_zero_rests_on_it_alone():
    rep = _check({0: 2.0}, runs=[standard_runs()[2]], for_score=True)
    (err,) = [f for f in _zero(rep) if f.level == "error"]
    assert "set offset = " in err.message
    assert err.message.endswith("or home both (from this run alone: no other run confirms the zero)")


def test_a_constant_part_from_one_direction_gives_no_offset():
    rep = _check({0: 0.2}, runs=[standard_runs()[2]], for_score=True)
    (w,) = [f for f in _zero(rep) if "constant part" in f.message]
    assert re.fullmatch(
        r"the TE's constant part is \+18\d\.\d um from direction \+1 alone \(1 run, run00\.csv\): it holds"
        r" half the backlash, which only the other direction cancels — record a pass in direction -1"
        r" before offsetting the theta_m column \(the CNC tables take the constant part as it is\)",
        w.message,
    ), w.message
    assert "mean of both directions" not in w.message and " rad " not in w.message
    # negative control: both directions recorded — the offset is advised
    both = _check({0: 0.2, 1: 0.2}, runs=standard_runs()[2:4], for_score=True)
    (w,) = [f for f in _zero(both) if "constant part" in f.message]
    assert (
        "mean of both directions' no-load TE" in w.message and "rad to the offset of the theta_m" in w.message
    )
