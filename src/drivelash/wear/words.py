"""Words of the wear outputs: counted nouns ("1 active alarm", "2 active alarms", "1 axis")
and the times of a forecast crossing (one rule for the fleet table and the alarm messages)."""

from __future__ import annotations

from datetime import datetime

__all__ = ["MINUTE_INTERVAL_DAYS", "count", "crossing_interval", "crossing_time", "to_the_minute"]

#: A crossing interval shorter than this is printed to the minute [days]: as dates alone its ends
#: read "2026-01-13 … 2026-01-13", which says nothing about its width.
MINUTE_INTERVAL_DAYS = 2.0


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
