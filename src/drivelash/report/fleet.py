"""Fleet wear report: one self-contained HTML page (``drivelash track report -o fleet.html``).

Sections: fleet overview (table sorted by forecast time to threshold, and a chart of the
forecast crossings with their 90 % intervals), the active alarms, and one trend figure per
axis: the used estimates, outliers, unexcited and failed recordings (ticks along the bottom),
the monotone (isotonic) trend, the fitted growth model with its 90 % confidence band and the
wider prediction band, the forecast to the threshold with the crossing's 90 % interval,
change points, and measurements of other sources (ISO 230-2 laser checks) with their
uncertainty.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.report.html import Figure, Section, render_html
from drivelash.units import GapUnit, gap_unit
from drivelash.wear.alarms import stale_notes
from drivelash.wear.trend import UNCONVERGED_MAX_U95, trend_scale
from drivelash.wear.words import count, crossing_interval, not_excited_reasons

__all__ = ["fleet_unit", "render_fleet_report", "write_fleet_report"]


def _mrad(x: float | None, u: GapUnit | None = None, with_unit: bool = False) -> str:
    """δ-like value ``x`` [rad, or m on a linear axis] in the display unit ``u`` (default mrad),
    2 decimals; ``with_unit``: followed by the unit (a table mixing rotary and linear axes)."""
    if x is None or not math.isfinite(x):
        return "–"
    u = u or gap_unit(None)
    return u.f(x, ".2f") if with_unit else u.n(x, ".2f")


def fleet_unit(summaries: list[dict[str, Any]]) -> GapUnit | None:
    """The one display unit of the axes' δ (mrad, or µm when every axis is linear), None when the
    fleet mixes rotary and linear axes (each cell then carries its unit)."""
    units = {gap_unit(s.get("kind")) for s in summaries}
    return next(iter(units)) if len(units) == 1 else (gap_unit(None) if not units else None)


def _day(t: datetime | None) -> str:
    return t.strftime("%Y-%m-%d") if t is not None else "–"


def _interval(s: dict[str, Any]) -> str:
    """The crossing's 90 % interval (UTC): dates, or dates and times when it is shorter than
    :data:`~drivelash.wear.words.MINUTE_INTERVAL_DAYS` (the rule of the alarm messages too)."""
    return crossing_interval(s["crossing_early"], s["crossing_late"], s["crossing_late_never"])


def _now_cell(s: dict[str, Any], with_unit: bool = False) -> str:
    """The "δ now" cell: the fitted trend now, or — too few estimates for a trend — the latest
    usable estimate in parentheses (:data:`NOW_LEGEND`); in the axis's unit (mrad or µm)."""
    u = gap_unit(s.get("kind"))
    if s["current_rad"] is None and s.get("latest_rad") is not None:
        return f"({_mrad(s['latest_rad'], u, with_unit)})"
    return _mrad(s["current_rad"], u, with_unit)


def not_excited_line(summaries: list[dict[str, Any]]) -> str | None:
    """The one line under the fleet table (``track status``, the report's overview) that says why
    the recordings counted "unexcited" were not excited, grouped by cause with their axes
    (:func:`~drivelash.wear.words.not_excited_reasons`); None when none is. The stored reason was
    shown nowhere but in ``track forecast --json`` (session 32 tester F, F3)."""
    pairs = [(s["axis"], r) for s in summaries for r in s.get("rows", [])]
    why = not_excited_reasons([r for _, r in pairs], [a for a, _ in pairs])
    return None if why is None else f"not excited: {why} (`drivelash estimate FILE` explains each)"


#: What the parentheses in the "δ now" column mean (under the status table and the report's).
NOW_LEGEND = "(…) in δ now: the latest estimate — no trend (too few recordings, or all at one time)"


def any_latest_only(summaries: list[dict[str, Any]]) -> bool:
    """Whether a "δ now" cell shows a latest estimate in parentheses (:func:`_now_cell`)."""
    return any(s["current_rad"] is None and s.get("latest_rad") is not None for s in summaries)


