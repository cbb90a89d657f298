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


# --- session 36, tester J, J1: the runs' zeros are clustered once (a partition) -------------------

_OFFSET = re.compile(r"set offset = (-?\d+\.\d+) \(rad\) on the theta_m column")


def _errors(rep):
    return [f for f in _zero(rep) if f.level == "error"]


def test_a_minority_sharing_a_wrong_zero_gets_no_offset_for_every_file():
    """2 of 10 runs homed 2 mm off: an offset in [columns] would move the 8 good runs."""
    rep = _check({3: 2.0, 7: 2.0})
    errs = _errors(rep)
    assert [f.file for f in errs] == ["run03.csv", "run07.csv"]
    for f in errs:
        assert "set offset" not in f.message, f.message
        assert re.fullmatch(
            r"TE is \+2\.0\d\d mm \(limit 1 mm, te export's for a no-load TE\): this run's zero is shared"
            r" by 2 of the 10 runs \(run03\.csv, run07\.csv; median TE \+2\.0\d\d … \+2\.0\d\d mm\), the 8"
            r" other run\(s\) sit at another zero \(median TE -0\.0\d\d … \+0\.0\d\d mm\): mixed position"
            r" zeros \(homed in between\?\) — an offset in \[columns\] applies to every file: home and"
            r" record these runs again, or leave them out of \[\[runs\]\]",
            f.message,
        ), f.message
    # half of the runs is no majority either
    half = _errors(_check(dict.fromkeys(range(5), 2.0)))
    assert len(half) == 5 and not any("set offset" in f.message for f in half)
    assert all(
        "shared by 5 of the 10 runs (run00.csv, run01.csv, run02.csv, run03.csv, …;" in f.message
        for f in half
    )


def test_drifting_zeros_are_named_drifting_without_an_offset():
    """Zeros +1.5 … +2.4 mm in 0.1 mm steps: no common zero, one advice for every run (it was four
    offsets from overlapping groups of 5/7/9/9/7/5 runs)."""
    rep = _check({i: 1.5 + 0.1 * i for i in range(10)})
    errs = _errors(rep)
    assert len(errs) == 10
    tails = set()
    for f in errs:
        assert "set offset" not in f.message and " rad" not in f.message, f.message
        head, tail = f.message.split("): ", 1)
        tails.add(tail)
    (tail,) = tails  # the same advice in every file
    assert re.fullmatch(
        r"the zeros of all 10 runs drift \(median TE \+1\.4\d\d … \+2\.4\d\d mm, no gap over 0\.5 mm between"
        r" neighbours, 0\.9\d\d mm end to end\): no common zero \(an encoder or scale slipping, homed in"
        r" between\?\) — an offset in \[columns\] applies to every file and none fits these runs: home both"
        r" and record them again",
        tail,
    ), tail


@pytest.mark.parametrize(
    "zeros",
    [
        {3: 2.0, 7: 2.0},
        {i: 1.5 + 0.1 * i for i in range(10)},
        dict.fromkeys(range(6), 2.0),
        {**dict.fromkeys(range(10), 1.5), 4: 1.2},
        {**dict.fromkeys(range(4), 3.0), **dict.fromkeys(range(4, 10), 1.5)},
    ],
)
def test_one_advice_per_campaign(zeros):
    """Whatever the zeros: at most one offset value, and the runs given it are a majority."""
    errs = _errors(_check(zeros))
    offs = {m.group(1) for f in errs if (m := _OFFSET.search(f.message))}
    assert len(offs) <= 1, offs
    shares = {
        m.group(1) for f in errs if (m := re.search(r"the zero of the (\d+) runs that share it", f.message))
    }
    assert all(int(n) > 5 for n in shares), shares


def test_a_majority_zero_gets_the_offset_and_names_the_runs_elsewhere():
    """Negative control: 6 of 10 runs at +2 mm — the offset of their zero, the 4 others named."""
    errs = _errors(_check(dict.fromkeys(range(6), 2.0)))
    assert [f.file for f in errs] == [f"run0{i}.csv" for i in range(6)]
    offs = {_OFFSET.search(f.message).group(1) for f in errs}
    (off,) = offs
    assert float(off) * BENCH.r_eff == pytest.approx(2.0e-3, abs=5e-5)
    for f in errs:
        assert f.message.endswith(
            "; the 4 other run(s) (run06.csv, run07.csv, run08.csv, run09.csv) sit at another zero: home and"
            " record them again, or leave them out of [[runs]])"
        ), f.message
        assert "(the zero of the 6 runs that share it, median TE +1.9" in f.message, f.message
