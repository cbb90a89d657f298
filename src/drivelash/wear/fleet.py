"""The fleet inventory (``fleet.toml``): one ``[[axis]]`` per monitored axis.

Example::

    [fleet]
    name = "line 3"
    db = "wear.sqlite"            # default store (relative to this file); --db overrides
    method = "default"            # estimator law used for every axis
    horizon_days = 30             # alarm when the forecast crossing may lie within this horizon
    not_excited_alarm = 5         # alarm after this many consecutive recordings without excitation
    estimate_rate_hz = 1000       # estimate on every k-th sample, rate/k >= this; "full": every sample
    time = { from = "filename", pattern = '(\\d{8}T\\d{6})', format = "%Y%m%dT%H%M%S" }

    [[axis]]
    id = "M01/X"                  # machine/axis
    drive = "drives/M01-X.toml"   # the `drivelash estimate` config: [drivetrain], [backlash], [columns]
    recordings = "rec/M01/X/*.parquet"   # glob, relative to this file
    threshold = 0.2               # maintenance threshold: rad at the load …
    # threshold_unit = "mm"       # … or mm at the load, with
    # transmission = 1.59         #   mm of load travel per rad of load angle

    [[axis]]
    id = "M01/Z"                  # a linear (prismatic) axis: its drive file's [columns] give
    drive = "drives/M01-Z.toml"   #   the positions in a length unit (m, mm, µm)
    recordings = "rec/M01/Z/*.csv"
    threshold = 30                # lost-motion threshold …
    threshold_unit = "um"         # … in µm ("um" or "µm"; "mm"; "m", the default on a linear axis)

The axis's kind follows its drive file (:func:`drive_axis_kind`): positions in a length unit make it
linear, and its δ, threshold and noise are lengths (m; shown in µm), else rotary (rad; shown in mrad).
On a linear axis ``threshold`` is in m unless ``threshold_unit`` says µm or mm; ``transmission``
(mm per rad, a rotary axis's lead) and ``threshold_unit = "rad"`` have no meaning there and are refused.

How the recording's start time is found (``time`` per axis, or the fleet default):

* ``from = "filename"``: ``pattern`` is a regular expression whose first group (or group
  ``time``) is parsed with ``format`` (``strptime``; UTC unless the format has ``%z``);
* ``from = "column"``: the first value of file column ``column`` is a POSIX time stamp in
  ``unit`` (s, ms, us), or the column's first ISO 8601 stamp (``2026-03-02T08:15:00+01:00``);
* ``from = "metadata"``: key ``key`` (default ``start_time``) of the file's own metadata
  (the ``drivelash.meta`` block of Parquet/CSV/HDF5/MAT files), ISO 8601;
* ``from = "mtime"``: the file's modification time (last resort: copies change it).

A stamp without an offset (file name, ISO column or metadata) is read in ``zone`` (an IANA time
zone name, default ``"UTC"``): ``zone = "Europe/Berlin"`` for a controller writing local wall-clock
time; a stamp with an offset keeps it, and POSIX stamps and mtime are UTC by definition.

Every error is one :class:`~drivelash.errors.ConfigError` line naming the file, the table
(``[[axis]] #k (id 'M01/X')``) and the key.
"""

from __future__ import annotations

import difflib
import glob
import hashlib
import json
import math
import os
import re
import stat
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from drivelash.errors import ConfigError, DrivelashError
from drivelash.io.config import DriveConfig, load_config, read_toml
from drivelash.params import DELTA_MAX_DEFAULT
from drivelash.units import LENGTH_TO_M, gap_unit

__all__ = [
    "AxisSpec",
    "Fleet",
    "ListedFile",
    "TimeSpec",
    "drive_axis_kind",
    "load_fleet",
    "parse_fleet",
    "time_spec_hash",
]


