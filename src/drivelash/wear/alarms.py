"""Alarms and the per-axis status that ``track status``/``forecast``/``report`` show.

Alarm kinds (each keyed so the same event is raised once and cleared when it no longer holds):

* ``threshold`` — the fitted δ at the latest used recording (never extrapolated across a gap to
  a later estimate far below the trend: :func:`~drivelash.wear.trend.judged_at`) is at or above
  the threshold, or
  the latest excited estimate lies above it by more than :data:`THRESHOLD_Z` of its stated
  uncertainty (also when the trend cannot use it: too few estimates, an outlier or the first
  recording after a jump);
* ``forecast`` — the early (5 %) bound of the forecast crossing lies within the axis's
  horizon after its latest recording;
* ``jump`` — a positive change point (sudden damage), keyed by its time;
* ``not_excited`` / ``not_converged`` / ``no_estimate`` — the latest N recordings
  (``[fleet] not_excited_alarm``) gave no usable estimate: all because the motion did not
  excite the deadzone, all because the estimator did not converge and stated no uncertainty,
  or a mix (failed files do not count);
* ``failed`` — the latest N recordings (the same ``not_excited_alarm``) all failed (unreadable,
  a lost encoder signal): "δ now" and the forecast are those of the last usable one, and the
  alarm says as of when. Fewer than N give a note with the same line (:func:`failed_note`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from typing import Any

import numpy as np

from drivelash.units import gap_unit
from drivelash.wear.store import Store
from drivelash.wear.trend import MIN_POINTS, AxisTrend, analyse, usable
from drivelash.wear.words import UNCONVERGED_MARK, count, crossing_time, to_the_minute

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
#: A recording dated more than this many days after the time of the judgement (the clock at
#: ingest/status) is dated in the future and left out of the trend: a controller clock set to
#: local time and read as UTC is at most 14 h ahead (UTC+14), plus clock drift of minutes; one
#: day covers both, while a date a month or years ahead (a wrong clock) is caught.
FUTURE_TOLERANCE_DAYS = 1.0


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
    u = gap_unit(axis.get("kind"))  # mrad, or µm on a linear axis (its δ in m)
    # the time the trend is judged at (trend.judged_at): never an extrapolation to an estimate
    # that contradicts it
    t_now = trend.t_now if trend.t_now is not None else (float(trend.t[-1]) if trend.t.size else None)
    last_used = trend.to_time(t_now)
    fc = trend.forecast
    ok_rows = sorted(
        (r for r in rows if r["status"] == "ok"), key=lambda r: (r["start_time"] or datetime.min, r["path"])
    )
    # an unconverged estimate only when the trend could take it (its σ states its doubt): one a
    # blocking warning made unconverged raises no alarm (session 32 tester F, F5)
    latest = next(
        (
            r
            for r in reversed(ok_rows)
            if r["excitation_ok"]
            and r["delta"] is not None
            and (r["converged"] or usable(r, axis.get("kind")))
        ),
        None,
    )
    single = None
    if thr is not None and latest is not None and not (fc is not None and fc.crossed):
        sd = latest["delta_std"] if latest["delta_std"] and math.isfinite(latest["delta_std"]) else None
        s_use = sd if sd is not None else trend.sigma
        if latest["delta"] - THRESHOLD_Z * s_use >= thr:
            single = latest, sd
    if single is not None:
        r, sd = single
        pm = f" ± {u.n(sd, '.2f')}" if sd is not None else ""
        cause = (r.get("reason") or "").partition(UNCONVERGED_MARK)[2]
        because = f" ({cause})" if cause else ""
        why = (
            f"estimate not converged{because}: uncertainty ±{u.f(1.96 * sd, '.2f')} (95 %)"
            if not r["converged"] and sd is not None
            else "estimate not converged, no uncertainty stated"
            if not r["converged"]
            else (
                f"no trend: {trend.unfitted}; this estimate alone is above it"
                if trend.unfitted
                else f"too few recordings for a trend yet, {count(len(trend.t), 'usable estimate')} of "
                f"{MIN_POINTS}: this estimate alone is above it"
            )
            if trend.model is None
            else "not in the fitted trend yet: a jump or a bad recording, the next recording decides"
            if not _in_fit(trend, r)
            else "the fitted trend is still below"
        )
        out.append(
            Alarm(
                "threshold",
                "crossed",
                f"{name}: latest estimate {u.n(r['delta'], '.2f')}{pm} {u} ({_day(r['start_time'])}) above "
                f"the threshold {u.f(thr, '.2f')} ({why})",
                r["start_time"],
            )
        )
    if fc is not None and thr is not None:
        if fc.crossed:
            out.append(
                Alarm(
                    "threshold",
                    "crossed",
                    f"{name}: backlash above the threshold {u.f(thr, '.2f')} "
                    f"(fitted {u.f(float(trend.curve(np.array([t_now]))[0][0]), '.2f')})",
                    last_used,
                )
            )
        elif fc.t_early is not None and t_now is not None and fc.t_early - t_now <= axis["horizon_days"]:
            when, early = trend.to_time(fc.t_cross), trend.to_time(fc.t_early)
            late = trend.to_time(fc.t_late) if fc.t_late is not None and math.isfinite(fc.t_late) else None
            minute = to_the_minute(early, late)  # the fleet table's rule for the same interval
            out.append(
                Alarm(
                    "forecast",
                    "within-horizon",
                    f"{name}: threshold {u.f(thr, '.2f')} may be crossed within "
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
                    f"{name}: sudden backlash increase of {u.f(cp.size, '.2f')} at {_day(when)}",
                    when,
                )
            )
    run = 0
    for r in reversed(ok_rows):
        if usable(r, axis.get("kind")):
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
    fails = failed_run(rows)
    if fails and len(fails) >= axis["not_excited_alarm"]:
        out.append(
            Alarm("failed", "latest", str(failed_note(name, fails, last_used)), fails[-1]["start_time"])
        )
    return out


def failed_run(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The axis's latest recordings (store rows) that all failed, oldest first (none when the
    latest dated recording did not fail); recordings without a start time cannot be placed and
    are not counted."""
    dated = sorted(
        (r for r in rows if r["start_time"] is not None), key=lambda r: (r["start_time"], r["path"])
    )
    run: list[dict[str, Any]] = []
    for r in reversed(dated):
        if r["status"] == "ok":
            break
        run.append(r)
    return run[::-1]


