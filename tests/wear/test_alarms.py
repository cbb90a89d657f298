"""Alarms on excited but unconverged estimates and on a jump at the latest recording
(exploratory findings on ``track status``: a wearing axis shown as "not excited"; a jump above
the threshold on the latest recording gave no model and no alarm)."""

from __future__ import annotations

from datetime import datetime, timedelta

import numpy as np

from drivelash.wear.alarms import axis_alarms
from drivelash.wear.trend import analyse

T0 = datetime(2026, 1, 5, 6, 0)


def _rows(deltas, std, converged=True, excited=True):
    return [
        {
            "status": "ok",
            "excitation_ok": excited,
            "converged": converged,
            "delta": d,
            "delta_std": std,
            "start_time": T0 + timedelta(days=7 * i, minutes=13 * i),
            "path": f"rec_{i:03d}.csv",
            "reason": "18 crossings of the gap; information during 35 % of the last window",
        }
        for i, d in enumerate(deltas)
    ]


def _axis(threshold):
    return {"name": "M02/Y", "threshold_rad": threshold, "horizon_days": 60.0, "not_excited_alarm": 3}


#: δ̂ of the tester's M02/Y (rad), 2048-count encoder: σ ≈ 1.2 mrad, 95 % ±2.4 mrad > 2 mrad claim
M02Y = [0.09368, 0.10578, 0.11684, 0.12799, 0.13965, 0.15104, 0.16259, 0.17414, 0.18515]


def _alarms(rows, thr):
    trend, used = analyse(rows, thr)
    return trend, used, {a.kind: a for a in axis_alarms(_axis(thr), rows, trend)}


def test_excited_unconverged_estimates_are_trended_and_raise_the_threshold_alarm():
    rows = _rows(M02Y, 1.2e-3, converged=False)
    trend, used, al = _alarms(rows, 0.1753)
    assert len(used) == 9 and trend.model == "linear"
    assert "not_excited" not in al and "not_converged" not in al
    assert "threshold" in al
    # fitted δ at the latest recording: the series' own linear trend, 185.1 mrad ± the noise
    now = 1e3 * float(trend.curve(trend.t[-1:])[0][0])
    assert abs(now - 185.1) < 0.5
    # negative control: the same axis with a threshold far above -> a forecast, no threshold alarm
    trend, used, al = _alarms(rows, 0.30)
    assert "threshold" not in al and len(used) == 9 and trend.forecast.t_cross is not None


def test_unconverged_without_usable_uncertainty_is_its_own_alarm_not_unexcited():
    # σ = 260 mrad (seen in the tester's M01/X): no information; it must not read "not excited"
    rows = _rows(M02Y[:4], 0.26, converged=False)
    trend, used, al = _alarms(rows, 0.1753)
    assert used == [] and "not_excited" not in al
    assert al["not_converged"].message.startswith("M02/Y: the last 4 recordings gave estimates not converged")
    # ... but the latest estimate (185 mrad) above a 100 mrad threshold by far more than 1.645 σ?
    # 0.128 - 1.645*0.26 < 0.1: no threshold alarm from a meaningless estimate
    assert "threshold" not in _alarms(rows, 0.10)[2]
    # negative control: truly unexcited recordings keep the not_excited wording
    al = _alarms(_rows(M02Y[:4], None, converged=False, excited=False), 0.1753)[2]
    assert "not_excited" in al and "did not excite the deadzone" in al["not_excited"].message


def test_unconverged_estimate_above_the_threshold_alarms_even_without_a_trend():
    rows = _rows([0.1790, 0.1851], 1.2e-3, converged=False)  # two: too few for a model
    trend, used, al = _alarms(rows, 0.1753)
    assert trend.model is None
    msg = al["threshold"].message
    assert "latest estimate 185.10 ± 1.20 mrad" in msg and "uncertainty ±2.35 mrad" in msg
    # negative control: 177 mrad is within 1.645 σ (2.0 mrad) of the threshold: no alarm yet
    assert "threshold" not in _alarms(_rows([0.1760, 0.1770], 1.2e-3, converged=False), 0.1753)[2]