#: Largest maintenance threshold on the backlash δ [rad at the load] taken as meant on an axis
#: whose drive file does not say its gap is large (docs/assumptions.md): the project's thresholds
#: are 0.07–0.2 rad (simulated fleets: δ₀ + growth ≤ 0.2 rad); 0.5 rad (29°) is no backlash of a
#: usual drive train, while a threshold written in mrad (86.46 for 0.08646 rad) lands far above it.
MAX_THRESHOLD_RAD = 0.5
#: … unless the axis's own drive file gives a larger gap: up to this multiple of its
#: ``[backlash] delta1`` (δ1 lies inside the gap, about half of it on the bench's couplings:
#: 0.093 of 0.186 rad, 0.5135 of 1.027 rad), so 4·δ1 ≈ twice the gap — 100 % wear — and never
#: beyond the estimator's δ_max, which no estimate can exceed. The paper's deadzone A (δ = 1.027
#: rad, δ1 = 0.5135) was refused at any threshold ≥ 0.5 rad (session 32 tester F, F7); with it
#: the limit is min(4 × 0.5135, δ_max = 2) = 2 rad, and an mrad slip (1100 for 1.1 rad) is still
#: 550× beyond.
THRESHOLD_DELTA1_FACTOR = 4.0
#: Largest lost-motion threshold [m] taken as meant on a linear (prismatic) axis whose drive file
#: does not say its gap is larger (docs/assumptions.md): a ball-screw or linear-motor axis's lost
#: motion is 5–60 µm, a rack and pinion's 0.05–0.3 mm; 1 mm is no backlash of a usual linear axis,
#: while a threshold written in µm (30 for 30e-6 m) lands 30 000× beyond it and one written in mm
#: (0.03 for 30 µm, what the rad hint said until session 34) 30× beyond.
MAX_THRESHOLD_M = 1e-3
#: Units ``threshold_unit`` takes for a length, and their factor to m.
THRESHOLD_LENGTH_UNITS = LENGTH_TO_M


def drive_axis_kind(drive: DriveConfig) -> str:
    """The kind of axis a drive file describes: "prismatic" when its ``[columns]`` give the motor
    position in a length unit or its velocity in a length velocity (the loader's rule,
    :func:`drivelash.io.config.is_prismatic`: its recordings carry m, m/s, N), else "rotary".

    Parameters
    ----------
    drive : DriveConfig
        The axis's drive configuration.

    Returns
    -------
    str
        "prismatic" or "rotary" (also without ``[columns]``: recordings in Trace names are read
        as SI rad unless their own metadata says otherwise — ingest then refuses them,
        :func:`drivelash.wear.estimate.estimate_recording`).
    """
    from drivelash.io.config import columns_axis

    return columns_axis(drive.columns)


def threshold_limit(drive: DriveConfig, kind: str = "rotary") -> tuple[float, str]:
    """The largest threshold [rad at the load, or m on a linear axis] an axis with this drive file
    takes as meant, and what sets it (for the message): :data:`MAX_THRESHOLD_RAD` (on a linear
    axis :data:`MAX_THRESHOLD_M`), or :data:`THRESHOLD_DELTA1_FACTOR` × the drive's δ1 (at most
    its δ_max) when that is larger.

    Parameters
    ----------
    drive : DriveConfig
        The axis's drive configuration ([backlash] delta1 [rad or m], [estimator] delta_max).
    kind : str
        "rotary" or "prismatic" (:func:`drive_axis_kind`).

    Returns
    -------
    (float, str)
        The limit and its basis, e.g. ``"limit 0.5 rad"`` or ``"limit 1000 µm"``.
    """
    u = gap_unit(kind)
    base = MAX_THRESHOLD_M if kind == "prismatic" else MAX_THRESHOLD_RAD

    def shown(x: float) -> str:
        return f"{x:g} rad" if kind != "prismatic" else u.f(x, "g")

    delta1 = getattr(drive.backlash, "delta1", None)
    delta_max = getattr(drive.estimator, "delta_max", None)
    delta_max = DELTA_MAX_DEFAULT if delta_max is None else float(delta_max)
    if delta1 is None or not math.isfinite(delta1):
        return base, f"limit {shown(base)}"
    own = min(THRESHOLD_DELTA1_FACTOR * float(delta1), delta_max)
    if own <= base:
        return base, f"limit {shown(base)}"
    if own >= delta_max:
        return own, f"limit {shown(own)}: the estimator's delta_max, no estimate exceeds it"
    return own, f"limit {shown(own)}: {THRESHOLD_DELTA1_FACTOR:g} × the drive's delta1 {shown(float(delta1))}"