def overview_rows(summaries: list[dict[str, Any]]) -> list[list[Any]]:
    """Rows of the overview table (also used by ``track status``): δ now and the threshold in the
    axes' unit (:func:`overview_header`), each with its unit when the fleet mixes rotary and
    linear axes."""
    rows = []
    mixed = fleet_unit(summaries) is None
    for s in summaries:
        days = s["days_to_threshold"]
        rows.append(
            [
                s["axis"],
                _now_cell(s, mixed),
                _mrad(s["threshold_rad"], gap_unit(s.get("kind")), mixed),
                s["model"] or "–",
                "crossed" if s["crossed"] else _day(s["crossing"]),
                _interval(s),
                "0" if s["crossed"] else ("–" if days is None else f"{days:.1f}"),
                f"{s['used']}/{s['recordings']}",
                str(s["unexcited"]),
                str(s["failed"]),
                ", ".join(sorted({a.kind for a in s["alarms"]})) or "–",
            ]
        )
    return rows


OVERVIEW_HEADER = [
    "axis",
    "δ now [mrad]",
    "threshold [mrad]",
    "model",
    "expected crossing (UTC)",
    "90 % interval (UTC)",
    "days after last rec.",
    "used/recordings",
    "unexcited",
    "failed",
    "alarms",
]


def overview_header(summaries: list[dict[str, Any]]) -> list[str]:
    """:data:`OVERVIEW_HEADER` with the fleet's unit of δ (:func:`fleet_unit`: "[µm]" when every
    axis is linear; none in the header when the fleet mixes kinds, the cells carry it)."""
    u = fleet_unit(summaries)
    unit = "" if u is None else f" [{u}]"
    return [h.replace(" [mrad]", unit) for h in OVERVIEW_HEADER]


#: Headers of the narrow ``track status`` table (a terminal too narrow for
#: :data:`OVERVIEW_HEADER`); :data:`COMPACT_LEGEND` spells them out under the table.
COMPACT_HEADER = [
    "axis",
    "δ now",
    "thresh.",
    "model",
    "crossing",
    "90 % int.",
    "days",
    "used",
    "unexc",
    "fail",
    "alarms",
]
#: Columns of :data:`COMPACT_HEADER` the narrow table leaves out, first to last, while it is
#: still wider than the terminal (the axis and its alarms always stay).
COMPACT_DROP_ORDER = ["unexc", "fail", "used", "90 % int.", "model", "thresh.", "crossing", "δ now", "days"]
#: Alarm kinds as the narrow table abbreviates them (every alarm is also listed in full below it).
ALARM_ABBREV = {
    "threshold": "thr",
    "forecast": "fc",
    "jump": "jump",
    "not_excited": "unexc",
    "not_converged": "unconv",
    "no_estimate": "noest",
}
#: Model names as the narrow table abbreviates them.
MODEL_ABBREV = {"accelerating": "accel."}
COMPACT_LEGEND = (
    "δ now, thresh.: mrad; crossing: expected threshold crossing (UTC); 90 % int.: its 90 % interval, "
    "days before … after it; days: days from the last recording to the crossing; used: usable/recordings; "
    "unexc: not excited; fail: failed; "
    "accel.: accelerating; alarms: "
    + ", ".join(f"{v} {k}" for k, v in ALARM_ABBREV.items() if v != k)
    + " (listed in full below)"
)


def compact_legend(summaries: list[dict[str, Any]]) -> str:
    """:data:`COMPACT_LEGEND` with the fleet's unit of δ (:func:`fleet_unit`)."""
    u = fleet_unit(summaries)
    return COMPACT_LEGEND.replace(
        "δ now, thresh.: mrad", "δ now, thresh.: " + (str(u) if u is not None else "in each axis's unit")
    )


def _rel_days(x: float) -> str:
    """A day count short but exact enough: one decimal below 10 days, whole days above."""
    return f"{x:.1f}" if abs(x) < 10 else f"{x:.0f}"


def _compact_interval(s: dict[str, Any]) -> str:
    """The crossing's 90 % interval relative to the expected crossing [days], e.g. ``-2.5…+40``
    (``never``: the late bound is never reached)."""
    tc, early = s["crossing"], s["crossing_early"]
    if early is None or tc is None:
        return "–"
    lo = _rel_days((tc - early).total_seconds() / 86400.0)
    if s["crossing_late_never"]:
        return f"-{lo}…never"
    late = s["crossing_late"]
    if late is None:
        return f"-{lo}…–"
    return f"-{lo}…+{_rel_days((late - tc).total_seconds() / 86400.0)}"


