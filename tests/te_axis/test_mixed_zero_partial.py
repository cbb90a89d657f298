"""Mixed position zeros are judged over the positions the runs share (tester H, TH4).

A pass whose trace stopped early was compared by its median TE over its own 100 mm with the
others' medians over the whole 400 mm stroke: with a 100 µm rack drift along the stroke it was
refused as "mixed position zeros between runs (homed in between?)" (+24.4 µm) although its zero
was the others'; a complete no-load run was warned for the load passes' shorter span. Now each
run's level is taken on the positions of the direction's longest run; a real zero shift of a
partial pass is still an error (negative control).
"""

from __future__ import annotations

import dataclasses

from drivelash.te.protocol.plausibility import check_runs

from .synth import BENCH, record, standard_runs

SHORT = {"lo": 0.05, "hi": 0.45}
DRIFT = 100e-6 / 0.4  # the rack's TE rises 100 µm over the 400 mm stroke (tester H's DP campaign)


def _check(partial=None, narrow_loads=False, zero_mm=0.0):
    runs = [dataclasses.replace(r, **SHORT) for r in standard_runs()]
    if narrow_loads:  # every load pass over 100 … 250 mm only, the geometric runs complete
        runs = [dataclasses.replace(r, lo=0.1, hi=0.25) if r.kind == "load" else r for r in runs]
    # two repeats of the 1000 N pass of direction +1 (50, 80 mm/s); the first one partial
    extra = [dataclasses.replace(runs[4], velocity=v) for v in (0.05, 0.08)]
    if partial:
        extra[0] = dataclasses.replace(extra[0], lo=partial[0], hi=partial[1], zero_mm=zero_mm)
    recs = [record(r, f"run{i:02d}.csv") for i, r in enumerate(runs + extra)]
    drifted = [dataclasses.replace(r, theta_m=r.theta_m - DRIFT * (r.x_T - 0.25) / BENCH.r_eff) for r in recs]
    rep = check_runs(drifted, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0, source="axis.toml")
    return [f for f in rep.findings if f.check == "mixed-zero"], rep


def test_a_partly_covered_pass_is_not_called_mixed_zeros():
    for part in ((0.35, 0.45), (0.05, 0.15), (0.2, 0.3)):
        mixed, rep = _check(part)
        assert mixed == [], (part, [f.line() for f in mixed])
        assert [f for f in rep.findings if f.check == "coverage" and f.file == "run10.csv"]  # still named
    mixed, _ = _check(narrow_loads=True)  # the complete geometric runs are not blamed either
    assert mixed == [], [f.line() for f in mixed]


def test_a_zero_shift_of_a_partial_pass_is_still_an_error():
    mixed, _ = _check((0.35, 0.45), zero_mm=0.05)  # homed 50 µm off, over 100 mm only
    assert len(mixed) == 1 and mixed[0].level == "error" and mixed[0].file == "run10.csv", mixed
    assert "TE offset +50.0 um from the 2 other runs of direction +1 at 1000 N" in mixed[0].message
    assert _check()[0] == []  # and the complete campaign with its drift has no finding