def _threshold_slip(a: AxisSection, drive: DriveConfig, kind: str = "rotary") -> str | None:
    """Why ``a.threshold`` looks like a unit slip (None: plausible), judged against the axis's
    drive file (:func:`threshold_limit`); ``kind``: the axis's (:func:`drive_axis_kind`)."""
    limit, basis = threshold_limit(drive, kind)
    if kind == "prismatic":
        unit = a.threshold_unit or "m"
        m = a.threshold * THRESHOLD_LENGTH_UNITS[unit]
        if m < limit:
            return None
        # the hint writes the number as meant in µm, the unit of a linear axis's lost motion —
        # unless it is in µm already (the hint then repeated the setting; session 34 last read)
        head = (
            f"{a.threshold:g} {unit} is {1e3 * m:.4g} mm of lost motion on a linear axis, no backlash"
            f" threshold ({basis})"
        )
        if unit in ("um", "µm"):
            return f"{head}: the key is in µm already — a linear axis's lost motion is µm to tens of µm"
        return (
            f"{head}; the key is in {unit} — {a.threshold:g} µm is"
            f' threshold = {a.threshold:g} with threshold_unit = "um"'
            + (f" (or threshold = {a.threshold * 1e-6:.6g} in m)" if unit == "m" else "")
        )
    if a.threshold_unit in (None, "rad"):
        if a.threshold < limit:
            return None
        return (
            f"{a.threshold:g} rad ({math.degrees(a.threshold):.4g}°) at the load is no backlash threshold"
            f" ({basis}); the key is in rad — {a.threshold:g} mrad is"
            f" threshold = {a.threshold * 1e-3:.6g}"
        )
    mm = a.threshold * THRESHOLD_LENGTH_UNITS[a.threshold_unit] * 1e3
    rad = mm / float(a.transmission or 1.0)
    if rad < limit:
        return None
    shown = "µm" if a.threshold_unit in ("um", "µm") else a.threshold_unit
    head = (
        f"{a.threshold:g} {shown} is {rad:.4g} rad at the load (transmission {a.transmission:g} mm/rad),"
        f" no backlash threshold ({basis})"
    )
    if shown == "µm":  # a slip to µm cannot be suggested for a value already in µm
        return f"{head}: check the value and the transmission"
    return f"{head}; the key is in {shown} — {a.threshold:g} µm is threshold = {a.threshold * 1e-3:.6g}" + (
        "" if a.threshold_unit == "mm" else ' with threshold_unit = "mm"'
    )


def _axis_kind_and_threshold(a: AxisSection, drive: DriveConfig) -> tuple[str, float, str | None]:
    """The axis's kind (:func:`drive_axis_kind`), its threshold in the kind's SI unit (rad at the
    load, or m) and why the unit keys do not fit the kind (None when they do)."""
    kind = drive_axis_kind(drive)
    unit = a.threshold_unit
    if kind == "prismatic":
        if unit == "rad":
            return (
                kind,
                math.nan,
                (
                    "threshold_unit = 'rad' on a linear axis (its drive file's [columns] give positions in"
                    " a length unit): its lost motion is a length — threshold_unit = 'um', 'mm' or 'm'"
                    " (the default)"
                ),
            )
        if a.transmission is not None:
            return (
                kind,
                math.nan,
                (
                    "'transmission' (mm of load travel per rad) has no meaning on a linear axis (its drive"
                    " file's [columns] give positions in a length unit): its threshold is a length already —"
                    " threshold_unit = 'um', 'mm' or 'm' (the default)"
                ),
            )
        return kind, a.threshold * THRESHOLD_LENGTH_UNITS[unit or "m"], None
    if unit in (None, "rad"):
        return kind, a.threshold, None
    if a.transmission is None:
        return (
            kind,
            math.nan,
            (
                f"threshold_unit = '{unit}' needs 'transmission' (mm of load travel per rad) on a rotary"
                " axis; a linear axis is one whose drive file's [columns] give positions in a length unit"
            ),
        )
    return kind, a.threshold * THRESHOLD_LENGTH_UNITS[unit] * 1e3 / float(a.transmission), None


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)


