"""Words of the wear outputs: counted nouns ("1 active alarm", "2 active alarms", "1 axis")
and the times of a forecast crossing (one rule for the fleet table and the alarm messages), and
why recordings were not excited, in brief (one rule for status, forecast and report)."""

from __future__ import annotations

from datetime import datetime
from typing import Any

__all__ = [
    "MINUTE_INTERVAL_DAYS",
    "REASON_GROUPS_SHOWN",
    "UNCONVERGED_MARK",
    "brief_reason",
    "count",
    "crossing_interval",
    "crossing_time",
    "not_excited_reasons",
    "to_the_minute",
]

#: Separates a stored excited-but-unconverged estimate's excitation reason from why it did not
#: converge (``reason`` column; :func:`drivelash.wear.estimate.estimate_recording`).
UNCONVERGED_MARK = "; not converged: "
#: A crossing interval shorter than this is printed to the minute [days]: as dates alone its ends
#: read "2026-01-13 … 2026-01-13", which says nothing about its width.
MINUTE_INTERVAL_DAYS = 2.0
#: Most groups of reasons :func:`not_excited_reasons` lists (most frequent first); the rest are
#: counted ("2 × other reasons"): the line stays one line however many distinct causes a fleet has
#: (the KR300 recordings of session 32 tester F gave two per axis).
REASON_GROUPS_SHOWN = 3
#: Where an estimator's reason turns from its cause to the explanation (:func:`brief_reason`).
_REASON_CUTS = (": ", "; ", " (", " — ")


def count(n: int, noun: str, plural: str | None = None) -> str:
    """``n`` and ``noun`` in the number ``n`` asks for.

    Parameters
    ----------
    n : int
        How many.
    noun : str
        The singular ("active alarm").
    plural : str, optional
        The plural when it is not ``noun + "s"`` ("axes").

    Returns
    -------
    str
        E.g. ``"1 active alarm"``, ``"0 active alarms"``, ``"3 axes"``.
    """
    return f"{n} {noun if n == 1 else plural or noun + 's'}"


def to_the_minute(early: datetime | None, late: datetime | None) -> bool:
    """Whether the times of a crossing whose 90 % interval is [early, late] (UTC) are printed to
    the minute: the interval is known and shorter than :data:`MINUTE_INTERVAL_DAYS`."""
    return (
        early is not None
        and late is not None
        and (late - early).total_seconds() < MINUTE_INTERVAL_DAYS * 86400.0
    )


def crossing_time(t: datetime | None, minute: bool) -> str:
    """A time of a crossing: ``2026-01-13``, or ``2026-01-13 09:19`` with ``minute``
    (:func:`to_the_minute`); ``–`` for None."""
    if t is None:
        return "–"
    return t.strftime("%Y-%m-%d %H:%M" if minute else "%Y-%m-%d")


def crossing_interval(early: datetime | None, late: datetime | None, never: bool = False) -> str:
    """A crossing's 90 % interval (UTC): ``2026-01-13 … 2026-01-23``; under
    :data:`MINUTE_INTERVAL_DAYS` to the minute, ``2026-01-13 09:19 … 09:24`` (the end's date
    when it differs); ``2026-01-13 … never`` when the upper end never crosses; ``–`` unknown."""
    if early is None:
        return "–"
    if never:
        return f"{crossing_time(early, False)} … never"
    if late is not None and to_the_minute(early, late):
        end = late.strftime("%H:%M" if late.date() == early.date() else "%Y-%m-%d %H:%M")
        return f"{crossing_time(early, True)} … {end}"
    return f"{crossing_time(early, False)} … {crossing_time(late, False)}"


def brief_reason(reason: str | None) -> str:
    """The cause at the head of an estimator's reason, up to its first ": ", "; ", " (" or " — "
    (the rest explains it and what to record instead; ``drivelash estimate`` prints it in full).

    Parameters
    ----------
    reason : str or None
        The stored reason of a recording.

    Returns
    -------
    str
        E.g. ``"the motion reverses only once"`` for "the motion reverses only once: the gap is
        crossed once, …"; ``"no reason stored"`` for None or an empty reason.
    """
    text = (reason or "").strip()
    if not text:
        return "no reason stored"
    cuts = [i for i in (text.find(c) for c in _REASON_CUTS) if i > 0]
    return text[: min(cuts)] if cuts else text


def not_excited_reasons(rows: list[dict[str, Any]], axes: list[str] | None = None) -> str | None:
    """Why recordings were not excited, grouped by :func:`brief_reason`, most frequent first:
    ``"2 × the motion reverses only once; 1 × the shaft torque reversed 5 times but the gap was
    never crossed"`` (None when no row is ``ok`` and not excited). At most
    :data:`REASON_GROUPS_SHOWN` groups; the rest are counted.

    Parameters
    ----------
    rows : list of dict
        Store rows (``status``, ``excitation_ok``, ``reason``).
    axes : list of str, optional
        The axis of each row (a fleet's rows): each group then names its axis, or counts them
        ("on 3 axes").
    """
    groups: dict[str, list[str]] = {}
    for k, r in enumerate(rows):
        if r["status"] == "ok" and not r["excitation_ok"]:
            groups.setdefault(brief_reason(r.get("reason")), []).append("" if axes is None else axes[k])
    if not groups:
        return None
    order = sorted(groups.items(), key=lambda kv: -len(kv[1]))  # stable: first seen first on ties

    def where(names: list[str]) -> str:
        if axes is None:
            return ""
        distinct = sorted(set(names))
        return f" ({distinct[0]})" if len(distinct) == 1 else f" (on {len(distinct)} axes)"

    parts = [f"{len(names)} × {text}{where(names)}" for text, names in order[:REASON_GROUPS_SHOWN]]
    rest = sum(len(names) for _, names in order[REASON_GROUPS_SHOWN:])
    if rest:
        parts.append(f"{rest} × other reasons")
    return "; ".join(parts)