#: The tester's j3: 5 recordings of linear wear, the 6th jumps 39.8 -> 65.2 mrad (σ 0.1 mrad)
J3 = [0.034986, 0.036113, 0.037451, 0.038546, 0.039837, 0.065191]


def test_jump_on_the_latest_recording_is_one_outlier_and_alarms_above_the_threshold():
    rows = _rows(J3, 1.05e-4)
    trend, used, al = _alarms(rows, 0.050)
    assert len(used) == 6
    # only the jump is left out (all 6 were: the jump tilted every neighbour's local line)
    assert trend.inlier.tolist() == [True] * 5 + [False]
    assert trend.model == "linear"
    assert "latest estimate 65.19 ± 0.11 mrad" in al["threshold"].message
    assert "the next recording decides" in al["threshold"].message
    # negative control: the 6th continues the trend -> no outlier and no threshold alarm
    calm = [*J3[:5], 0.041]
    trend, used, al = _alarms(_rows(calm, 1.05e-4), 0.050)
    assert trend.inlier.all() and "threshold" not in al


def test_isolated_outlier_still_flagged_alone_in_the_middle():
    y = np.array([30.0, 31.0, 32.0, 33.0, 34.0, 50.0, 36.0, 37.0, 38.0, 39.0]) * 1e-3
    trend, _, _ = _alarms(_rows(list(y), 1e-4), 0.2)
    assert (~trend.inlier).nonzero()[0].tolist() == [5]


def test_correct_latest_estimate_on_accelerating_wear_after_a_gap_stays_in_the_fit():
    """README flow (simulate fleet --machines 2 --axes 2 --recordings 12 --seed 3), M01/X: the
    11th recording unexcited, the 12th δ̂ 130.39 mrad (truth 130.38) was a red × — the local
    quadratic through the 8 before it predicts 125.2 mrad two days on."""
    y = [63.59, 65.46, 67.70, 70.23, 73.53, 77.77, 82.64, 88.84, 96.46, 105.68, 130.39]
    days = [*range(10), 11]
    rows = _rows([1e-3 * v for v in y], 1e-4)
    for r, d in zip(rows, days, strict=True):
        r["start_time"] = T0 + timedelta(days=d)
    trend, used, _ = _alarms(rows, 0.1131)
    assert trend.inlier.all() and trend.model == "accelerating"
    assert abs(1e3 * float(trend.curve(trend.t[-1:])[0][0]) - 130.39) < 0.1
    # negative control: 10 mrad above the truth is still an outlier
    rows[-1]["delta"] = 0.14038
    assert _alarms(rows, 0.1131)[0].inlier.tolist() == [True] * 10 + [False]


def test_a_forecast_whose_crossing_has_passed_without_data_is_called_stale():
    """Tester finding (session 14): `track status` on 2026-11-28 showed an axis whose data end
    2026-01-24 as "crossing 2026-02-03, days left 10.2, may be crossed within 30 days" — a date ten
    months past, frozen because no recording came since. It is now named as stale (status line,
    report overview); a crossing still ahead, a crossed axis and an axis without forecast are not."""
    from drivelash.wear.alarms import stale_notes

    def summ(name, crossing, crossed=False):
        last = datetime(2026, 1, 24, 6)
        return {"axis": name, "crossing": crossing, "crossed": crossed, "last_recording": last}

    now = datetime(2026, 11, 28, 3, 0)
    notes = stale_notes(
        [
            summ("M02/Y", datetime(2026, 2, 3)),
            summ("M01/X", datetime(2026, 12, 3)),  # still ahead: not stale
            summ("M03/X", datetime(2026, 1, 20), crossed=True),  # crossed: its alarm says so
            summ("M04/X", None),  # no forecast
        ],
        now=now,
    )
    assert [n for n, _ in notes] == ["M02/Y"]
    msg = notes[0][1]
    assert "2026-02-03 UTC has passed" in msg and "2026-01-24 UTC, 308 days ago" in msg and "\n" not in msg
    # a store with zone-aware times is compared in UTC as well
    from datetime import UTC

    aware = summ("M02/Y", datetime(2026, 2, 3, tzinfo=UTC))
    aware["last_recording"] = datetime(2026, 1, 24, 6, tzinfo=UTC)
    assert stale_notes([aware], now=now.replace(tzinfo=UTC))[0][0] == "M02/Y"