def _a_number(v: Any) -> Any:
    """Before pydantic's coercion: a TOML boolean or string is not a number (``threshold = true``
    became 1 rad, ``threshold = "0.08"`` was read as 0.08)."""
    if isinstance(v, bool) or isinstance(v, str):
        raise ValueError(f"must be a number, got {type(v).__name__} {v!r}")
    return v


class TimeSpec(_Strict):
    """How the start time of a recording is found (see the module docstring)."""

    source: Literal["filename", "column", "metadata", "mtime"] = Field(alias="from")
    pattern: str | None = None
    format: str | None = None
    column: str | None = None
    unit: Literal["s", "ms", "us"] = "s"
    key: str = "start_time"
    zone: str = "UTC"

    @field_validator("zone")
    @classmethod
    def _zone(cls, v: str) -> str:
        from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

        try:
            ZoneInfo(v)
        except (ZoneInfoNotFoundError, ValueError):
            raise ValueError(
                f"zone {v!r} is not a time zone name (IANA, e.g. 'Europe/Berlin' or 'UTC')"
            ) from None
        return v

    @model_validator(mode="after")
    def _complete(self) -> TimeSpec:
        if self.source == "filename":
            if not self.pattern:
                raise ValueError("from = 'filename' needs 'pattern' (a regular expression)")
            try:
                rx = re.compile(self.pattern)
            except re.error as exc:
                raise ValueError(f"'pattern' is not a valid regular expression ({exc})") from None
            if rx.groups < 1:
                raise ValueError("'pattern' needs one group capturing the time stamp")
            if not self.format:
                raise ValueError("from = 'filename' needs 'format' (strptime, e.g. '%Y%m%dT%H%M%S')")
        if self.source == "column" and not self.column:
            raise ValueError("from = 'column' needs 'column' (the file column with POSIX time stamps)")
        return self


class FleetSection(_Strict):
    """``[fleet]``: defaults for every axis."""

    name: str = "fleet"
    db: str = "wear.sqlite"
    method: Literal["default", "paper"] = "default"
    horizon_days: float = Field(default=30.0, gt=0)
    not_excited_alarm: int = Field(default=5, ge=1)
    estimate_rate_hz: float | Literal["full"] = 1000.0
    time: TimeSpec | None = None

    @field_validator("horizon_days", "not_excited_alarm", mode="before")
    @classmethod
    def _numbers(cls, v: Any) -> Any:
        return _a_number(v)

    @field_validator("estimate_rate_hz", mode="before")
    @classmethod
    def _rate_type(cls, v: Any) -> Any:
        return v if v == "full" else _a_number(v)

    @field_validator("estimate_rate_hz")
    @classmethod
    def _rate(cls, v: float | str) -> float | str:
        if v != "full" and not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ValueError(f"must be a rate in Hz > 0 or 'full', got {v!r}")
        return v


class AxisSection(_Strict):
    """One ``[[axis]]`` entry."""

    id: str
    drive: str
    recordings: str
    threshold: float = Field(gt=0)
    #: None: the axis's own unit, rad on a rotary axis, m on a linear one
    threshold_unit: Literal["rad", "m", "mm", "um", "µm"] | None = None
    transmission: float | None = Field(default=None, gt=0)
    time: TimeSpec | None = None

    @field_validator("id")
    @classmethod
    def _machine_axis(cls, v: str) -> str:
        if not re.fullmatch(r"[^/\s]+/[^/\s]+", v):
            raise ValueError(f"must be 'machine/axis' (one '/', no spaces), got {v!r}")
        return v

    @field_validator("threshold", "transmission", mode="before")
    @classmethod
    def _numbers(cls, v: Any) -> Any:
        return _a_number(v)

    @field_validator("threshold", "transmission")
    @classmethod
    def _finite(cls, v: float | None) -> float | None:
        if v is not None and not math.isfinite(v):
            raise ValueError(f"must be finite, got {v!r}")
        return v