def compact_rows(summaries: list[dict[str, Any]]) -> list[list[str]]:
    """Rows of the narrow ``track status`` table (:data:`COMPACT_HEADER`): the cells of
    :func:`overview_rows`, with the 90 % interval relative to the expected crossing [days] and
    abbreviated model and alarm names (:data:`COMPACT_LEGEND`)."""
    out = []
    for s, row in zip(summaries, overview_rows(summaries), strict=True):
        row = [str(x) for x in row]
        row[3] = MODEL_ABBREV.get(row[3], row[3])
        row[5] = _compact_interval(s)
        row[10] = ",".join(ALARM_ABBREV.get(k, k) for k in sorted({a.kind for a in s["alarms"]})) or "–"
        out.append(row)
    return out


def _dates(t0: datetime, days: np.ndarray) -> list[datetime]:
    return [t0 + timedelta(days=float(d)) for d in days]


#: The sentence that says which clock the report's dates are on (stored times are naive UTC).
TIMES_UTC = "All dates and times are UTC (recording starts, forecast crossings and their intervals)."


#: The ticks along the bottom of an axis figure: (key of :func:`tick_marks`, colour, legend).
TICKS = (
    ("not_excited", "0.5", "not excited"),
    ("left_out", "C5", "excited, left out of the trend"),
    ("failed", "C3", "failed file"),
)


def tick_marks(s: dict[str, Any]) -> dict[str, list[datetime]]:
    """Start times of an axis's recordings that are not in its trend, by why (:data:`TICKS`):
    ``not_excited`` (``ok``, excitation insufficient), ``left_out`` (``ok`` and excited, but not
    used — not converged without a usable stated uncertainty, :func:`~drivelash.wear.trend.usable`)
    and ``failed`` (not ``ok``). A recording the trend uses is never ticked: an unconverged one
    in the trend was also ticked "not excited" (session 32 tester F, F9).

    Parameters
    ----------
    s : dict
        :func:`drivelash.wear.alarms.axis_summary` (``rows``, ``used_rows``).
    """
    used = {(r["path"], r["start_time"]) for r in s.get("used_rows") or []}
    out: dict[str, list[datetime]] = {k: [] for k, _, _ in TICKS}
    for r in s["rows"]:
        if r["start_time"] is None or (r.get("path"), r["start_time"]) in used:
            continue
        if r["status"] != "ok":
            out["failed"].append(r["start_time"])
        elif not r["excitation_ok"]:
            out["not_excited"].append(r["start_time"])
        else:
            out["left_out"].append(r["start_time"])
    return out