def test_a_stale_note_does_not_say_no_recording_when_later_unexcited_ones_exist():
    """s19 tester, F17: "has passed with no recording since the last one (2026-01-13 UTC)" while
    three later recordings were in the store, unexcited (cut to 2 s) — and "record the axis
    again", which the user had done. Now it says no *usable estimate* since, counts the later
    recordings by why, and asks for a motion that crosses the gap. Negative control: without
    later recordings the old wording stays."""
    from drivelash.wear.alarms import stale_notes

    last = datetime(2026, 1, 13, 7)

    def row(day, excited=False, status="ok"):
        return {"start_time": datetime(2026, 1, day, 7), "status": status, "excitation_ok": excited,
                "delta": 0.1, "converged": True, "delta_std": 1e-4}  # fmt: skip

    base = {"axis": "M01/Y", "crossing": datetime(2026, 1, 15), "crossed": False, "last_recording": last}
    later = [row(14), row(15), row(16), row(17, status="failed")]
    ((_, msg),) = stale_notes(
        [{**base, "rows": [row(12, True), row(13, True), *later]}], now=datetime(2026, 11, 29)
    )
    assert "no recording since" not in msg
    assert "no usable estimate since 2026-01-13 UTC" in msg
    assert "4 later recordings: 3 not excited, 1 failed" in msg
    assert "record the axis again with a motion that crosses the gap" in msg
    ((_, old),) = stale_notes([{**base, "rows": [row(12, True), row(13, True)]}], now=datetime(2026, 11, 29))
    assert "with no recording since the last one (2026-01-13 UTC" in old


def test_only_excited_estimates_enter_the_trend_unconverged_ones_up_to_5_mrad_at_95_percent():
    """README: "only excited estimates enter the trend — converged ones, and unconverged ones whose
    stated 95 % uncertainty is at most 5 mrad". 95 % = 1.96 σ; the boundary from both sides."""
    sigma_in, sigma_out = 4.95e-3 / 1.96, 5.05e-3 / 1.96
    n = len(analyse(_rows(M02Y, sigma_in, converged=False), 0.2)[1])
    assert n == len(M02Y)  # 4.95 mrad at 95 %: every estimate used
    assert analyse(_rows(M02Y, sigma_out, converged=False), 0.2)[1] == []  # 5.05 mrad: none
    assert analyse(_rows(M02Y, None, converged=False), 0.2)[1] == []  # no stated uncertainty
    # converged estimates enter whatever their σ; unexcited ones never, converged or not
    assert len(analyse(_rows(M02Y, 0.26, converged=True), 0.2)[1]) == len(M02Y)
    assert analyse(_rows(M02Y, 1e-4, converged=True, excited=False), 0.2)[1] == []


def test_status_lists_crossed_axes_first_then_by_time_to_threshold_then_those_without_a_forecast(
    monkeypatch,
):
    """README: `track status` shows the "axes sorted by time to threshold" (fleet_summary, the
    order status prints). Names are chosen so that their alphabetical order is another one."""
    import drivelash.wear.alarms as alarms

    axes = {  # name: (crossed, days to threshold)
        "A01/X": (False, None),
        "B01/X": (False, 300.0),
        "C01/X": (False, 12.5),
        "D01/X": (True, None),
        "E01/X": (False, 40.0),
    }
    monkeypatch.setattr(alarms, "judged_axes", lambda store, fleet: list(axes))
    monkeypatch.setattr(
        alarms,
        "axis_summary",
        lambda store, a: {"axis": a, "crossed": axes[a][0], "days_to_threshold": axes[a][1]},
    )
    order = [s["axis"] for s in alarms.fleet_summary(None)]
    assert order == ["D01/X", "C01/X", "E01/X", "B01/X", "A01/X"]
    assert order != sorted(axes)  # negative control: not the store's (alphabetical) order