def _reason(r: dict[str, Any]) -> str:
    """The first line of a stored row's reason, without its file name (the messages name it)."""
    why = ((r["reason"] or "").strip().splitlines() or [str(r["status"])])[0]
    return why.removeprefix(f"{r['path']}, ").removeprefix(f"{r['path']}: ")


def failed_note(name: str, fails: list[dict[str, Any]], as_of: datetime | None) -> str | None:
    """The one line saying that the latest recordings of axis ``name`` failed (``fails``:
    :func:`failed_run`) and that "δ now" and the forecast are as of ``as_of`` (the time the
    trend is judged at; None: no usable estimate) — None when none failed (session 30 tester
    B, B-06: a lost load-encoder signal left status showing the δ and forecast of 10 days
    before as current)."""
    if not fails:
        return None
    last = fails[-1]
    span = f"{_day(fails[0]['start_time'])} … {_day(last['start_time'])}"
    what = (
        f"the last {len(fails)} recordings failed ({span}"
        if len(fails) > 1
        else f"the last recording failed ({_day(last['start_time'])}"
    )
    since = (
        f"δ now and the forecast are as of {_day(as_of)}"
        if as_of is not None
        else "no usable estimate before them"
    )
    check = "check the axis's signals (encoders) and its export"
    return f"{name}: {what}; latest: {_reason(last)}): {since} — {check}"


def _in_fit(trend: AxisTrend, r: dict[str, Any]) -> bool:
    """Whether store row ``r`` is an inlier of the trend's fit."""
    if trend.t0 is None or r["start_time"] is None:
        return False
    d = (r["start_time"] - trend.t0).total_seconds() / 86400.0
    hit = (abs(trend.t - d) < 1e-9) & (trend.y == r["delta"])
    return bool(np.any(hit & trend.inlier))


