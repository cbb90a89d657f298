"""Which unconverged estimates a wear trend and its alarms may use (session 32 tester F, F5/F6).

F5: an estimate the estimator calls "not converged — do not use" because of a blocking warning
(contact stiffness at the limit of what the law corrects) was trended and alarmed with its tiny
stated σ: bench-0B, K_S stated 5×, 1 kHz: 188.37 ± 0.08 mrad (95 %) for a true 186.0, alarm at
188. An unsettled δ̂ (KUKA KR300 rec_C axis 1) moved 1.41 mrad in its last window with ±0.27.
F6: at 1 kHz the excitation information of bench-0B with K_S stated 6× read 0.0217 (8 kHz 0.0100,
2 kHz 0.0068: insufficient) and the estimate was "converged" 3.09 mrad off with ±0.75.
Reference: the simulator's true δ (``delta_true``).
"""

from __future__ import annotations

import dataclasses
from datetime import datetime, timedelta

import pytest

import drivelash as dl
from drivelash.sim.scenarios import get_scenario
from drivelash.wear.alarms import axis_alarms
from drivelash.wear.estimate import unconverged_cause
from drivelash.wear.trend import analyse, usable
from drivelash.wear.words import UNCONVERGED_MARK

T0 = datetime(2026, 1, 5, 8, 0)


def _bench0b(K_S_factor: float, step: int) -> tuple[dl.BacklashEstimate, float]:
    """bench-0B, 10 s, seed 1, every ``step``-th sample of 8 kHz, K_S stated ``K_S_factor``×."""
    sc = get_scenario("bench-0B")
    df = sc.simulate(duration=10.0, seed=1).to_pandas().iloc[::step].reset_index(drop=True)
    dt = dataclasses.replace(sc.estimator_drivetrain, K_S=sc.estimator_drivetrain.K_S * K_S_factor)
    return dl.estimate_backlash(df, dt, sc.estimator_backlash.delta1), float(df["delta_true"].iloc[-1])


def _row(res, std, i: int = 0) -> dict:
    """A store row as :func:`drivelash.wear.estimate.estimate_recording` writes it."""
    reason = res.reason
    if res.excitation_ok and not res.converged:
        cause, std = unconverged_cause(res, std)
        reason = f"{reason}{UNCONVERGED_MARK}{cause}"
    return {
        "status": "ok",
        "excitation_ok": res.excitation_ok,
        "converged": res.converged,
        "delta": res.delta,
        "delta_std": std,
        "start_time": T0 + timedelta(days=i),
        "path": f"rec_{i}.parquet",
        "reason": reason,
    }


def _axis(thr: float) -> dict:
    return {"name": "M1/B", "threshold_rad": thr, "horizon_days": 60.0, "not_excited_alarm": 3}


def test_blocked_unconverged_estimate_enters_no_trend_and_raises_no_alarm():
    est, true = _bench0b(5.0, 8)  # 1 kHz, K_S 5x: κ at its limit (a blocking warning)
    assert est.excitation_ok and not est.converged
    # confidently wrong: the error ten times the 95 % half-width (measured 2.37 mrad against
    # ±0.08 mrad until session 35; 1.99 against ±0.17 since the Δθ reconstruction's cut-off
    # follows the velocity noise — K_S 5× makes θ_def 5× smaller, ω_c 31.4 → 36.2 rad/s)
    assert est.delta - true > 10 * 1.96 * est.summary["delta_std"] > 0
    row = _row(est.result, est.summary["delta_std"])
    assert row["delta_std"] is None and "contact stiffness" in row["reason"].partition(UNCONVERGED_MARK)[2]
    assert not usable(row)
    trend, used = analyse([row], 0.188)
    assert used == []
    assert not [a for a in axis_alarms(_axis(0.188), [row], trend) if a.kind == "threshold"]


def test_low_rate_information_near_its_minimum_is_not_converged():
    est, true = _bench0b(6.0, 8)  # 1 kHz, K_S 6x: information 0.0217 (0.0068 at 2 kHz)
    assert abs(est.delta - true) > 3e-3
    assert not est.converged
    w = [x for x in est.result.warnings if x.startswith("at 1000 Hz the excitation information")]
    assert len(w) == 1 and "≥ 2000 Hz" in w[0]
    row = _row(est.result, est.summary["delta_std"])
    assert not usable(row) and row["delta_std"] is None


