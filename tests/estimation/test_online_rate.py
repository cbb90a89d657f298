"""The online estimate and its 95 % interval at a drive's usual trace rate (session 29).

The wear tracker estimates every recording at 1 kHz unless told otherwise (``[fleet]
estimate_rate_hz``), and stores δ̂ with its uncertainty. Measured here on the 18 bench
scenarios with their true parameters, at the simulator's 8 kHz and sliced to every 8th sample
(1 kHz, what a drive trace recorded at 1 kHz holds):

* 8 kHz: every δ̂ within 0.21 mrad, every 95 % interval holds the truth (18/18);
* 2 kHz: every δ̂ within 0.25 mrad, every interval holds the truth (18/18);
* 1 kHz: every δ̂ within 1 mrad (the accuracy goal; worst −0.567 mrad, bench-2C), but biased
  low by 0.27–0.57 mrad on the 186 and 105 mrad gaps (B, C; 0.30–0.58 before session 36's
  velocity-noise cut-off), and the interval misses the truth
  on 4 of 18 (0C by 4 µrad, 2C, 4B, 4C; on 9 before session 36 counted the δ1 check's difference)
  — a known miss, below. Over 20 noise seeds of bench-0B: mean error −0.31 mrad
  (spread 0.07) at 1 kHz, intervals ± 0.25 mrad, holding the truth 3/20 (8 kHz: −0.07 mrad,
  20/20) (``/work/team/diag29/cov.py bench-0B 20 1,8`` in session 29; not in the repo).

Reference: the scenarios' true δ (``delta_true`` column). The estimator's uncertainty
(:func:`drivelash.estimation.estimator._uncertainty`) has a resolution floor measured at 8 kHz
and no part for the sample period.
"""

from __future__ import annotations

import pandas as pd
import pytest

import drivelash as dl
from drivelash.sim.scenarios import list_scenarios

RECORDED = ["t", "theta_m", "omega_m", "theta_l", "omega_l", "torque_m"]
#: Every k-th sample of the simulator's 8 kHz.
STEP = {"8 kHz": 1, "2 kHz": 4, "1 kHz": 8}


@pytest.fixture(scope="module")
def runs() -> dict[str, list[tuple[str, float, float, float, float, bool]]]:
    """Per rate: (scenario, true δ, δ̂, interval low, interval high, converged) [rad]."""
    out: dict[str, list] = {r: [] for r in STEP}
    for sc in list_scenarios():
        if not sc.name.startswith("bench-"):
            continue
        tr = sc.simulate()
        df = pd.DataFrame({c: tr[c] for c in RECORDED})
        true = float(tr["delta_true"][-1])
        for rate, k in STEP.items():
            est = dl.estimate_backlash(
                df.iloc[::k].reset_index(drop=True), sc.estimator_drivetrain, sc.estimator_backlash.delta1
            )
            s = est.summary
            lo, hi = s["delta_interval_95"]
            out[rate].append((sc.name, true, s["delta"], lo, hi, s["converged"]))
    assert len(out["8 kHz"]) == 18
    return out


def _held(rows) -> list[str]:
    return [name for name, true, _, lo, hi, _ in rows if lo is not None and lo <= true <= hi]


@pytest.mark.slow
@pytest.mark.parametrize("rate", ["8 kHz", "2 kHz"])
def test_down_to_2khz_every_interval_holds_the_truth(runs, rate):
    assert len(_held(runs[rate])) == 18, [(r[0], (r[2] - r[1]) * 1e3) for r in runs[rate]]
    assert max(abs(r[2] - r[1]) for r in runs[rate]) < 0.26e-3


@pytest.mark.slow
def test_at_1khz_every_estimate_is_within_1_mrad(runs):
    errs = {r[0]: (r[2] - r[1]) * 1e3 for r in runs["1 kHz"]}
    assert max(abs(e) for e in errs.values()) < 1.0, errs
    # the bias the interval misses: low on the small gaps (B: 186 mrad, C: 105 mrad) only
    small = [e for n, e in errs.items() if not n.endswith("A")]
    assert all(e < -0.1 for e in small), errs


@pytest.mark.slow
def test_at_1khz_the_measured_miss(runs):
    """The figures the README quotes for the known miss below, at their values: on the B and C
    gaps δ̂ is 0.27–0.57 mrad low, and the interval holds the truth on 14 of the 18 scenarios (9
    before session 36: the δ1 check's bound, κ gain × its difference, widened the B and C ones)."""
    small = [(r[2] - r[1]) * 1e3 for r in runs["1 kHz"] if not r[0].endswith("A")]
    assert len(small) == 12 and -0.59 < min(small) and max(small) < -0.26, small
    assert len(_held(runs["1 kHz"])) == 14


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason="known miss: at 1 kHz (every 8th sample of the 8 kHz bench scenarios) the online 95 % "
    "interval holds the true δ on 14 of 18 scenarios (goal: 17 of 18; 8 and 2 kHz: 18 of 18). δ̂ is "
    "within 1 mrad everywhere but biased low by 0.27–0.57 mrad on the 186 and 105 mrad gaps, and "
    "the interval — the estimator's spread, δ1 check and a resolution floor measured at 8 kHz — "
    "has no part for the sample period. Cause not found: the learnt contact stiffness scale κ "
    "falls from 0.86 to 0.67 between 8 and 1 kHz on bench-0B, but also from 0.80 to 0.70 on "
    "bench-0A, where δ̂ stays unbiased (−0.15 mrad at both rates)",
)
def test_at_1khz_the_interval_holds_the_truth(runs):
    held = _held(runs["1 kHz"])
    assert len(held) >= 17, sorted(set(r[0] for r in runs["1 kHz"]) - set(held))


def test_below_2khz_the_result_says_its_interval_is_not_verified():
    """bench-0B (8 s) sliced to 1 kHz: the result carries the note naming the rate and the
    verified 2 kHz, and stays converged (a note does not block); negative control: sliced to
    2 kHz, no such note."""
    from drivelash.sim.scenarios import get_scenario

    sc = get_scenario("bench-0B")
    tr = sc.simulate(duration=8.0)
    df = pd.DataFrame({c: tr[c] for c in RECORDED})
    notes = {}
    for k in (8, 4):
        est = dl.estimate_backlash(
            df.iloc[::k].reset_index(drop=True), sc.estimator_drivetrain, sc.estimator_backlash.delta1
        )
        notes[k] = [w for w in est.warnings if "down to which the 95 % interval is verified" in w]
        if k == 8:
            assert est.summary["converged"], est.warnings
    assert len(notes[8]) == 1 and notes[8][0].startswith("note: the sample rate 1000 Hz is below the 2000 Hz")
    assert notes[4] == []