def unmatched_note(name: str, unmatched: list[dict[str, Any]], fleet_file: str | None) -> str:
    """The one line naming the stored recordings of axis ``name`` that :func:`split_unmatched`
    left out (``fleet_file``: the fleet file's name)."""
    n = len(unmatched)
    it, they = ("it", "it counts") if n == 1 else ("them", "they count")
    return (
        f"{name}: {count(n, 'stored recording')} left out: "
        + ("its file still exists but is" if n == 1 else "their files still exist but are")
        + f" no longer matched by the axis's 'recordings' in {fleet_file or 'the fleet file'} "
        f"(e.g. {unmatched[0]['path']}); kept in the store, {they} again if the glob matches "
        f"{it} again"
    )


def _axis_notes(
    name: str,
    trend: AxisTrend,
    used: list[dict[str, Any]],
    unmatched: list[dict[str, Any]],
    future: list[dict[str, Any]],
    fleet_file: str | None,
    kind: str | None = None,
) -> list[str]:
    """The one-line notes of an axis's summary: stored recordings left out because the fleet
    file no longer matches them, recordings dated in the future, and latest estimates far
    below the trend that the judgement does not extrapolate to (:func:`~drivelash.wear.trend.judged_at`)."""
    out: list[str] = []
    u = gap_unit(kind)
    if unmatched:
        out.append(unmatched_note(name, unmatched, fleet_file))
    if future:
        n = len(future)
        first = min(future, key=lambda r: r["start_time"])
        out.append(
            f"{name}: {count(n, 'recording')} dated more than {_days(FUTURE_TOLERANCE_DAYS)} after now "
            f"({first['path']}: {first['start_time']:%Y-%m-%d %H:%M} UTC"
            + (", …" if n > 1 else "")
            + "): left out of the trend — a wrong clock or file name?"
        )
    if trend.unfitted is not None:
        # one line instead of statsmodels' SingularMatrixWarning (session 32 tester F, F2)
        out.append(
            f"{name}: no growth model — {trend.unfitted}; check how the recordings are dated "
            f"(the axis's 'time' in {fleet_file or 'the fleet file'}: file-name stamp, clock)"
        )
    if trend.model is not None and trend.t_now is not None and trend.t.size:
        later = np.flatnonzero(trend.t > trend.t_now + 1e-9)
        if later.size:
            j = int(later[-1])
            fit = float(trend.curve(trend.t[j : j + 1])[0][0])
            if trend.y[j] < fit:
                out.append(
                    f"{name}: the latest estimate {u.f(trend.y[j], '.2f')} "
                    f"({_day(trend.to_time(float(trend.t[j])))}) lies far below the trend "
                    f"({u.f(fit, '.2f')} there) and is left out: the machine stood still, or a wrong "
                    f"date? The trend is judged at {_day(trend.to_time(trend.t_now))}, not extrapolated to it"
                )
    return out


def twin_groups(rows: list[dict[str, Any]]) -> list[list[dict[str, Any]]]:
    """Groups of an axis's stored recordings (store rows, status ok) that share the start time,
    the duration and the sample count but not the content: almost surely one measurement
    exported twice (CSV and Parquet), which the content hash cannot tell; each would count in
    the trend (s19 tester, F12). Sorted by start time."""
    groups: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in rows:
        if r["status"] != "ok" or r["start_time"] is None or not r.get("samples"):
            continue
        groups.setdefault((r["start_time"], r["duration_s"], r["samples"]), []).append(r)
    return [
        sorted(g, key=lambda r: r["path"])
        for k, g in sorted(groups.items(), key=lambda kv: kv[0][0])
        if len({r["content_hash"] for r in g}) > 1
    ]


def twin_note(name: str, groups: list[list[dict[str, Any]]]) -> str | None:
    """The one line naming :func:`twin_groups` of axis ``name`` (None when none)."""
    if not groups:
        return None
    g = groups[0]
    more = f" (and {count(len(groups) - 1, 'more start time')})" if len(groups) > 1 else ""
    return (
        f"{name}: {len(g)} recordings start at {g[0]['start_time']:%Y-%m-%d %H:%M:%S} UTC with the same "
        f"duration ({g[0]['duration_s']:g} s) and sample count ({g[0]['samples']}){more} — the same "
        f"recording exported twice? ({', '.join(r['path'] for r in g)}); each counts in the trend: "
        "keep one file or narrow the axis's 'recordings'"
    )


