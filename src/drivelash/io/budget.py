"""Resource guards: refuse up front what would not fit in memory or time.

A request (a simulation length, a sample period, a grid, a file to read whole) is
checked against a stated budget *before* the work starts, and refused with one line
giving the figure it would need and what changes it:

- memory: :data:`MEMORY_FRACTION` of the machine's RAM (the smaller of the physical
  memory, ``os.sysconf``, and a cgroup limit when one is set); override with the
  environment variable ``DRIVELASH_MEMORY_BUDGET`` (bytes, ``512M``, ``8G`` or ``30%``);
- time: :data:`DEFAULT_TIME_BUDGET_S` of compute, estimated from a deliberately fast
  nominal rate so that only requests that are certainly too long are refused; override
  with ``DRIVELASH_TIME_BUDGET`` (seconds).

The numbers and their reasons are in ``docs/assumptions.md`` ("Outputs and bad input").
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from drivelash.errors import ResourceError

__all__ = [
    "DEFAULT_TIME_BUDGET_S",
    "MEMORY_FRACTION",
    "check_budget",
    "check_time",
    "format_bytes",
    "machine_memory",
    "memory_budget",
    "time_budget",
]

#: Fraction of the machine's RAM one command may plan to use.
MEMORY_FRACTION = 0.5
#: Compute-time budget of one request [s] (one hour: a command-line run that would take
#: longer is almost always a mistyped unit or count; set ``DRIVELASH_TIME_BUDGET`` to allow it).
DEFAULT_TIME_BUDGET_S = 3600.0
ENV_MEMORY = "DRIVELASH_MEMORY_BUDGET"
ENV_TIME = "DRIVELASH_TIME_BUDGET"

_UNITS = {"": 1, "K": 1024, "M": 1024**2, "G": 1024**3, "T": 1024**4}


def format_bytes(n: float) -> str:
    """``n`` bytes in a readable binary unit (``1.5 GiB``)."""
    if not n < 1e30:
        return f"{n:.3g} B"
    for unit, scale in (("TiB", 1024**4), ("GiB", 1024**3), ("MiB", 1024**2), ("KiB", 1024)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n:.0f} B"


def _cgroup_limit() -> int | None:
    for p in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            text = Path(p).read_text().strip()
        except OSError:
            continue
        if text.isdigit() and int(text) < 1 << 60:
            return int(text)
    return None


def machine_memory() -> int:
    """RAM available to this process [bytes]: physical memory, or the cgroup limit if smaller."""
    phys = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    lim = _cgroup_limit()
    return min(phys, lim) if lim else phys


def memory_budget() -> tuple[int, str]:
    """The memory budget [bytes] and a description of where it comes from."""
    env = os.environ.get(ENV_MEMORY, "").strip()
    if env:
        m = re.fullmatch(r"(\d+(?:\.\d*)?)\s*(%|[KMGT]?)i?B?", env, flags=re.IGNORECASE)
        if m is None:
            raise ResourceError(
                f"{ENV_MEMORY}={env!r}: not a size (use bytes, e.g. 512M, 8G, or a percentage like 30%)"
            )
        value, unit = float(m[1]), m[2].upper()
        if unit == "%":
            return int(machine_memory() * value / 100), f"{value:g}% of this machine's RAM ({ENV_MEMORY})"
        return int(value * _UNITS[unit]), f"{ENV_MEMORY}={env}"
    source = f"{MEMORY_FRACTION:.0%} of this machine's RAM; set {ENV_MEMORY} to change"
    return int(machine_memory() * MEMORY_FRACTION), source


def time_budget() -> tuple[float, str]:
    """The compute-time budget [s] and a description of where it comes from."""
    env = os.environ.get(ENV_TIME, "").strip()
    if env:
        try:
            value = float(env)
        except ValueError:
            raise ResourceError(f"{ENV_TIME}={env!r}: not a number of seconds") from None
        return value, f"{ENV_TIME}={env}"
    return DEFAULT_TIME_BUDGET_S, f"default; set {ENV_TIME} [s] to change"


def check_budget(nbytes: float, *, what: str, option: str | None = None) -> None:
    """Refuse a request that would need more than the memory budget.

    Parameters
    ----------
    nbytes : float
        Estimated peak memory of the request [bytes].
    what : str
        The request, naming its input (``"simulate bench-0A --duration 1e+06"``).
    option : str, optional
        What reduces the request (``"shorten --duration"``).

    Raises
    ------
    ResourceError
        One line: the figure needed, the budget and what changes it.
    """
    budget, source = memory_budget()
    if not nbytes <= budget:  # also refuses NaN
        hint = f"; {option}" if option else ""
        raise ResourceError(
            f"{what}: would need about {format_bytes(nbytes)} of memory, more than the budget of "
            f"{format_bytes(budget)} ({source}){hint}"
        )


def check_time(seconds: float, *, what: str, option: str | None = None) -> None:
    """Refuse a request whose estimated compute time exceeds the time budget (see :func:`check_budget`)."""
    budget, source = time_budget()
    if not seconds <= budget:
        hint = f"; {option}" if option else ""
        raise ResourceError(
            f"{what}: would take at least {_fmt_time(seconds)} of compute, more than the budget of "
            f"{_fmt_time(budget)} ({source}){hint}"
        )


def _fmt_time(s: float) -> str:
    if not s < 1e12:
        return f"{s:.3g} s"
    if s >= 86400:
        return f"{s / 86400:.3g} days"
    if s >= 3600:
        return f"{s / 3600:.3g} h"
    return f"{s:.3g} s"