def _axis_figure(s: dict[str, Any], meas: list[dict[str, Any]]) -> Figure:
    name = s["axis"]

    u = gap_unit(s.get("kind"))  # mrad, or µm on a linear axis
    per = u.per_si  # display units per SI unit

    def draw(fig: Any) -> None:
        import matplotlib.dates as mdates

        ax = fig.add_subplot(1, 1, 1)
        tr = s["trend"]
        thr = s["threshold_rad"]
        rows = s["rows"]
        times = [r["start_time"] for r in rows if r["start_time"] is not None]
        if tr.t.size:
            t0 = tr.t0
            ok = tr.inlier
            d = _dates(t0, tr.t)
            used = s.get("used_rows") or []
            conv = (
                np.array([bool(r["converged"]) for r in used])
                if len(used) == tr.t.size
                else np.ones(tr.t.size, dtype=bool)
            )
            std = np.array(
                [np.nan if r["delta_std"] is None else float(r["delta_std"]) for r in used]
                if len(used) == tr.t.size
                else np.full(tr.t.size, np.nan)
            )
            good = ok & conv
            if good.any():
                ax.plot(
                    [x for x, k in zip(d, good, strict=True) if k],
                    per * tr.y[good],
                    "o",
                    ms=3.5,
                    color="C0",
                    label="estimate (converged)",
                )
            weak = ok & ~conv
            if weak.any():
                # in the trend although the estimator did not call it converged: weighted by its
                # stated uncertainty, so the reader sees that uncertainty (session 32 tester F, F9)
                ax.errorbar(
                    [x for x, k in zip(d, weak, strict=True) if k],
                    per * tr.y[weak],
                    yerr=per * 1.96 * np.nan_to_num(std[weak]),
                    fmt="s",
                    ms=5,
                    mfc="white",
                    color="C9",
                    capsize=3,
                    label=f"not converged, in the trend, ±95 % ({int(weak.sum())})",
                )
            if (~ok).any():
                ax.plot(
                    [x for x, k in zip(d, ok, strict=True) if not k],
                    per * tr.y[~ok],
                    "x",
                    ms=6,
                    color="C3",
                    label="outlier (not fitted)",
                )
            ax.plot(d, per * tr.isotonic, color="0.35", lw=1.0, label="monotone trend (isotonic)")
            if tr.model is not None:
                fc = tr.forecast
                end = float(tr.t[-1])
                if fc is not None and fc.t_cross is not None and not fc.crossed:
                    end = max(end, fc.t_cross * 1.05 if math.isfinite(fc.t_cross) else end)
                    if fc.t_late is not None and math.isfinite(fc.t_late):
                        end = max(end, min(fc.t_late, 3 * fc.t_cross) * 1.02)
                else:
                    end = end + 0.25 * max(end - float(tr.t[0]), 1.0)
                tt = np.linspace(float(tr.t[0]), end, 400)
                mean, lo, hi, plo, phi = tr.curve(tt)
                dd = _dates(t0, tt)
                ax.fill_between(
                    dd, per * plo, per * phi, color="C1", alpha=0.12, lw=0, label="90 % prediction band"
                )
                ax.fill_between(
                    dd,
                    per * lo,
                    per * hi,
                    color="C1",
                    alpha=0.35,
                    lw=0,
                    label="90 % band of the true δ (incl. systematic)",
                )
                ax.plot(dd, per * mean, color="C1", lw=1.6, label=f"{tr.model} model")
                if fc is not None and fc.t_cross is not None and thr is not None:
                    xc = t0 + timedelta(days=fc.t_cross)
                    ax.plot([xc], [per * thr], "v", color="C3", ms=9, label=f"crossing {_day(xc)}")
                    if fc.t_early is not None:
                        xe = t0 + timedelta(days=fc.t_early)
                        xl = (
                            (t0 + timedelta(days=fc.t_late))
                            if fc.t_late is not None and math.isfinite(fc.t_late)
                            else dd[-1]
                        )
                        ax.plot(
                            [xe, xl],
                            [per * thr] * 2,
                            color="C3",
                            lw=4,
                            alpha=0.5,
                            solid_capstyle="butt",
                            label="crossing, 90 % interval",
                        )
            for c in tr.change_points:
                ax.axvline(t0 + timedelta(days=c.t_days), color="C3" if c.size > 0 else "C2", ls="--", lw=1.0)
        if thr is not None:
            ax.axhline(per * thr, color="k", lw=1.2, ls="-.", label=f"threshold {u.f(thr)}")
        marks = tick_marks(s)
        trans = ax.get_xaxis_transform()
        for key, color, what in TICKS:
            when = marks[key]
            if when:
                ax.plot(
                    when,
                    [0.02] * len(when),
                    "|",
                    ms=12,
                    mew=2,
                    color=color,
                    transform=trans,
                    label=f"{what} ({len(when)})",
                )
        m = [x for x in meas if x["value_rad"] is not None]
        if m:
            ax.errorbar(
                [x["time"] for x in m],
                [per * x["value_rad"] for x in m],
                yerr=[per * (x["std_rad"] or 0.0) for x in m],
                fmt="D",
                color="C4",
                ms=5,
                capsize=3,
                label=f"{m[0]['source']} (laser check)",
            )
        if not tr.t.size and not times and not m:
            ax.text(0.5, 0.5, "no recordings", transform=ax.transAxes, ha="center", va="center")
        ax.set_ylabel(f"deadzone δ [{u}]" if u.si == "rad" else f"lost motion δ [{u}]")
        ax.set_title(
            f"{name}: {s['used']} of {count(s['recordings'], 'recording')} usable"
            + (
                f", {s['used'] - s['outliers']} in the fit ({count(s['outliers'], 'outlier')})"
                if s["outliers"]
                else ""
            ),
            fontsize=10,
        )
        ax.set_xlabel("recording start (UTC)")
        ax.grid(alpha=0.3)
        ax.xaxis.set_major_formatter(mdates.ConciseDateFormatter(ax.xaxis.get_major_locator()))
        ax.legend(loc="upper left", fontsize=7, ncol=2, framealpha=0.85)

    return Figure(
        key="axis-" + name.replace("/", "-"),
        caption=(
            f"{name}: estimates in the trend (dots: converged; open squares with their 95 % interval: "
            "not converged, weighted by their stated uncertainty; outliers ×), monotone trend, fitted "
            "growth model with its 90 % band and 90 % prediction band, threshold (dash-dot) and "
            "forecast crossing with its 90 % interval; dashed verticals are detected jumps; ticks at "
            "the bottom mark recordings not in the trend: not excited (grey), excited but left out "
            "(brown: not converged and not admitted, see the overview) and failed (red)."
            + (f" Not excited: {why}." if (why := not_excited_reasons(s["rows"])) else "")
        ),
        draw=draw,
        size=(10.0, 4.2),
    )