def _days(d: float) -> str:
    """A day count as the horizon is given: "1 day", "60 days", "0.5 days"."""
    return f"{d:g} day" if d == 1 else f"{d:g} days"


def _day(t: datetime | None) -> str:
    """A date of an alarm or stale message, with its clock: "2026-01-08 UTC" (the store keeps
    naive UTC; status and forecast print "UTC" after their times as well)."""
    return t.strftime("%Y-%m-%d UTC") if t is not None else "–"


def _file_id(path: str | os.PathLike[str]) -> tuple[int, int] | None:
    """(device, inode) of an existing file; None when it does not exist (or cannot be read)."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_dev, st.st_ino


@dataclass(frozen=True)
class MatchedFiles:
    """The files an axis's ``recordings`` glob matches (:func:`matched_files`): their paths as the
    glob gave them and their identities (device, inode).

    Attributes
    ----------
    paths : frozenset of str
        The matched paths.
    ids : frozenset of tuple
        Their (device, inode) identities.
    sizes : tuple of (str, int)
        (path, size in bytes) of each: the files a stored recording's content may be at
        (equal content has equal size; :func:`split_unmatched` hashes only those).
    """

    paths: frozenset[str]
    ids: frozenset[tuple[int, int]]
    sizes: tuple[tuple[str, int], ...] = ()


def matched_files(spec: Any) -> MatchedFiles | None:
    """The files an axis's ``recordings`` glob matches now (``spec``: an
    :class:`~drivelash.wear.fleet.AxisSpec`; its listing when it holds one), with their identities
    (device, inode): a fleet file reached through another path (relative, a symlinked directory)
    names the same files with other strings. None when it matches no file: a glob that matches
    nothing (a copy of the fleet file elsewhere, an unmounted share; ingest warns about it) says
    nothing about which stored recordings belong to the axis, so nothing is left out."""
    entries = spec.entries()
    if not entries:
        return None
    return MatchedFiles(
        frozenset(str(f.path) for f in entries),
        frozenset(f.ident for f in entries),
        tuple((str(f.path), int(f.size)) for f in entries),
    )


def split_unmatched(
    rows: list[dict[str, Any]],
    files: MatchedFiles | None,
    seen: dict[str, set[str]] | None = None,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """(rows judged, rows left out): a stored recording whose file still exists but is no longer
    matched by the axis's ``recordings`` glob (``files``, :func:`matched_files`; None = the fleet
    file is not known: nothing left out) is left out — a glob that first pointed at the wrong
    directory and was corrected. A recording whose file no longer exists (archived, deleted)
    stays: that is what a history store is for. A stored path the glob names is kept without
    looking at the file again; only the others are looked up by identity.

    A recording is the content, not one path (session 30 tester B, B-01: the globs pointed at a
    copy of the recordings while the originals still existed, or a fleet directory copied with
    its store; every axis showed 0/0 and every alarm was cleared): it stays when the glob
    matches any path its content was seen under (``seen``: content hash → paths,
    :meth:`~drivelash.wear.store.Store.seen_paths`), or a matched file of its size holds its
    content now (hashed only for a recording that would otherwise be left out)."""
    if files is None:
        return rows, []
    keep: list[dict[str, Any]] = []
    out: list[dict[str, Any]] = []
    digests: dict[str, str] = {}  # matched path -> content hash, hashed once per call
    for r in rows:
        paths = [r["path"], *sorted((seen or {}).get(r["content_hash"], set()) - {r["path"]})]
        if any(p in files.paths for p in paths):
            keep.append(r)
            continue
        fids = [fid for fid in map(_file_id, paths) if fid is not None]
        if not fids or any(fid in files.ids for fid in fids):
            keep.append(r)  # every file gone (the history), or the glob names one by another path
            continue
        (keep if _content_matched(r, files, digests) else out).append(r)
    return keep, out


def _content_matched(r: dict[str, Any], files: MatchedFiles, digests: dict[str, str]) -> bool:
    """Whether a file the glob matches (of the stored recording ``r``'s size) holds its content;
    ``digests`` caches the hashes (matched path → content hash)."""
    from drivelash.wear.estimate import content_hash

    size = r.get("size_bytes")
    if size is None or str(r["content_hash"]).startswith("unreadable:"):
        return False
    for p, n in files.sizes:
        if n != size:
            continue
        if p not in digests:
            digests[p] = content_hash(p)[0]
        if digests[p] == r["content_hash"]:
            return True
    return False


def _naive_utc(t: datetime) -> datetime:
    """A time as the store keeps it: naive UTC."""
    return t.astimezone(UTC).replace(tzinfo=None) if t.tzinfo is not None else t


def axis_summary(store: Store, axis: dict[str, Any], now: datetime | None = None) -> dict[str, Any]:
    """Trend, forecast and alarms of one axis (a dict of plain values plus ``trend``).

    Parameters
    ----------
    store : Store
        The history store.
    axis : dict
        A row of :meth:`~drivelash.wear.store.Store.axes`, with the judging settings of
        :func:`judged_axes`; with its ``files`` (:func:`matched_files`, set by
        :func:`judged_axes` when the fleet file is known) the stored recordings whose file
        exists but is no longer matched are left out (:func:`split_unmatched`).
    now : datetime, optional
        The time of the judgement (default: the clock; naive = UTC). A recording dated more than
        :data:`FUTURE_TOLERANCE_DAYS` after it is left out of the trend and named in
        ``notes`` (a wrong clock or file name).
    """
    files = axis.get("files")
    seen = store.seen_paths(axis["name"]) if files is not None else None
    rows, unmatched = split_unmatched(store.current_estimates(axis), files, seen)
    limit = _naive_utc(now or datetime.now(UTC)) + timedelta(days=FUTURE_TOLERANCE_DAYS)
    future = [r for r in rows if r["start_time"] is not None and _naive_utc(r["start_time"]) > limit]
    if future:
        rows = [r for r in rows if not any(r is f for f in future)]
    trend, used = analyse(rows, axis["threshold_rad"], axis.get("kind") or "rotary")
    alarms = axis_alarms(axis, rows, trend)
    fc = trend.forecast
    last_t = trend.to_time(float(trend.t[-1])) if trend.t.size else None
    t_now = trend.t_now if trend.model and trend.t_now is not None else None
    current = float(trend.curve(np.array([t_now]))[0][0]) if t_now is not None else None
    # without a trend (too few estimates) the views show the latest usable estimate instead of
    # an empty "δ now" (session 30 tester B, B-08)
    latest = None if trend.model else next((r for r in reversed(sorted(
        used, key=lambda r: (r["start_time"] or datetime.min, r["path"])))), None)  # fmt: skip
    remaining = None
    if fc is not None and fc.t_cross is not None and t_now is not None:
        remaining = fc.t_cross - t_now
    notes = _axis_notes(
        axis["name"], trend, used, unmatched, future, axis.get("fleet_file"), axis.get("kind")
    )
    as_of = trend.t_now if trend.t_now is not None else (float(trend.t[-1]) if trend.t.size else None)
    failed = failed_note(axis["name"], failed_run(rows), trend.to_time(as_of))
    if failed is not None and not any(a.kind == "failed" for a in alarms):  # else the alarm says it
        notes.append(failed)
    twins = twin_note(axis["name"], twin_groups(rows))
    if twins is not None:
        notes.append(twins)
    return {
        "axis": axis["name"],
        # "rotary": δ, threshold, noise in rad; "prismatic" (a linear axis): in m (the *_rad keys'
        # names are the store's), shown in µm (drivelash.units.gap_unit)
        "kind": axis.get("kind") or "rotary",
        "threshold_rad": axis["threshold_rad"],
        "recordings": len(rows) + len(future),
        "unmatched": len(unmatched),
        "future": len(future),
        "judged_at": trend.to_time(t_now),
        "notes": notes,
        "used": len(used),
        "unexcited": sum(1 for r in rows if r["status"] == "ok" and not r["excitation_ok"]),
        # excited, but the estimator did not converge (its 95 % uncertainty above its claim);
        # those with a stated uncertainty are in "used", weighted by it
        "unconverged": sum(
            1 for r in rows if r["status"] == "ok" and r["excitation_ok"] and not r["converged"]
        ),
        "unconverged_used": sum(1 for r in used if not r["converged"]),
        "unusable": sum(
            1 for r in rows if r["status"] == "ok" and r["excitation_ok"] and not usable(r, axis.get("kind"))
        ),
        "failed": sum(1 for r in rows if r["status"] != "ok"),
        "outliers": int((~trend.inlier).sum()) if trend.t.size else 0,
        "last_recording": last_t,
        "current_rad": current,
        "latest_rad": latest["delta"] if latest is not None else None,
        "latest_std": latest["delta_std"] if latest is not None else None,
        "latest_time": latest["start_time"] if latest is not None else None,
        "min_points": MIN_POINTS,
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
    Each such axis also gets the files its ``recordings`` glob matches now (``files``,
    :func:`matched_files`): a stored recording whose file exists but is no longer matched is
    left out of its summary (:func:`split_unmatched`).

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
            kind=f.kind,
            files=matched_files(f),
            fleet_file=fleet.path.name,
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


def fleet_summary(
    store: Store, fleet: Any | None = None, now: datetime | None = None
) -> list[dict[str, Any]]:
    """:func:`axis_summary` of every axis, sorted by forecast time to threshold (soonest first;
    crossed axes first, axes without a forecast last); judged with ``fleet``'s current
    thresholds when given, and then only ``fleet``'s axes (:func:`judged_axes`); ``now`` as in
    :func:`axis_summary`."""
    out = [
        axis_summary(store, a) if now is None else axis_summary(store, a, now)
        for a in judged_axes(store, fleet)
    ]

    def key(s: dict[str, Any]) -> tuple:
        if s["crossed"]:
            return (0, 0.0, s["axis"])
        d = s["days_to_threshold"]
        return (1, d, s["axis"]) if d is not None else (2, 0.0, s["axis"])

    out.sort(key=key)
    return out


def _dated_or_written(r: dict[str, Any]) -> datetime | None:
    """A row's start time; for a failed recording that could not be dated, its file's time
    (naive UTC) — a file that failed after the last usable one is a later recording too (the
    stale note left it out: session 30 tester B, B-10)."""
    if r["start_time"] is not None:
        return r["start_time"]
    if r["status"] != "ok" and r.get("mtime_ns") is not None:
        return datetime.fromtimestamp(r["mtime_ns"] / 1e9, UTC).replace(tzinfo=None)
    return None


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
            last = s.get("judged_at") or last
            age = (ref - last).total_seconds() / 86400.0
            later = [r for r in s.get("rows", []) if (t := _dated_or_written(r)) is not None and t > last]
            if not later:
                since = f"with no recording since the last one ({_day(last)}, {count(round(age), 'day')} ago)"
                advice = "record the axis again"
            else:
                failed = sum(1 for r in later if r["status"] != "ok")
                unexc = sum(1 for r in later if r["status"] == "ok" and not r["excitation_ok"])
                out_of = sum(1 for r in later if usable(r, s.get("kind")))
                other = len(later) - failed - unexc - out_of
                parts = [
                    f"{unexc} not excited" if unexc else "",
                    f"{out_of} left out of the trend" if out_of else "",
                    f"{other} not usable" if other else "",
                    f"{failed} failed" if failed else "",
                ]
                since = (
                    f"with no usable estimate since {_day(last)} ({count(round(age), 'day')} ago; "
                    f"{count(len(later), 'later recording')}: {', '.join(p for p in parts if p)})"
                )
                advice = (
                    "record the axis again with a motion that crosses the gap"
                    if unexc
                    else ("check the later recordings")
                )
            out.append(
                (
                    s["axis"],
                    f"the expected crossing {_day(tc)} has passed {since}: the forecast is stale — {advice}",
                )
            )
    return out


def refresh_alarms(store: Store, names: list[str] | None = None, fleet: Any | None = None) -> list[Alarm]:
    """Re-evaluate and store the alarms of the named axes (all when None); returns the active ones.
    With ``fleet`` (the ingest's), its axes are judged as :func:`judged_axes` does: a stored
    recording no longer matched by its axis's glob raises no alarm."""
    active: list[Alarm] = []
    axes = store.axes()
    if fleet is not None:
        judged = {a["name"]: a for a in judged_axes(store, fleet)}
        axes = [judged.get(a["name"], a) for a in axes]
    for a in axes:
        if names is not None and a["name"] not in names:
            continue
        s = axis_summary(store, a)
        store.sync_alarms(a["name"], s["alarms"])
        active.extend(s["alarms"])
    return active
