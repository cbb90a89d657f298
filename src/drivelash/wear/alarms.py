"""Alarms and the per-axis status that ``track status``/``forecast``/``report`` show.

Alarm kinds (each keyed so the same event is raised once and cleared when it no longer holds):

* ``threshold`` — the fitted δ at the latest used recording is at or above the threshold;
* ``forecast`` — the early (5 %) bound of the forecast crossing lies within the axis's
  horizon after its latest recording;
* ``jump`` — a positive change point (sudden damage), keyed by its time;
* ``not_excited`` — the latest N recordings (``[fleet] not_excited_alarm``) gave no usable
  estimate because the motion did not excite the deadzone (failed files do not count).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from drivelash.wear.store import Store
from drivelash.wear.trend import AxisTrend, analyse

__all__ = ["Alarm", "axis_summary", "fleet_summary", "refresh_alarms"]


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
            when = trend.to_time(fc.t_cross)
            out.append(
                Alarm(
                    "forecast",
                    "within-horizon",
                    f"{name}: threshold {1e3 * thr:.2f} mrad may be crossed within "
                    f"{axis['horizon_days']:g} days (90 % interval from "
                    f"{_day(trend.to_time(fc.t_early))}; expected {_day(when)})",
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
    ok_rows = sorted(
        (r for r in rows if r["status"] == "ok"), key=lambda r: (r["start_time"] or datetime.min, r["path"])
    )
    run = 0
    for r in reversed(ok_rows):
        if r["excitation_ok"] and r["converged"]:
            break
        run += 1
    if run >= axis["not_excited_alarm"]:
        first = ok_rows[-run]
        out.append(
            Alarm(
                "not_excited",
                "latest",
                f"{name}: the last {run} recordings did not excite the deadzone "
                f"(since {_day(first['start_time'])}: {first['reason']})",
                ok_rows[-1]["start_time"],
            )
        )
    return out


def _day(t: datetime | None) -> str:
    return t.strftime("%Y-%m-%d") if t is not None else "–"


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
        "unexcited": sum(
            1 for r in rows if r["status"] == "ok" and not (r["excitation_ok"] and r["converged"])
        ),
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


def fleet_summary(store: Store) -> list[dict[str, Any]]:
    """:func:`axis_summary` of every axis, sorted by forecast time to threshold (soonest first;
    crossed axes first, axes without a forecast last)."""
    out = [axis_summary(store, a) for a in store.axes()]

    def key(s: dict[str, Any]) -> tuple:
        if s["crossed"]:
            return (0, 0.0, s["axis"])
        d = s["days_to_threshold"]
        return (1, d, s["axis"]) if d is not None else (2, 0.0, s["axis"])

    out.sort(key=key)
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