def _crossing_chart(summaries: list[dict[str, Any]]) -> Figure | None:
    pts = [s for s in summaries if s["crossing"] is not None or s["crossed"]]
    if not pts:
        return None

    def draw(fig: Any) -> None:
        ax = fig.add_subplot(1, 1, 1)
        for i, s in enumerate(pts):
            x = s["crossing"]
            color = (
                "C3"
                if s["crossed"] or any(a.kind in ("threshold", "forecast") for a in s["alarms"])
                else "C0"
            )
            if s["crossing_early"] is not None:
                late = s["crossing_late"] or s["crossing"]
                ax.plot(
                    [s["crossing_early"], late], [i, i], color=color, lw=4, alpha=0.4, solid_capstyle="butt"
                )
            if x is not None:
                ax.plot([x], [i], "o", color=color)
        ax.set_yticks(range(len(pts)), [s["axis"] for s in pts], fontsize=7)
        # half a row beyond the first and last axis, soonest on top: no marker sits on the frame
        ax.set_ylim(len(pts) - 0.5, -0.5)
        ax.set_xlabel("forecast threshold crossing, UTC (bar: 90 % interval; red: alarm)")
        import matplotlib.dates as mdates

        ax.xaxis.set_major_formatter(mdates.ConciseDateFormatter(ax.xaxis.get_major_locator()))
        ax.grid(alpha=0.3)

    return Figure(
        "crossings",
        "Forecast threshold crossings of the fleet, soonest first.",
        draw,
        size=(10.0, max(2.5, 0.22 * len(pts) + 1.2)),
    )


def rate_sentence(summaries: list[dict[str, Any]]) -> str:
    """How the stored estimates sampled their recordings, e.g. "δ was estimated at 1000 Hz
    (every 8th sample of the 8000 Hz recordings) …" — from the rows' ``estimate_rate_hz``."""
    from collections import Counter

    kinds: Counter[str] = Counter()
    for s in summaries:
        for r in s.get("rows", []):
            if r.get("status") != "ok":
                continue
            fs, er = r.get("sample_rate_hz"), r.get("estimate_rate_hz")
            if er is None or fs is None:
                kinds["at a rate not recorded (stored before revision 0002: every sample)"] += 1
            elif abs(er - fs) <= 1e-6 * fs:
                kinds[f"on every sample ({fs:.6g} Hz)"] += 1
            else:
                k = round(fs / er)
                nth = f"{k}{'th' if 10 <= k % 100 <= 20 else {1: 'st', 2: 'nd', 3: 'rd'}.get(k % 10, 'th')}"
                kinds[f"at {er:.6g} Hz (every {nth} sample of {fs:.6g} Hz recordings)"] += 1
    if not kinds:
        return ""
    parts = [k if len(kinds) == 1 else f"{k}: {n} recording{'s' * (n != 1)}" for k, n in kinds.most_common()]
    return (
        "δ was estimated " + "; ".join(parts) + " — fleet.toml's [fleet] estimate_rate_hz "
        '(1000 unless set, "full" for every sample; docs/assumptions.md, "Estimation rate").'
    )