@pytest.mark.parametrize("name", ["bench-0A", "bench-0B", "bench-0C"])
def test_negative_control_true_parameters_stay_converged_at_1khz(name):
    sc = get_scenario(name)
    df = sc.simulate(duration=10.0, seed=1).to_pandas().iloc[::8].reset_index(drop=True)
    est = dl.estimate_backlash(df, sc.estimator_drivetrain, sc.estimator_backlash.delta1)
    assert est.converged and not [w for w in est.result.warnings if not w.startswith("note:")]
    assert est.result.extra["sigma_fraction"] >= 0.25


def test_uncertain_unconverged_estimates_still_enter_weighted():
    """Negative control: the session-9 case (coarse encoder, 'uncertain by ±2.4 mrad' the only
    blocking warning) is still trended; an unsettled one with its widened σ too, and its alarm
    names the cause."""
    rows = [
        {
            "status": "ok",
            "excitation_ok": True,
            "converged": False,
            "delta": d,
            "delta_std": 1.2e-3,
            "start_time": T0 + timedelta(days=7 * i),
            "path": f"rec_{i}.csv",
            "reason": f"18 crossings{UNCONVERGED_MARK}"
            + (
                "not settled: δ̂ moved 2.00 mrad over its last window"
                if i == 8
                else "the estimate is uncertain"
            ),
        }
        for i, d in enumerate([0.0937, 0.1058, 0.1168, 0.1280, 0.1397, 0.1510, 0.1626, 0.1741, 0.1852])
    ]
    trend, used = analyse(rows, 0.20)
    assert len(used) == 9
    two = rows[7:]  # too few for a trend: the latest estimate alone is above 175.3 mrad
    msg = [
        a.message for a in axis_alarms(_axis(0.1753), two, analyse(two, 0.1753)[0]) if a.kind == "threshold"
    ]
    assert len(msg) == 1 and "(not settled: δ̂ moved 2.00 mrad over its last window)" in msg[0]


#: Axis 1 of the KR300 with the authors' parameters where known (``para`` in the MAT file) and a
#: plausible J_l = 3000 kg·m² (session 32 tester F's drive file for this case; N = 1798/7).
KR300_AXIS1 = """
[drivetrain]
N = 256.85714285714283
J_m = 0.0364
J_l = 3000.0
K_S = 870000.0
D_S = 0.0
T_Cm = 1.4
T_Cl = 50.0
beta_m = 0.03
beta_l = 100.0

[backlash]
delta1 = 0.001

[columns."rec.time_cont"]
column = "t"
unit = "s"

[columns."rec.act_pos_mot_deg(1,:)"]
column = "theta_m"
unit = "deg"
scale = 256.85714285714283

[columns."rec.act_pos_se_deg(1,:)"]
column = "theta_l"
unit = "deg"

[columns."rec.act_vel_mot_deg_per_s(1,:)"]
column = "omega_m"
unit = "deg/s"
scale = 256.85714285714283

[columns."rec.act_vel_se_deg_per_s(1,:)"]
column = "omega_l"
unit = "deg/s"

[columns."rec.act_torque_abs_nm(1,:)"]
column = "torque_m"
unit = "N·m"
"""


def test_unsettled_estimate_enters_the_trend_only_with_its_last_window_movement(tmp_path):
    from realdata import shared_data

    drive = tmp_path / "kr300_axis1.toml"
    drive.write_text(KR300_AXIS1, encoding="utf-8")
    est = dl.estimate_backlash(str(shared_data("kuka-kr300", "rec_C.mat")), str(drive))
    r = est.result
    assert not r.extra["settled"] and not est.converged and est.excitation_ok
    move = r.extra["window_movement"]
    assert move > 1e-3  # 1.41 mrad, stated ±0.27 mrad (95 %)
    assert 1.96 * est.summary["delta_std"] < move
    row = _row(r, est.summary["delta_std"])
    assert 1.96 * row["delta_std"] >= move and usable(row)
    assert "not settled: δ̂ moved 1.41 mrad" in row["reason"]
    # the tester's 1 mrad threshold: 1.477 mrad − 1.645 σ is below it now — no single-estimate alarm
    trend, _ = analyse([row], 1e-3)
    assert not [a for a in axis_alarms(_axis(1e-3), [row], trend) if a.kind == "threshold"]
