"""Alarms and the per-axis status that ``track status``/``forecast``/``report`` show.

Alarm kinds (each keyed so the same event is raised once and cleared when it no longer holds):

* ``threshold`` — the fitted δ at the latest used recording is at or above the threshold, or
  the latest excited estimate lies above it by more than :data:`THRESHOLD_Z` of its stated
  uncertainty (also when the trend cannot use it: too few estimates, an outlier or the first
  recording after a jump);
* ``forecast`` — the early (5 %) bound of the forecast crossing lies within the axis's
  horizon after its latest recording;
* ``jump`` — a positive change point (sudden damage), keyed by its time;
* ``not_excited`` / ``not_converged`` / ``no_estimate`` — the latest N recordings
  (``[fleet] not_excited_alarm``) gave no usable estimate: all because the motion did not
  excite the deadzone, all because the estimator did not converge and stated no uncertainty,
  or a mix (failed files do not count).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

import numpy as np

from drivelash.wear.store import Store
from drivelash.wear.trend import AxisTrend, analyse, usable
from drivelash.wear.words import count, crossing_time, to_the_minute

__all__ = [
    "Alarm",
    "axes_not_in_fleet",
    "fleet_axes_not_stored",
    "axis_summary",
    "fleet_summary",
    "hidden_alarm_count",
    "judged_axes",
    "not_in_fleet_note",
    "not_stored_note",
    "refresh_alarms",
]

#: A single estimate raises the threshold alarm when δ̂ − THRESHOLD_Z·σ ≥ threshold (σ its stated
#: uncertainty, else the axis's noise scale): one-sided 95 % that the recording's δ is above.
THRESHOLD_Z = 1.645


@dataclass(frozen=True)
class Alarm:
    """One active alarm."""

    kind: str
    key: str
    message: str
    data_time: datetime | None


def axis_alarms(axis: dict[str, Any], rows: list[dict[str, Any]], trend: AxisTrend) -> list[Alarm]:
    """The alarms that hold for one axis now."""
    out: list[Alarm] = []
    name = axis["name"]
    thr = axis["threshold_rad"]
    last_used = trend.to_time(float(trend.t[-1])) if trend.t.size else None
    fc = trend.forecast
    ok_rows = sorted(
        (r for r in rows if r["status"] == "ok"), key=lambda r: (r["start_time"] or datetime.min, r["path"])
    )
    latest = next((r for r in reversed(ok_rows) if r["excitation_ok"] and r["delta"] is not None), None)
    single = None
    if thr is not None and latest is not None and not (fc is not None and fc.crossed):
        sd = latest["delta_std"] if latest["delta_std"] and math.isfinite(latest["delta_std"]) else None
        s_use = sd if sd is not None else trend.sigma
        if latest["delta"] - THRESHOLD_Z * s_use >= thr:
            single = latest, sd
    if single is not None:
        r, sd = single
        pm = f" ± {1e3 * sd:.2f}" if sd is not None else ""
        why = (
            f"estimate not converged: uncertainty ±{1e3 * 1.96 * sd:.2f} mrad (95 %)"
            if not r["converged"] and sd is not None
            else "estimate not converged, no uncertainty stated"
            if not r["converged"]
            else "not in the fitted trend yet: a jump or a bad recording, the next recording decides"
            if trend.model is None or not _in_fit(trend, r)
            else "the fitted trend is still below"
        )
        out.append(
            Alarm(
                "threshold",
                "crossed",
                f"{name}: latest estimate {1e3 * r['delta']:.2f}{pm} mrad ({_day(r['start_time'])}) above "
                f"the threshold {1e3 * thr:.2f} mrad ({why})",
                r["start_time"],
            )
        )
    if fc is not None and thr is not None:
        if fc.crossed:
            out.append(
                Alarm(
                    "threshold",
                    "crossed",
                    f"{name}: backlash above the threshold {1e3 * thr:.2f} mrad "
                    f"(fitted {1e3 * float(trend.curve(trend.t[-1:])[0][0]):.2f} mrad)",
                    last_used,
                )
            )
        elif fc.t_early is not None and fc.t_early - float(trend.t[-1]) <= axis["horizon_days"]:
            when, early = trend.to_time(fc.t_cross), trend.to_time(fc.t_early)
            late = trend.to_time(fc.t_late) if fc.t_late is not None and math.isfinite(fc.t_late) else None
            minute = to_the_minute(early, late)  # the fleet table's rule for the same interval
            out.append(
                Alarm(
                    "forecast",
                    "within-horizon",
                    f"{name}: threshold {1e3 * thr:.2f} mrad may be crossed within "
                    f"{_days(axis['horizon_days'])} (90 % interval from "
                    f"{crossing_time(early, minute)} UTC; expected {crossing_time(when, minute)} UTC)",
                    last_used,
                )
            )
    for cp in trend.change_points:
        if cp.size > 0:
            when = trend.to_time(cp.t_days)
            out.append(
                Alarm(
                    "jump",
                    when.isoformat() if when else f"{cp.t_days:.6f}",
                    f"{name}: sudden backlash increase of {1e3 * cp.size:.2f} mrad at {_day(when)}",
                    when,
                )
            )
    run = 0
    for r in reversed(ok_rows):
        if usable(r):
            break
        run += 1
    if run >= axis["not_excited_alarm"]:
        tail = ok_rows[-run:]
        first = tail[0]
        unexc = sum(1 for r in tail if not r["excitation_ok"])
        since = f"since {_day(first['start_time'])}"
        if unexc == run:
            kind, text = "not_excited", f"did not excite the deadzone ({since}: {first['reason']})"
        elif unexc == 0:
            kind, text = (
                "not_converged",
                f"gave estimates not converged and not usable ({since}: {first['reason']})",
            )
        else:
            kind, text = (
                "no_estimate",
                (
                    f"gave no usable estimate ({unexc} did not excite the deadzone, "
                    f"{run - unexc} not converged and not usable; {since})"
                ),
            )
        out.append(
            Alarm(
                kind,
                "latest",
                f"{name}: "
                + (f"the last {run} recordings {text}" if run > 1 else f"the last recording {text}"),
                ok_rows[-1]["start_time"],
            )
        )
    return out


def _in_fit(trend: AxisTrend, r: dict[str, Any]) -> bool:
    """Whether store row ``r`` is an inlier of the trend's fit."""
    if trend.t0 is None or r["start_time"] is None:
        return False
    d = (r["start_time"] - trend.t0).total_seconds() / 86400.0
    hit = (abs(trend.t - d) < 1e-9) & (trend.y == r["delta"])
    return bool(np.any(hit & trend.inlier))


