"""Counted nouns of the wear outputs: "1 active alarm", "2 active alarms", "1 axis"."""

from __future__ import annotations

__all__ = ["count"]


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