def test_every_date_in_an_alarm_or_stale_message_says_utc():
    """The status table and the report say "(UTC)" around alarm messages that carried bare dates
    ("… at 2026-01-08"); every date in a message now reads "2026-01-08 UTC". One case per kind
    of alarm that names a date: threshold (latest estimate), forecast, jump, not excited, and
    the stale-forecast note printed next to them."""
    import re

    from drivelash.wear.alarms import stale_notes

    jump = [0.030 + 0.001 * i for i in range(6)] + [0.050 + 0.001 * i for i in range(6)]
    cases = {
        "threshold": (_rows(J3, 1.05e-4), 0.050),
        "forecast": (_rows(M02Y, 1.2e-3), 0.20),
        "jump": (_rows(jump, 1.0e-4), 0.5),
        "not_excited": (_rows(M02Y[:4], None, converged=False, excited=False), 0.1753),
    }
    messages = []
    for kind, (rows, thr) in cases.items():
        al = _alarms(rows, thr)[2]
        assert kind in al, (kind, sorted(al))
        messages.append(al[kind].message)
    last = datetime(2026, 1, 24, 6)
    summ = {"axis": "M02/Y", "crossing": datetime(2026, 2, 3), "crossed": False, "last_recording": last}
    messages += [m for _, m in stale_notes([summ], now=datetime(2026, 11, 28, 3))]
    for m in messages:
        dates = re.findall(r"\d{4}-\d{2}-\d{2}[^,;)]*", m)
        assert dates and all(d.startswith(d[:10] + " UTC") for d in dates), m


def test_one_recording_and_one_day_are_singular_in_alarm_messages():
    """``not_excited_alarm = 1`` said "the last 1 recordings did not excite …" and a one-day
    horizon "within 1 days"."""
    axis = {**_axis(0.20), "not_excited_alarm": 1, "horizon_days": 1.0}
    rows = _rows(M02Y, 1.2e-3)
    rows[-1].update(excitation_ok=False)
    trend, _ = analyse(rows, 0.20)
    msgs = [a.message for a in axis_alarms(axis, rows, trend)]
    assert any("M02/Y: the last recording did not excite the deadzone" in m for m in msgs), msgs
    assert not any("1 recordings" in m or "1 days" in m for m in msgs), msgs
    from drivelash.wear.alarms import _days

    assert _days(1.0) == "1 day" and _days(60.0) == "60 days" and _days(0.5) == "0.5 days"


def test_the_forecast_alarm_prints_a_short_interval_to_the_minute_as_the_fleet_table_does():
    """The alarm stored at ingest gave the 90 % interval's start as a date ("from 2026-04-20")
    while the overview printed the same interval to the minute ("2026-04-20 08:57 … 09:29"),
    which hid that the crossing is known within minutes. One rule now: under 2 days
    (``MINUTE_INTERVAL_DAYS``) both print minutes, the alarm's start being the table's start;
    a wide interval (negative control) is dates in both."""
    from drivelash.report.fleet import _interval
    from drivelash.wear.words import MINUTE_INTERVAL_DAYS

    def table_and_alarm(noise, std):
        rng = np.random.default_rng(1)
        deltas = [0.100 + 0.001 * i + noise * rng.standard_normal() for i in range(10)]
        trend, _, al = _alarms(_rows(deltas, std), 0.115)
        fc = trend.forecast
        summary = {
            "crossing_early": trend.to_time(fc.t_early),
            "crossing_late": trend.to_time(fc.t_late),
            "crossing_late_never": False,
        }
        return fc, _interval(summary), al["forecast"].message

    fc, table, msg = table_and_alarm(1e-6, 1e-5)
    assert fc.t_late - fc.t_early < MINUTE_INTERVAL_DAYS
    start = table.split(" … ")[0]
    assert len(start) == len("2026-04-20 08:57"), table
    assert f"(90 % interval from {start} UTC; expected " in msg, (table, msg)
    expected = msg.split("expected ")[1]
    assert len(expected) == len("2026-04-20 09:13 UTC)"), msg

    fc, table, msg = table_and_alarm(1e-3, 1.2e-3)  # wide: dates
    assert fc.t_late - fc.t_early > MINUTE_INTERVAL_DAYS
    start = table.split(" … ")[0]
    assert len(start) == len("2026-04-02"), table
    assert f"(90 % interval from {start} UTC; expected " in msg and msg.endswith(" UTC)")
    assert len(msg.split("expected ")[1]) == len("2026-04-19 UTC)"), msg
