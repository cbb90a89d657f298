"""Messages about sub-mrad δ1 values and a rounding-negative δ1 (session 36; tester I's I5, I7).

I5: the estimator's warnings format gaps with fixed decimals in mrad (µm); on a 3 mrad gap a δ1
difference of 0.03 mrad printed "+0.0 mrad from the configured δ1 = 0.1 mrad". The terminal's
δ1 check line printed "consistent (data: 1.50 mrad)" beside "δ1 = 1.800 mrad" without saying why
a different value is consistent. I7: a δ1 computed as a zero in floating point (−8.5e-22) was
refused as "must be finite and >= 0".
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from drivelash import estimate_backlash  # noqa: E402
from drivelash.commands.estimate import _print_summary  # noqa: E402
from drivelash.errors import ParameterError  # noqa: E402
from drivelash.estimation import DeadzoneEstimator  # noqa: E402
from drivelash.params import DELTA1_ROUNDING, rounded_delta1  # noqa: E402
from drivelash.units import MICROMETRE, MRAD  # noqa: E402
from estimation.test_session36_delta1_consistent import small_gap_drive  # noqa: E402


@pytest.mark.parametrize(
    ("x", "spec", "text"),
    [
        (0.03e-3, "+.1f", "+0.03 mrad"),  # was "+0.0 mrad"
        (0.13e-3, ".1f", "0.13 mrad"),  # was "0.1 mrad"
        (-0.004e-3, "+.2f", "-0.004 mrad"),  # was "-0.00 mrad"
        # negative controls: two significant digits already shown, or zero, stay as they were
        (1.8e-3, ".1f", "1.8 mrad"),
        (12.34e-3, "+.2f", "+12.34 mrad"),
        (0.0, ".1f", "0.0 mrad"),
        (1.5e-3, ".3g", "1.5 mrad"),
    ],
)
def test_a_fixed_point_gap_keeps_two_significant_digits(x, spec, text):
    assert MRAD.f(x, spec) == text


def test_the_same_rule_in_micrometres():
    assert MICROMETRE.f(0.04e-6, "+.1f") == "+0.04 µm"
    assert MICROMETRE.f(20e-6, ".1f") == "20.0 µm"


SUMMARY = {
    "method": "default",
    "samples": 40000,
    "T_s": 5e-4,
    "delta": 3.3e-3,
    "delta1": 1.8e-3,
    "delta1_used": 1.8e-3,
    "delta_std": 0.15e-3,
    "excitation_ok": True,
    "reason": "40 crossings of the gap",
    "converged": True,
    "convergence_time_s": 2.0,
    "convergence_band_rad": 0.66e-3,
    "delta1_check_result": "consistent",
    "delta1_estimate": 1.5e-3,
    "delta1_check_bound": 0.6e-3,
    "warnings": [],
}


def test_a_consistent_delta1_check_beside_another_delta1_says_why(capsys):
    _print_summary(SUMMARY)
    out = " ".join(capsys.readouterr().out.split())
    assert (
        "δ1 check: consistent (data: 1.5 mrad, -0.3 mrad from δ1, within the check's tolerance; δ1 kept,"
        " the interval allows ±0.6 mrad for it)"
    ) in out, out


def test_negative_control_without_a_bound_the_line_is_short(capsys):
    _print_summary(SUMMARY | {"delta1_estimate": 1.8e-3, "delta1_check_bound": 0.0})
    out = " ".join(capsys.readouterr().out.split())
    assert "δ1 check: consistent (data: 1.8 mrad)" in out, out


def test_a_computed_zero_delta1_is_zero():
    """δ1 = −8.5e-22 is read as 0 by the notebook API and the class, with the same result as 0;
    −1 nrad (1000× the rounding allowance) is still refused."""
    drive, tr = small_gap_drive(1, 10e-3)
    dt = drive.drivetrain()
    a = estimate_backlash(tr, dt, -8.5e-22).summary
    b = estimate_backlash(tr, dt, 0.0).summary
    assert a["delta"] == b["delta"] and a["delta1"] == 0.0
    assert DeadzoneEstimator(dt, -8.5e-22, tr.T_s).delta1 == 0.0
    with pytest.raises(ParameterError, match="delta1"):
        estimate_backlash(tr, dt, -1e-9)
    with pytest.raises(ParameterError, match="delta1"):
        DeadzoneEstimator(dt, -1e-9, tr.T_s)
    assert rounded_delta1(-DELTA1_ROUNDING) == 0.0 and rounded_delta1(-2 * DELTA1_ROUNDING) < 0


# --- tester J (session 36) -------------------------------------------------------------


def test_small_keeps_two_significant_digits_below_one_unit():
    """J7: "uncertain by ±0.5 mrad … more than the 0.2 mrad" for a 0.511 mrad half-width."""
    assert MRAD.small(0.511e-3) == "0.51" and MRAD.small(0.198e-3) == "0.2"
    assert MRAD.small(1.04e-3) == "1.0" and MRAD.small(0.0) == "0.0"  # controls: ≥ 1, zero


def test_a_negative_zero_delta1_prints_as_zero():
    """J6: δ1 = −0.0 (or −8.5e-22) printed "δ1 = -0.000 mrad"; the summary now holds 0."""
    assert rounded_delta1(-0.0) == 0.0 and str(rounded_delta1(-0.0)) == "0.0"
    drive, tr = small_gap_drive(1, 10e-3)
    s = estimate_backlash(tr, drive.drivetrain(), -8.5e-22).summary
    assert s["delta1"] == 0.0 and str(s["delta1"]) == "0.0"


def test_a_consistent_check_by_the_torque_ratio_says_its_delta1_is_no_evidence(capsys):
    """J4: bench-0C with its true δ1 = 52.5 mrad printed "δ1 check: consistent (data: 49 mrad)" —
    a 3.5 mrad difference beyond the 1 mrad floor, "consistent" because the joint law fits the torque
    clearly worse, and no word of it."""
    s = SUMMARY | {
        "delta": 0.105,
        "delta1": 0.0525,
        "delta1_used": 0.0525,
        "delta1_estimate": 0.049,
        "delta1_check_bound": 0.0,
        "delta1_check_by_ratio": True,
    }
    _print_summary(s)
    out = " ".join(capsys.readouterr().out.split())
    assert (
        "δ1 check: consistent (data: 49 mrad — no evidence against δ1: the joint δ/δ1 law that gives it"
        " fits the shaft torque clearly worse)"
    ) in out, out


def test_an_unsettled_estimate_says_why_it_is_not_converged():
    """J5: bench-0C for 4 s — sufficient excitation, δ1 consistent, no warning, "not converged".
    Now a note names the settling test; negative control: 20 s converge without it."""
    from drivelash.sim.scenarios import get_scenario

    sc = get_scenario("bench-0C")
    short = estimate_backlash(sc.simulate(duration=4.0), sc.estimator_drivetrain, 0.0525).summary
    assert short["excitation_ok"] and not short["converged"]
    (note,) = [w for w in short["warnings"] if w.startswith("note: δ̂ has not settled")]
    assert "over the last 4 s, more than the" in note and "band a converged estimate" in note, note
    full = estimate_backlash(sc.simulate(), sc.estimator_drivetrain, sc.estimator_backlash.delta1).summary
    assert full["converged"] and not any("has not settled" in w for w in full["warnings"])