def render_fleet_report(
    summaries: list[dict[str, Any]],
    measurements: dict[str, list[dict[str, Any]]],
    *,
    title: str,
    store: str,
    notes: Sequence[str] = (),
) -> str:
    """The fleet report's HTML text (see the module docstring).

    Parameters
    ----------
    summaries : list of dict
        :func:`drivelash.wear.alarms.fleet_summary` (sorted by forecast time).
    measurements : dict
        Axis → measurements of other sources (``Store.measurements``).
    title : str
        Page title.
    store : str
        The store's URL (shown, password hidden).
    notes : sequence of str
        Lines added to the overview (e.g. the store's axes that the fleet file no longer names).
    """
    alarms = [(s["axis"], a) for s in summaries for a in s["alarms"]]
    n_rec = sum(s["recordings"] for s in summaries)
    overview = Section(
        "Fleet overview",
        paragraphs=[
            f"{count(len(summaries), 'axis', 'axes')}, {count(n_rec, 'recording')} in {store}; "
            f"{count(len(alarms), 'active alarm')}. "
            "Only recordings with sufficient excitation enter a trend: converged estimates, and "
            "unconverged ones only when nothing but their uncertainty (or an unsettled last window, "
            "its movement added to σ) kept them from converging and that 95 % uncertainty is at most "
            f"{_u95_text(summaries)}, weighted by it. "
            "Axes are sorted by the forecast time to their maintenance threshold. "
            f"{TIMES_UTC} " + rate_sentence(summaries),
        ],
        tables=[("", overview_header(summaries), overview_rows(summaries))],
        text_left=True,
    )
    if any_latest_only(summaries):
        overview.paragraphs.append(NOW_LEGEND + ".")
    why = not_excited_line(summaries)
    if why is not None:
        overview.paragraphs.append(why[0].upper() + why[1:] + ".")
    overview.paragraphs.extend(notes)
    stale = stale_notes(summaries)
    if stale:
        overview.paragraphs.append(
            "Stale forecasts (no recording since, checked against the clock when this report was "
            "written): " + "; ".join(f"{name}: {msg}" for name, msg in stale) + "."
        )
    chart = _crossing_chart(summaries)
    if chart is not None:
        overview.figures.append(chart)
    if alarms:
        alarm_rows = [[ax, a.kind, _day(a.data_time), a.message] for ax, a in alarms]
        alarm_sec = Section(
            "Alarms",
            tables=[("", ["axis", "kind", "data time (UTC)", "message"], alarm_rows)],
            text_left=True,
        )
    else:
        alarm_sec = Section("Alarms", raw=['<p class="verdict-ok">No active alarm.</p>'])
    axes = Section(
        "Axes",
        paragraphs=[
            "Growth models: linear δ = a + b·t and accelerating δ = a + v·(e^{kt} − 1)/k, chosen by AICc "
            "(the accelerating one only when lower by more than 2); one level shift per detected jump, and "
            "after a repair (a drop) the linear model may give the new part its own rate, also by AICc."
        ],
    )
    for s in summaries:
        axes.figures.append(_axis_figure(s, measurements.get(s["axis"], [])))
    sections = [overview, alarm_sec]
    kinds = {s["axis"]: s.get("kind") for s in summaries}
    m_unit = fleet_unit([{"kind": kinds.get(ax)} for ax in measurements if measurements[ax]])
    mrows = [
        [
            m["axis"],
            m["source"],
            _day(m["time"]),
            *_readable(m["value"], m["std"], m["unit"]),
            _mrad(m["value_rad"], gap_unit(kinds.get(ax)), m_unit is None),
            m["reference"] or "–",
        ]
        for ax in sorted(measurements)
        for m in measurements[ax]
    ]
    if mrows:
        as_delta = "as deadzone δ" + ("" if m_unit is None else f" [{m_unit}]")
        head = ["axis", "source", "time", "value", "std", "unit", as_delta, "reference"]
        sections.append(Section("Measurements of other sources", tables=[("", head, mrows)], text_left=True))
    sections.append(axes)
    return render_html(title, sections)


def _u95_text(summaries: list[dict[str, Any]]) -> str:
    """The admission limit of unconverged estimates as the overview states it: in mrad, and in µm
    too when the fleet has a linear axis (:func:`~drivelash.wear.trend.usable`)."""
    text = f"{1e3 * UNCONVERGED_MAX_U95:g} mrad"
    if any(s.get("kind") == "prismatic" for s in summaries):
        lin = gap_unit("prismatic").f(UNCONVERGED_MAX_U95 * trend_scale("prismatic"), "g")
        text += f" ({lin} on a linear axis)"
    return text


def _readable(value: float, std: float | None, unit: str) -> tuple[str, str, str]:
    """A measurement's value, std and unit as a reader wants them: lengths in µm (a laser check
    of lost motion is a few µm to a few hundred), angles in mrad."""
    f, u = {
        "m": (1e6, "µm"),
        "mm": (1e3, "µm"),
        "um": (1.0, "µm"),
        "µm": (1.0, "µm"),
        "rad": (1e3, "mrad"),
    }.get(unit, (1.0, unit))
    return f"{f * value:.2f}", "–" if std is None else f"{f * std:.2f}", u


def write_fleet_report(path: str | Path, html_text: str) -> Path:
    """Write the report text to ``path``: a staging path of ``Outputs`` directly, any other
    path atomically (a failed write leaves an existing file as it was)."""
    from drivelash.report import _write

    return _write(path, html_text)
