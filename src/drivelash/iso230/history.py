"""ISO 230-2 checks in the wear history (:mod:`drivelash.wear.store`), beside the estimates.

A laser check is stored as a measurement of source ``"iso230-2"`` for the axis
(``Store.add_measurement``): the value is the lost motion of the test — −B̄, plus the
control's reversal compensation, with the reference drift removed when it was estimated
— with its standard uncertainty, in m at the load (linear axis) or in rad on the
deadzone's scale (rotary axis, through ``[transmission] i_G``). The store converts m to
rad with the axis's transmission, so the trend plots show laser checks and
recording-based estimates on one axis. The ISO values (A, B with its interval, B̄, E, M,
R, …) go into the measurement's details. The key is the SHA-256 of the measurement
file: storing the same file again is a no-op.

The deadzone to compare with can come from the same history: the excited estimate of the
axis nearest in time to the check (the last one before it when there is one).
"""

from __future__ import annotations

import hashlib
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from drivelash.errors import DataError
from drivelash.iso230.compare import Deadzone

__all__ = ["SOURCE", "check_time", "deadzone_from_store", "store_check"]

#: The ``source`` of ISO 230-2 checks in the history store.
SOURCE = "iso230-2"


def check_time(measurement: Path, given: str | None) -> tuple[datetime, str]:
    """When the check was made: ``--time`` (ISO 8601, naive = UTC) or the file's mtime.

    Returns
    -------
    time : datetime
        Aware, UTC.
    how : str
        ``"--time"`` or ``"file modification time"``.

    Raises
    ------
    DataError
        ``--time`` is not an ISO 8601 date/time.
    """
    if given is not None:
        try:
            t = datetime.fromisoformat(given)
        except ValueError:
            raise DataError(f"--time {given!r}: not an ISO 8601 date/time (e.g. 2026-03-01T14:30)") from None
        return (t.replace(tzinfo=UTC) if t.tzinfo is None else t.astimezone(UTC)), "--time"
    return datetime.fromtimestamp(measurement.stat().st_mtime, tz=UTC), "file modification time"


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def deadzone_from_store(store: Any, axis: str, when: datetime) -> Deadzone | None:
    """The axis's estimate nearest to ``when`` (the last one before it first) among those its
    wear trend uses (:func:`drivelash.wear.trend.usable`: excited, and converged or with a stated
    95 % uncertainty within the trend's gate — then with a note saying so), with the axis kind the
    store holds (a linear axis's δ is in m at the table; NULL, an older store: rotary).

    Returns None when the history holds no usable estimate for the axis.
    """
    from drivelash.iso230.compare import unconverged_note
    from drivelash.wear.trend import usable

    naive = when.astimezone(UTC).replace(tzinfo=None)
    ax = next((a for a in store.axes() if a["name"] == axis), {"name": axis})
    rows = [r for r in store.current_estimates(ax) if usable(r)]
    if not rows:
        return None
    before = [r for r in rows if r["start_time"] <= naive]
    best = max(before, key=lambda r: r["start_time"]) if before else min(rows, key=lambda r: r["start_time"])
    return Deadzone(
        float(best["delta"]),
        None if best.get("delta_std") is None else float(best["delta_std"]),
        f"{store.name}, axis {axis}, recording {Path(best['path']).name}",
        best["start_time"].isoformat(timespec="seconds"),
        None if best["converged"] else unconverged_note(float(best["delta_std"]), None, ax.get("kind")),
        axis=ax.get("kind") or "rotary",
    )


def axis_factor(store: Any, axis: str) -> float | None:
    """The axis's transmission in the store, in m of load travel per rad (None when not set)."""
    store.axis_id(axis)  # an unknown axis is a one-line error
    for a in store.axes():
        if a["name"] == axis and a.get("transmission_mm_per_rad"):
            return float(a["transmission_mm_per_rad"]) * 1e-3
    return None


def store_check(
    store: Any,
    axis: str,
    measurement: Path,
    when: datetime,
    result: Any,
    lost_motion: float,
    u_lost_motion: float,
    *,
    rotary_factor: float | None = None,
    extra: dict[str, Any] | None = None,
) -> int:
    """Store the check; returns the measurement id (the existing one for a file stored before).

    Parameters
    ----------
    store : Store
    axis : str
        ``machine/axis``.
    measurement : Path
        The measurement file (its SHA-256 is the key).
    when : datetime
        Time of the check.
    result : Iso230Result
    lost_motion, u_lost_motion : float
        The value stored and its standard uncertainty [m, or rad at the load].
    rotary_factor : float, optional
        For a rotary axis: load rad per rad of deadzone (1/i_G); the value is stored in
        rad on the deadzone's scale.
    extra : dict, optional
        More details (drift, compensation, …).
    """
    if result.unit == "rad":
        f = rotary_factor or 1.0
        value, std, unit = lost_motion / f, u_lost_motion / f, "rad"
    else:
        value, std, unit = lost_motion, u_lost_motion, "m"
    details = {
        "quantity": "lost motion −B̄ (+ compensation, drift removed when estimated)",
        "unit_of_iso_values": result.unit,
        "targets": result.m,
        "runs_per_direction": result.n,
        **{k: float(getattr(result, k)) for k in result.AXIS_KEYS},
        "u_B": result.u_B,
        "B_interval": list(result.B_interval),
        "u_B_mean": result.u_B_mean,
        **(extra or {}),
    }
    return store.add_measurement(
        axis,
        when,
        value=value,
        std=std,
        unit=unit,
        source=SOURCE,
        reference=str(measurement),
        key=_sha256(measurement),
        details=details,
    )