class FleetFile(_Strict):
    """The whole ``fleet.toml``."""

    fleet: FleetSection = FleetSection()
    axis: list[AxisSection]


@dataclass(frozen=True)
class ListedFile:
    """One recording as the listing of an axis saw it (:meth:`AxisSpec.scan`).

    Attributes
    ----------
    path : Path
        The path as the glob gave it.
    size : int
        Size [bytes].
    mtime_ns : int
        Modification time [ns since the epoch].
    ident : tuple of int
        (device, inode): the file's identity whichever path reaches it.
    """

    path: Path
    size: int
    mtime_ns: int
    ident: tuple[int, int]


@dataclass(frozen=True)
class AxisSpec:
    """One axis, resolved: paths absolute, drive config loaded, threshold in rad.

    Attributes
    ----------
    name : str
        ``machine/axis``.
    drive_path : Path
        The drive configuration file.
    drive : DriveConfig
        Its parsed content (``[drivetrain]``, ``[backlash]``, ``[columns]`` …).
    drive_hash : str
        SHA-256 of the canonical JSON of ``drive`` and the estimation method: the
        estimate's config hash (an edited drive file gives new estimates).
    recordings : str
        Absolute glob of the recordings.
    threshold_rad : float
        Maintenance threshold on δ in the axis's SI unit: rad at the load, or m on a linear
        axis (``kind`` "prismatic"; the name is the store's column's).
    transmission : float or None
        mm of load travel per rad of load angle (for thresholds and laser checks in mm; a
        rotary axis only).
    time : TimeSpec
        How the start time is found.
    method : str
        Estimator law.
    estimate_rate_hz : float or None
        Estimation rate [Hz]: recordings sampled faster are estimated on every k-th sample
        (``rate / k >= estimate_rate_hz``); None: every sample.
    horizon_days : float
        Forecast-alarm horizon [days].
    not_excited_alarm : int
        Consecutive unexcited recordings that raise an alarm.
    listing : tuple of ListedFile or None
        The files as listed once by :meth:`listed` (None: :meth:`files` globs each time).
    kind : str
        "rotary" (δ in rad) or "prismatic" (a linear axis, δ in m; :func:`drive_axis_kind`).
    """

    name: str
    drive_path: Path
    drive: DriveConfig
    drive_hash: str
    recordings: str
    threshold_rad: float
    transmission: float | None
    time: TimeSpec
    method: str
    horizon_days: float
    not_excited_alarm: int
    estimate_rate_hz: float | None = None
    listing: tuple[ListedFile, ...] | None = field(default=None, compare=False, repr=False)
    kind: str = "rotary"

    def at_rate(self, estimate_rate_hz: float | None) -> AxisSpec:
        """This axis estimated at another rate (None: every sample), with the config hash
        that rate gives — the two always change together.

        Parameters
        ----------
        estimate_rate_hz : float or None
            Estimation rate [Hz]; None: every sample.
        """
        return replace(
            self,
            estimate_rate_hz=estimate_rate_hz,
            drive_hash=config_hash(self.drive, self.method, estimate_rate_hz),
        )

    @property
    def machine(self) -> str:
        """The machine part of the id."""
        return self.name.split("/", 1)[0]

    def scan(self) -> tuple[ListedFile, ...]:
        """The regular files the ``recordings`` glob matches now, sorted by path, each seen by one
        ``stat`` (a file gone between the glob and its stat is not listed)."""
        out: list[ListedFile] = []
        for p in glob.glob(self.recordings, recursive=True):
            try:
                st = os.stat(p)
            except OSError:
                continue
            if stat.S_ISREG(st.st_mode):
                out.append(ListedFile(Path(p), int(st.st_size), int(st.st_mtime_ns), (st.st_dev, st.st_ino)))
        return tuple(sorted(out, key=lambda f: f.path))

    def listed(self) -> AxisSpec:
        """This axis with its files listed once (:meth:`scan`): :meth:`entries` and :meth:`files`
        then give that listing instead of globbing again, so every step of one ingest sees the
        same files (a recording written meanwhile waits for the next ingest) and a network share
        is listed once."""
        return replace(self, listing=self.scan())

    def entries(self) -> tuple[ListedFile, ...]:
        """The matched files with their size, modification time and identity: the listing of
        :meth:`listed`, else a fresh :meth:`scan`."""
        return self.listing if self.listing is not None else self.scan()

    def files(self) -> list[Path]:
        """The recordings matched by the glob, sorted by path (the listing of :meth:`listed` if
        taken)."""
        return [f.path for f in self.entries()]