def _days(d: float) -> str:
    """A day count as the horizon is given: "1 day", "60 days", "0.5 days"."""
    return f"{d:g} day" if d == 1 else f"{d:g} days"


def _day(t: datetime | None) -> str:
    """A date of an alarm or stale message, with its clock: "2026-01-08 UTC" (the store keeps
    naive UTC; status and forecast print "UTC" after their times as well)."""
    return t.strftime("%Y-%m-%d UTC") if t is not None else "–"


def axis_summary(store: Store, axis: dict[str, Any]) -> dict[str, Any]:
    """Trend, forecast and alarms of one axis (a dict of plain values plus ``trend``)."""
    rows = store.current_estimates(axis)
    trend, used = analyse(rows, axis["threshold_rad"])
    alarms = axis_alarms(axis, rows, trend)
    fc = trend.forecast
    last_t = trend.to_time(float(trend.t[-1])) if trend.t.size else None
    current = float(trend.curve(trend.t[-1:])[0][0]) if trend.model and trend.t.size else None
    remaining = None
    if fc is not None and fc.t_cross is not None and trend.t.size:
        remaining = fc.t_cross - float(trend.t[-1])
    return {
        "axis": axis["name"],
        "threshold_rad": axis["threshold_rad"],
        "recordings": len(rows),
        "used": len(used),
        "unexcited": sum(1 for r in rows if r["status"] == "ok" and not r["excitation_ok"]),
        # excited, but the estimator did not converge (its 95 % uncertainty above its claim);
        # those with a stated uncertainty are in "used", weighted by it
        "unconverged": sum(
            1 for r in rows if r["status"] == "ok" and r["excitation_ok"] and not r["converged"]
        ),
        "unconverged_used": sum(1 for r in used if not r["converged"]),
        "unusable": sum(1 for r in rows if r["status"] == "ok" and r["excitation_ok"] and not usable(r)),
        "failed": sum(1 for r in rows if r["status"] != "ok"),
        "outliers": int((~trend.inlier).sum()) if trend.t.size else 0,
        "last_recording": last_t,
        "current_rad": current,
        "model": trend.model,
        "params": trend.params,
        "aicc": trend.aicc,
        "noise_rad": trend.sigma,
        "crossed": bool(fc.crossed) if fc else False,
        "crossing": trend.to_time(fc.t_cross) if fc else None,
        "crossing_early": trend.to_time(fc.t_early) if fc else None,
        "crossing_late": (
            trend.to_time(fc.t_late) if fc and fc.t_late is not None and math.isfinite(fc.t_late) else None
        ),
        "crossing_late_never": bool(
            fc is not None and fc.t_late is not None and not math.isfinite(fc.t_late)
        ),
        "days_to_threshold": remaining,
        "change_points": [
            {"time": trend.to_time(c.t_days), "size_rad": c.size, "index": c.index}
            for c in trend.change_points
        ],
        "alarms": alarms,
        "trend": trend,
        "rows": rows,
        "used_rows": used,
    }