@dataclass(frozen=True)
class Fleet:
    """A parsed inventory: its file, defaults and axes.

    Attributes
    ----------
    path : Path
        The ``fleet.toml``.
    name : str
        ``[fleet] name``.
    db : str
        ``[fleet] db``, the default store as written: a URL, or an SQLite path relative to
        the file's directory.
    axes : tuple of AxisSpec
        The axes, resolved.
    """

    path: Path
    name: str
    db: str
    axes: tuple[AxisSpec, ...]

    def listed(self) -> Fleet:
        """The fleet with every axis's files listed once (:meth:`AxisSpec.listed`)."""
        return replace(self, axes=tuple(a.listed() for a in self.axes))


def _where(loc: tuple[Any, ...], data: dict[str, Any]) -> tuple[str, str]:
    """(table description, key) of a pydantic error location."""
    parts = [p for p in loc if p not in ("float", "str", "int", "bool")]
    if parts and parts[0] == "axis" and len(parts) >= 2 and isinstance(parts[1], int):
        k = parts[1]
        ident = ""
        try:
            ident = f" (id {data['axis'][k]['id']!r})"
        except (KeyError, IndexError, TypeError):
            pass
        rest = [str(p) for p in parts[2:]]
        table = f"[[axis]] #{k + 1}{ident}"
        if len(rest) > 1:
            table += " " + ".".join(rest[:-1])
        return table, (rest[-1] if rest else "")
    if len(parts) >= 2:
        return f"[{'.'.join(str(p) for p in parts[:-1])}]", str(parts[-1])
    return "top level", str(parts[0]) if parts else ""


def _valid(table: str) -> list[str]:
    if table.startswith("[[axis]]"):
        return list(AxisSection.model_fields) if "time" not in table else ["from", *TimeSpec.model_fields]
    if table == "[fleet]":
        return list(FleetSection.model_fields)
    if "time" in table:
        return ["from", *TimeSpec.model_fields]
    return ["fleet", "axis"]


def _format(source: str, err: dict[str, Any], data: dict[str, Any]) -> str:
    table, key = _where(tuple(err.get("loc", ())), data)
    kind = err.get("type", "")
    if kind == "extra_forbidden":
        close = difflib.get_close_matches(key, [v for v in _valid(table) if v != "source"], n=1, cutoff=0.5)
        hint = f"; did you mean '{close[0]}'?" if close else ""
        return f"{source}: table {table}, key '{key}': unknown key{hint}"
    if kind == "missing":
        return f"{source}: table {table}, key '{key}': missing"
    msg = str(err.get("msg", "invalid value")).replace("\n", " ")
    msg = msg.removeprefix("Value error, ")
    if key in ("", "time") and kind == "value_error":
        return f"{source}: table {table}{' ' + key if key else ''}: {msg}"
    got = err.get("input")
    if not isinstance(got, dict | list) and kind != "value_error":
        msg = f"{msg} (got {got!r})"
    return f"{source}: table {table}, key '{key}': {msg}"


def time_spec_hash(spec: TimeSpec) -> str:
    """SHA-256 (hex) of a ``time`` specification's canonical JSON: stored with each recording's
    start time, so a changed specification re-dates the recordings (``wear.ingest.redate``)."""
    doc = spec.model_dump(mode="json", by_alias=True)
    if doc.get("zone") == "UTC":  # the default: absent, so the hashes stored before it are unchanged
        del doc["zone"]
    return hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()


def config_hash(drive: DriveConfig, method: str, estimate_rate_hz: float | None = None) -> str:
    """SHA-256 (hex) of the drive configuration's canonical JSON, the method and the
    estimation rate (absent at the full rate, so those hashes are unchanged)."""
    doc: dict[str, Any] = {"drive": drive.model_dump(mode="json", exclude_none=True), "method": method}
    if estimate_rate_hz is not None:
        doc["estimate_rate_hz"] = float(estimate_rate_hz)
    return hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()


def parse_fleet(data: dict[str, Any], path: Path) -> Fleet:
    """Validate a parsed ``fleet.toml`` and resolve its axes (drive configs loaded).

    Raises
    ------
    ConfigError
        One line naming the file, the table and the key.
    """
    src = str(path)
    if not isinstance(data.get("axis"), list) and "axis" in data:
        raise ConfigError(f"{src}: 'axis' must be an array of tables ([[axis]])")
    try:
        doc = FleetFile.model_validate(data)
    except ValidationError as exc:
        errors = sorted(exc.errors(), key=lambda e: e.get("type") != "extra_forbidden")
        raise ConfigError(_format(src, errors[0], data)) from None
    if not doc.axis:
        raise ConfigError(f"{src}: no [[axis]] table: the fleet has no axes")
    base = path.parent
    seen: dict[str, int] = {}
    axes = []
    for k, a in enumerate(doc.axis):
        table = f"[[axis]] #{k + 1} (id {a.id!r})"
        if a.id in seen:
            raise ConfigError(f"{src}: table {table}, key 'id': duplicate of [[axis]] #{seen[a.id] + 1}")
        seen[a.id] = k
        spec = a.time or doc.fleet.time
        if spec is None:
            raise ConfigError(f"{src}: table {table}, key 'time': missing (and no [fleet] time default)")
        drive_path = (base / a.drive).resolve()
        if not drive_path.is_file():
            raise ConfigError(f"{src}: table {table}, key 'drive': no such drive configuration {drive_path}")
        try:
            drive = load_config(drive_path)
            drive.to_drivetrain_params()
            drive.require("backlash")
        except DrivelashError as exc:
            raise ConfigError(f"{src}: table {table}, key 'drive': {exc}") from None
        # after the drive: its [columns] set the kind, its gap the limit (F7)
        kind, thr, misfit = _axis_kind_and_threshold(a, drive)
        if misfit:
            raise ConfigError(f"{src}: table {table}: {misfit}")
        slip = _threshold_slip(a, drive, kind)
        if slip:
            raise ConfigError(f"{src}: table {table}, key 'threshold': {slip}")
        rate = None if doc.fleet.estimate_rate_hz == "full" else float(doc.fleet.estimate_rate_hz)
        axes.append(
            AxisSpec(
                name=a.id,
                drive_path=drive_path,
                drive=drive,
                drive_hash=config_hash(drive, doc.fleet.method, rate),
                recordings=str(base / a.recordings) if not Path(a.recordings).is_absolute() else a.recordings,
                threshold_rad=float(thr),
                transmission=a.transmission,
                time=spec,
                method=doc.fleet.method,
                horizon_days=doc.fleet.horizon_days,
                not_excited_alarm=doc.fleet.not_excited_alarm,
                estimate_rate_hz=rate,
                kind=kind,
            )
        )
    return Fleet(path=path, name=doc.fleet.name, db=doc.fleet.db, axes=tuple(axes))


def load_fleet(path: str | Path) -> Fleet:
    """Read, validate and resolve a ``fleet.toml`` (see the module docstring).

    Parameters
    ----------
    path : str or Path
        The inventory file; relative paths in it are relative to its directory.

    Returns
    -------
    Fleet
        The axes resolved: absolute paths, drive configurations loaded, thresholds in rad.

    Raises
    ------
    ConfigError
        Missing/unreadable file, TOML syntax, unknown/missing/invalid key, missing drive
        configuration — one line naming file, table and key.
    """
    p = Path(path)
    data = read_toml(p, "fleet")
    return parse_fleet(data, p.resolve())