def judged_axes(store: Store, fleet: Any | None = None) -> list[dict[str, Any]]:
    """The store's axes, with the judging settings (threshold, horizon, not-excited count,
    transmission) of ``fleet`` (a :class:`~drivelash.wear.fleet.Fleet`) where it names the axis:
    the store holds the values of the last ingest, the fleet file is what the user means now.

    With a ``fleet``, only its axes: an axis removed from the fleet file keeps its history in
    the store but is not judged (:func:`axes_not_in_fleet` names those)."""
    axes = store.axes()
    if fleet is None:
        return axes
    spec = {a.name: a for a in fleet.axes}
    out = []
    for a in axes:
        f = spec.get(a["name"])
        if f is None:
            continue
        a.update(
            threshold_rad=f.threshold_rad,
            horizon_days=f.horizon_days,
            not_excited_alarm=f.not_excited_alarm,
            transmission_mm_per_rad=f.transmission,
        )
        out.append(a)
    return out


def axes_not_in_fleet(store: Store, fleet: Any | None) -> list[str]:
    """Names of the store's axes that ``fleet`` does not name (sorted; none without a fleet):
    axes removed from the fleet file, whose history the store keeps."""
    if fleet is None:
        return []
    names = {a.name for a in fleet.axes}
    return [a["name"] for a in store.axes() if a["name"] not in names]


def hidden_alarm_count(store: Store, names: list[str]) -> int:
    """How many active alarms the store holds for the axes ``names`` — as of each axis's last
    ingest (an axis removed from the fleet file is no longer re-judged, so its alarms stay as
    they were); the count :func:`not_in_fleet_note` states."""
    hidden = set(names)
    return sum(1 for a in store.alarms(active_only=True) if a["axis"] in hidden) if hidden else 0


def not_in_fleet_note(names: list[str], fleet_file: str, alarms: int | None = None) -> str | None:
    """The one line that says which axes of the store a fleet-filtered view leaves out (None
    when none): every name is listed, so nothing is dropped silently; with ``alarms`` (their
    stored active alarms, :func:`hidden_alarm_count`) it says how many alarms are not shown
    (and not counted in the view's "N active alarms")."""
    if not names:
        return None
    n = len(names)
    what = "1 axis in the store is" if n == 1 else f"{n} axes in the store are"
    its = "its history is kept; it is" if n == 1 else "their history is kept; they are"
    note = f"{what} not in {fleet_file} ({', '.join(names)}): {its} not shown"
    if alarms is None:
        return note
    last = "its last ingest" if n == 1 else "their last ingests"
    if alarms == 0:
        return f"{note} (no active alarm as of {last})"
    return f"{note}, nor {'its' if n == 1 else 'their'} {count(alarms, 'active alarm')} (as of {last})"


def fleet_axes_not_stored(store: Store, fleet: Any | None) -> list[str]:
    """Names of ``fleet``'s axes the store has no axis of (in the fleet file's order; none
    without a fleet): axes added or renamed since the last ``track ingest``."""
    if fleet is None:
        return []
    have = {a["name"] for a in store.axes()}
    return [a.name for a in fleet.axes if a.name not in have]


def not_stored_note(names: list[str], fleet_file: str) -> str | None:
    """The one line that says which axes of the fleet file a fleet-filtered view cannot show
    (None when none): not ingested yet, e.g. an axis renamed in the fleet file, whose old
    name's history :func:`not_in_fleet_note` names."""
    if not names:
        return None
    n = len(names)
    what = f"1 axis of {fleet_file} is" if n == 1 else f"{n} axes of {fleet_file} are"
    return (
        f"{what} not in the store yet ({', '.join(names)}): nothing to show before "
        "the next `drivelash track ingest` (a renamed axis starts a new history)"
    )


def fleet_summary(store: Store, fleet: Any | None = None) -> list[dict[str, Any]]:
    """:func:`axis_summary` of every axis, sorted by forecast time to threshold (soonest first;
    crossed axes first, axes without a forecast last); judged with ``fleet``'s current
    thresholds when given, and then only ``fleet``'s axes (:func:`judged_axes`)."""
    out = [axis_summary(store, a) for a in judged_axes(store, fleet)]

    def key(s: dict[str, Any]) -> tuple:
        if s["crossed"]:
            return (0, 0.0, s["axis"])
        d = s["days_to_threshold"]
        return (1, d, s["axis"]) if d is not None else (2, 0.0, s["axis"])

    out.sort(key=key)
    return out


def stale_notes(summaries: list[dict[str, Any]], now: datetime | None = None) -> list[tuple[str, str]]:
    """Axes whose expected threshold crossing lies in the past with no recording since: the
    forecast is frozen at the last data, so it says nothing about today (a machine whose
    recordings stopped arriving). One ``(axis, message)`` per axis; ``now`` defaults to the
    clock (UTC; the store's zone-less times are UTC)."""
    now = now or datetime.now(UTC)
    out: list[tuple[str, str]] = []
    for s in summaries:
        tc, last = s["crossing"], s["last_recording"]
        if s["crossed"] or tc is None or last is None:
            continue
        ref = now if tc.tzinfo is not None else now.astimezone(UTC).replace(tzinfo=None)
        if tc < ref:
            age = (ref - last).total_seconds() / 86400.0
            out.append(
                (
                    s["axis"],
                    f"the expected crossing {_day(tc)} has passed with no recording since the last one "
                    f"({_day(last)}, {count(round(age), 'day')} ago): the forecast is stale — "
                    "record the axis again",
                )
            )
    return out


def refresh_alarms(store: Store, names: list[str] | None = None) -> list[Alarm]:
    """Re-evaluate and store the alarms of the named axes (all when None); returns the active ones."""
    active: list[Alarm] = []
    for a in store.axes():
        if names is not None and a["name"] not in names:
            continue
        s = axis_summary(store, a)
        store.sync_alarms(a["name"], s["alarms"])
        active.extend(s["alarms"])
    return active
