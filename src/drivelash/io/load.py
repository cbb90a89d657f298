"""``load_trace``: read a recording, map and convert its columns, validate it once.

Pipeline: :func:`~drivelash.io.formats.read_raw` → column mapping and unit
conversion (``[columns]`` of the configuration) → encoder wrap-around unwrapping
→ validation. Every problem is a :class:`~drivelash.errors.DataError` whose one
line names the file, the column and the first bad row (its line in a text file, else
``data row N (1-based)``: the reader's :class:`~drivelash.errors.DataRows`). Non-uniform sampling is
refused unless resampling is asked for explicitly.

Prismatic axes (a carriage on a ball screw, like EMPS): position columns given
in a length unit (m, mm, µm) make the trace *prismatic* — ``theta_m`` then
carries metres, ``omega_m`` m/s and ``torque_m`` newtons, and ``meta["axis"]``
is ``"prismatic"`` with ``meta["units"]`` stating the units actually carried.
The inverse dynamic model τ = M q̈ + F_v q̇ + F_c sign(q̇) + offset has the same
form on both kinds of axis, so identification and the observer need no
special case.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import NO_LINES, DataError, DataRows
from drivelash.io.config import UNIT_KIND, ColumnMap, DriveConfig, SamplingSection, is_prismatic
from drivelash.io.formats import WHOLE_READ_FACTOR, RawTable, read_raw
from drivelash.io.trace import UNITS as TRACE_UNITS
from drivelash.io.trace import Trace
from drivelash.units import LENGTH_TO_M

#: Signal columns that are checked for constant and saturated values.
SIGNAL_COLUMNS = ("theta_m", "omega_m", "theta_l", "omega_l", "torque_m")

#: Factor to SI per unit.
_TO_SI: dict[str, float] = {
    "s": 1.0,
    "ms": 1e-3,
    "us": 1e-6,
    "ns": 1e-9,
    "rad": 1.0,
    "deg": math.pi / 180.0,
    "rev": 2.0 * math.pi,
    "rad/s": 1.0,
    "deg/s": math.pi / 180.0,
    "rpm": 2.0 * math.pi / 60.0,
    "rev/s": 2.0 * math.pi,
    **LENGTH_TO_M,
    "in": 25.4e-3,
    "arcsec": math.pi / 648000.0,
    "mrad": 1e-3,
    "urad": 1e-6,
    "m/s": 1.0,
    "mm/s": 1e-3,
    "N·m": 1.0,
    "N*m": 1.0,
    "Nm": 1.0,
    "N": 1.0,
    "A": 1.0,
    "mA": 1e-3,
    "1": 1.0,
}

#: Which unit kinds a canonical column accepts.
_ACCEPTS: dict[str, tuple[str, ...]] = {
    "t": ("time",),
    "theta_m": ("angle", "length", "dimensionless"),
    "theta_l": ("angle", "length", "dimensionless"),
    "omega_m": ("angular_velocity", "velocity", "dimensionless"),
    "omega_l": ("angular_velocity", "velocity", "dimensionless"),
    "torque_m": ("torque", "force", "current", "voltage", "dimensionless"),
    # ISO 230-2 positioning tests (drivelash.iso230): positions and deviations of a
    # linear (length) or rotary (angle) axis; run number and approach direction
    "P_target": ("length", "angle"),
    "P_cmd": ("length", "angle"),
    "P_actual": ("length", "angle"),
    "P_axis": ("length", "angle"),
    "x_dev": ("length", "angle"),
    "run": ("dimensionless",),
    "direction": ("dimensionless",),
}

#: Relative tolerance for recognising a unit-factor mix-up (deg↔rad 57.3, rpm↔rad/s 9.55).
UNIT_FACTOR_TOLERANCE = 0.15

#: A velocity column whose least-squares ratio to d(position)/dt (on the samples with motion,
#: :func:`check_unit_ratio`) is below this — or negative and a known unit factor in magnitude
#: (−57.3, −1e-3, …) — counts against its position: refused (one of the two needs
#: ``scale = -1``). Correct recordings give ≈ +1 (tests/io, bench scenarios, EMPS, KUKA); a
#: sign-flipped velocity gives −1 (EMPS −1.00, bench-0B −0.98). Not 0: an unwrapped int16 counter
#: of a finer encoder gives −0.012 from its wrap jumps, which the seam check names (set wrap).
NEGATIVE_UNIT_RATIO = -0.5

#: A velocity whose integral ∫ω dt follows its position with a scale farther than this factor
#: from 1 either way (θ ≈ a + s·∫ω dt explaining at least :data:`VELOCITY_SCALE_MIN_R2` of θ's
#: variance; no known unit factor, which is refused first) is refused after the seam check:
#: the time axis (a sample rate stated 2× too high makes the velocity 0.5× the derivative) or
#: the velocity's scale (a gear ratio, rev vs rad) is wrong. Consistent recordings give
#: 1/s = 0.996 … 1.004 (bench-0A/0B/0C and paper-sim at 8 kHz and decimated to 250 Hz,
#: tester A's CNC exports at 250 Hz … 8 kHz, a coarse encoder on a still load); session 32,
#: M8 of session 30's tester A (docs/assumptions.md).
VELOCITY_SCALE_FACTOR = 1.5

#: Share of the position's variance the velocity's integral must explain before its scale is
#: judged (a drifting or noise-dominated integral is left alone).
VELOCITY_SCALE_MIN_R2 = 0.9

#: A torque/force column is "saturated" when at least this fraction of samples sits
#: exactly at its maximum or minimum while the axis moves, in runs of at least
#: SATURATION_MIN_RUN samples (a run held at standstill is a dwell: :data:`DWELL_SPEED`).
SATURATION_FRACTION = 0.02
#: A run of samples at a torque/force extreme is a *dwell*, not clipping, when every position
#: column that moves in the recording (:data:`DWELL_POSITIONS`) travels over the run at most this
#: fraction of the recording's mean speed (its range over the run ≤ DWELL_SPEED × run samples ×
#: its range over the recording / (samples − 1)): the axis stands still and the drive holds a
#: constant current (finding TH12: a stroke end held for 1.5 s at one quantised current value,
#: 9.1 % of a pass, was refused as "clipped recording?"). A run while the axis moves at the pass
#: speed gives ≥ 1 (the recording's mean speed counts its standstills too); a clip at the
#: reversal of an oscillation, where the speed passes zero, gives 0.39 ωτ for a run of τ (one
#: period recorded, more periods give more) — below 1 % only for runs shorter than 0.4 % of
#: the period, which stay under SATURATION_FRACTION. docs/assumptions.md, "Saturation".
DWELL_SPEED = 0.01
#: … or, when larger, this many of the position column's encoder counts (its smallest non-zero
#: step between consecutive samples over the recording, measured from the data): a position
#: controller holding a standstill dithers by a count or two, whatever the run's length (finding
#: J2: a 1 s hold toggling between two adjacent counts of a 2048-count encoder, 3.07 mrad, was
#: refused as "clipped recording?" under a speed limit of 2.2 mrad). 2 counts hold a ±1 count
#: dither; a position recorded finer than its motion (unquantised, resampled) has a tiny step and
#: keeps the speed rule. docs/assumptions.md, "Saturation".
DWELL_COUNTS = 2.0
#: Position columns whose standstill makes a run at a torque extreme a dwell (motor, load, linear
#: scale, set position); a recording without any of them moving has no dwell.
DWELL_POSITIONS = ("theta_m", "theta_l", "x_T", "x_d")
#: Columns that may be constant: a load that stays inside the deadzone (quantised encoder)
#: is a legitimate recording — the estimator's verdict says so, it is not a loading error.
MAY_STAND_STILL = ("theta_l", "omega_l")
SATURATION_MIN_RUN = 5


#: SI units of the columns of a prismatic (linear) axis (positions in m, forces in N).
PRISMATIC_UNITS: dict[str, str] = {
    "t": "s",
    "theta_m": "m",
    "omega_m": "m/s",
    "torque_m": "N",
    "theta_l": "m",
    "omega_l": "m/s",
}


def _one_rev(cm: ColumnMap) -> float | None:
    """One revolution in the column's file units (the default wrap modulus)."""
    return {"rad": 2 * math.pi, "deg": 360.0, "rev": 1.0, "counts": cm.counts_per_rev}.get(cm.unit)


def stated_unit(
    table: Any, source: str, unit: str, fix: Callable[[str], str], warnings: list[str] | None = None
) -> None:
    """A column whose unit the file states (a units row below the CSV header, an HDF5 dataset's
    or a Parquet field's ``unit`` attribute; kept in ``meta["column_units"]``) is refused when
    it would be read in another unit: one line naming the column, both units and ``fix(stated)``
    (where to declare the stated unit). A stated unit drivelash does not read (``kNm``) is an
    error where the column would be read as SI, and a warning (into ``warnings``) where the
    user's ``[columns]`` entry maps it: unit and scale are then the user's statement. A column
    of time stamps states ``s`` (read as seconds from the first: a ``ms`` in ``[columns]`` or
    ``[sampling] time_unit`` would scale the seconds again); what a units row writes above the
    stamps (``-``, ``hh:mm:ss``) is not checked."""
    from drivelash.io.formats import UNIT_ALIASES, unit_name

    if source in table.meta.get("timestamp_columns", ()):
        if unit != "s":
            raise DataError(
                "holds ISO 8601 time stamps (read as seconds from the first), so its unit is 's', "
                f"not {unit!r}",
                path=table.path,
                column=source,
            )
        return  # the stamps state their unit; a units-row cell above them ('-', 'hh:mm:ss') is a label
    stated = table.meta.get("column_units", {}).get(source)
    if stated is None:
        return
    where = table.meta.get("column_units_from", "units row")
    canon = unit_name(stated, number=True)
    mega = _mega(stated) if canon is None else None
    if mega is not None:  # 'MA' is no 'mA': the case of a prefix matters (finding J9)
        raise DataError(
            f"the file's {where} says {stated!r}: M is mega (10^6 {mega}; milli is a lower-case m, a"
            f" unit's case matters), but the column would be read in {unit!r}; drivelash reads no mega"
            f" unit — if the column is in {'m' + mega!r}, write that in the {where}",
            path=table.path,
            column=source,
        )
    if canon is None and warnings is not None:
        warnings.append(
            f"{table.path}, column {source!r}: the file's {where} names {stated!r}, which drivelash"
            f" cannot check; read as [columns.{source}] unit = {unit!r} with its scale"
        )
        return
    if canon is None:
        raise DataError(
            f"the file's {where} names {stated!r}, not a unit drivelash reads (known: "
            f"{', '.join(UNIT_KIND)}; also {', '.join(UNIT_ALIASES)}); map it in [columns.{source}]"
            " with the unit and scale to SI",
            path=table.path,
            column=source,
        )
    if UNIT_ALIASES.get(canon, canon) != UNIT_ALIASES.get(unit, unit):
        fix_it = fix(canon) + (" and its scale to SI" if canon == "1" else "")
        raise DataError(
            f"the file's {where} says {stated!r}, but the column would be read in {unit!r}; {fix_it}",
            path=table.path,
            column=source,
        )


def _mega(stated: str) -> str | None:
    """The unit ``stated`` names with the mega prefix ``M`` (``'MA'``: ``'A'``), else None — read
    case-insensitively it would be the milli unit (``'mA'``, 10^9 × apart)."""
    from drivelash.io.formats import unit_name

    u = stated.strip().strip('"').strip()
    if len(u) >= 2 and u[0] + u[-1] in ("[]", "()", "{}"):
        u = u[1:-1].strip()
    if len(u) < 2 or u[0] != "M":
        return None
    return unit_name(u[1:])


def unit_needs(unit: str) -> str:
    """What a column read in ``unit`` needs besides it, as `` and …`` to append to the advice to
    declare it: a current (A, mA) its torque_constant — in N·m/A (N/A for a force) even for a
    column in mA — a voltage its gain; else ``""`` (finding J9: "set unit = 'mA' in
    [columns.cur]" alone was then refused for the missing torque_constant)."""
    if UNIT_KIND.get(unit) == "current":
        return " and torque_constant (N·m/A, or N/A for a force; per ampere even for a column in mA)"
    if unit == "V":
        return " and gain (N·m/V or N/V)"
    return ""


def passthrough_unit(table: Any, name: str) -> None:
    """An unmapped column read under its Trace name is in SI (:data:`TRACE_UNITS`): refused when
    the file states another unit for it; one rule for the whole-file loader and the stream."""
    if name in TRACE_UNITS and name != "t":
        stated_unit(
            table,
            name,
            TRACE_UNITS[name],
            lambda u: f"map it in [columns.{name}] with unit = {u!r}{unit_needs(u)}",
        )


def time_factor(table: Any, name: str, sampling: SamplingSection) -> float:
    """SI factor of an unmapped time column in ``[sampling] time_unit`` (refused where the file
    states another unit, time stamps included: :func:`stated_unit`); one rule for the whole-file
    loader and the stream."""
    stated_unit(table, name, sampling.time_unit, lambda u: f"set [sampling] time_unit = {u!r}")
    return _TO_SI[sampling.time_unit]


def _factor(cm: ColumnMap, table: RawTable, source: str, warnings: list[str] | None = None) -> float:
    """Multiplicative factor from file units to SI for one mapped column."""
    path = table.path

    def fix(u: str) -> str:
        have = cm.torque_constant if UNIT_KIND.get(u) == "current" else cm.gain if u == "V" else None
        return f"set unit = {u!r}{unit_needs(u) if have is None else ''} in [columns.{source}]"

    stated_unit(table, source, cm.unit, fix, warnings)
    if cm.unit == "counts":
        if cm.counts_per_rev is None:
            raise DataError("unit 'counts' needs counts_per_rev in [columns]", path=path, column=source)
        return 2.0 * math.pi / cm.counts_per_rev
    if UNIT_KIND[cm.unit] == "current":  # A or mA: to amperes, times the torque constant [N·m/A]
        if cm.torque_constant is None:
            raise DataError(
                f"unit {cm.unit!r} needs torque_constant (N·m/A or N/A) in [columns]",
                path=path,
                column=source,
            )
        return _TO_SI[cm.unit] * cm.torque_constant
    if cm.unit == "V":
        g = cm.gain
        if g is None:
            raise DataError("unit 'V' needs gain (N·m/V or N/V) in [columns]", path=path, column=source)
        if isinstance(g, str):
            if g not in table.scalars:
                raise DataError(
                    f"gain refers to scalar '{g}', which the file does not contain"
                    f" (scalars: {', '.join(table.scalars) or 'none'})",
                    path=path,
                    column=source,
                )
            g = table.scalars[g]
        if not math.isfinite(g) or g == 0:
            raise DataError(f"gain must be finite and non-zero, got {g!r}", path=path, column=source)
        return float(g)
    return _TO_SI[cm.unit]


def unwrap_encoder(x: np.ndarray, modulus: float) -> tuple[np.ndarray, int, int | None]:
    """Undo wrap-around of a position counter.

    Parameters
    ----------
    x : numpy.ndarray
        Position in file units.
    modulus : float
        Counter range (one revolution or the counter size) in the same units.

    Returns
    -------
    unwrapped : numpy.ndarray
    n_wraps : int
        Number of wrap events found (jumps larger than half the modulus).
    first_row : int or None
        Row of the first sample after the first wrap.
    """
    if x.size < 2 or modulus <= 0:
        return x, 0, None
    from drivelash.io._unitcheck import wrap_scan

    # one compiled pass decides the common case (finite, no step beyond half the modulus)
    finite, jump = wrap_scan(np.ascontiguousarray(x, dtype=np.float64), 0.5 * modulus)
    if not (finite and jump):
        return x, 0, None
    d = np.diff(x)
    jumps = np.abs(d) > 0.5 * modulus
    # A wrapping signal stays within one modulus; a genuinely fast multi-turn signal does not.
    if not jumps.any() or np.ptp(x) > modulus * (1 + 1e-9):
        return x, 0, None
    return np.unwrap(x, period=modulus), int(jumps.sum()), int(np.flatnonzero(jumps)[0] + 1)


def _refuse_counter_wrap(raw: np.ndarray, modulus: float, table: RawTable, source: str, unit: str) -> None:
    """Refuse a position counter that wraps at a power of two other than one revolution, naming
    the ``wrap`` to declare (a multi-turn counter of fixed width, e.g. 22 bit = 4 revolutions of
    a 2^20 encoder: its jumps stay in the data and spoil every later check with a wrong cause).

    Only when unambiguous: every step beyond half a revolution has the size of one power of two
    W ≥ one revolution (to within twice the largest other step), and the other steps are
    below W/100.
    """
    if raw.size < 3 or not np.all(np.isfinite(raw)):
        return
    d = np.diff(raw)
    big = np.abs(d) > 0.5 * modulus
    if not big.any() or big.all():
        return
    small = np.abs(d[~big])
    step = float(small.max())
    w = 2.0 ** np.round(np.log2(np.abs(d[big])))
    if not (np.all(w == w[0]) and w[0] >= modulus * (1 - 1e-9) and w[0] > 100 * step):
        return
    if not np.all(np.abs(np.abs(d[big]) - w[0]) <= 2 * step + 1e-9 * w[0]):
        return
    first = int(np.flatnonzero(big)[0])
    raise DataError(
        f"the counter jumps by {d[first]:+.10g} {unit} ({int(big.sum())} time(s); other steps at most"
        f" {step:.4g}): a counter that wraps at {w[0]:.10g} {unit} ({w[0] / modulus:g} revolutions);"
        f" declare wrap = {w[0]:.10g} in its [columns] mapping",
        path=table.path,
        column=source,
        row=first + 1,
        rows=table.rows,
    )


def wrap_note(path: str, column: str, n_wraps: int, jump: str, row: int, rows: DataRows) -> str:
    """The warning for an unwrapped encoder column (the first jump lands on data row ``row``,
    named as ``rows`` does); the file loader's and the stream's text."""
    return (
        f"{path}, column '{column}', {rows.where(row)}: encoder wrap-around ({n_wraps} jump(s) of"
        f" {jump}) unwrapped"
    )


def _unwrapped(
    raw: np.ndarray, modulus: float, table: RawTable, source: str, jump: str, warnings: list[str]
) -> np.ndarray:
    """``raw`` with encoder wrap-arounds of ``modulus`` removed; each unwrapping is reported."""
    x, n_wraps, row = unwrap_encoder(raw, modulus)
    if not n_wraps or row is None:
        return raw
    warnings.append(wrap_note(table.path, source, n_wraps, jump, row, table.rows))
    return x


def _mapping_from(mapping: Any) -> tuple[dict[str, ColumnMap] | None, SamplingSection]:
    """The column mapping and ``[sampling]`` of ``mapping`` (see :func:`load_trace`).

    ``mapping``: None, a DriveConfig, the path of a configuration file, or a dict
    *source column → Trace column*: each value a Trace column name (``{"pos_load": "theta_l"}``:
    the source column ``pos_load`` becomes ``theta_l``, in that column's SI unit), a ``[columns]``-style
    table (``{"column": "theta_l", "unit": "deg"}``) or a :class:`ColumnMap`. A dict carries no
    ``[sampling]`` (the defaults). Anything else, or an invalid entry, is a one-line
    :class:`~drivelash.errors.ParameterError` naming the key.
    """
    from drivelash.errors import ParameterError

    if mapping is None:
        return None, SamplingSection()
    if isinstance(mapping, (str, Path)):
        from drivelash.io.config import load_config

        mapping = load_config(mapping)
    if isinstance(mapping, DriveConfig):
        return mapping.columns, mapping.sampling_or_default()
    if isinstance(mapping, Mapping):
        return column_maps(mapping), SamplingSection()
    raise ParameterError(
        "mapping",
        type(mapping).__name__,
        "must be a DriveConfig, a configuration path, a dict source column → Trace column (name or "
        "[columns]-style table) or None",
    )


def column_maps(mapping: Mapping[Any, Any], what: str = "columns") -> dict[str, ColumnMap]:
    """``{source: ColumnMap}`` from a dict *source column → Trace column name or table*.

    A string value is the Trace column, its values in that column's SI unit
    (:data:`drivelash.io.trace.UNITS`: ``t`` in s, ``theta_m`` in rad, …; ``"1"`` for another
    name); a dict is a ``[columns.<source>]`` table. An invalid entry raises a one-line
    :class:`~drivelash.errors.ParameterError` naming ``<what>.<source>[.<key>]``.
    """
    import pydantic

    from drivelash.errors import ParameterError

    out: dict[str, ColumnMap] = {}
    for k, v in mapping.items():
        if isinstance(v, ColumnMap):
            out[str(k)] = v
            continue
        if isinstance(v, str):  # the Trace column, in its SI unit (the unit of an unmapped column)
            v = {"column": v, "unit": TRACE_UNITS.get(v, "1")}
        if not isinstance(v, Mapping):
            raise ParameterError(
                what,
                str(k),
                f"must be a Trace column name or a table like {{'column': 'theta_l', 'unit': 'deg'}}, "
                f"got {type(v).__name__}",
            )
        try:
            out[str(k)] = ColumnMap.model_validate(dict(v))
        except pydantic.ValidationError as exc:
            e = exc.errors()[0]
            loc = ".".join(str(x) for x in e.get("loc", ()))
            msg = str(e.get("msg", "invalid")).removeprefix("Value error, ")
            raise ParameterError(what, f"{k}.{loc}" if loc else str(k), msg) from None
    return out


def _sample_down(cols: dict[str, np.ndarray], max_rate_hz: float) -> dict[str, Any] | None:
    """``{"k", "T_s", "samples"}`` of the file when keeping every k-th sample (k > 1) meets
    ``max_rate_hz`` [Hz], else None (too few samples, no usable interval, or already slow)."""
    t = cols.get("t")
    if t is None or t.size < 3 or not max_rate_hz > 0:
        return None
    d = np.diff(t[:4097])
    T_s = float(np.median(d))
    if not (math.isfinite(T_s) and T_s > 0):
        return None  # the time checks report it
    k = int(math.floor(1.0 / (T_s * max_rate_hz) * (1 + 1e-9)))
    return {"k": k, "T_s": T_s, "samples": int(t.size)} if k > 1 else None


def _apply_mapping(
    table: RawTable, cmap: dict[str, ColumnMap] | None, sampling: SamplingSection, warnings: list[str]
) -> tuple[dict[str, np.ndarray], dict[str, str], dict[str, str]]:
    """Columns in SI, their unit kinds and the source name of each Trace column."""
    path = table.path
    kinds: dict[str, str] = {}
    origin: dict[str, str] = {}
    cols: dict[str, np.ndarray] = {}
    used = _used_text_column(table, cmap)
    if used is not None:  # a text column the mapping uses: its first bad cell (A16)
        raise table.unread[used]
    if cmap is None:
        cols = dict(table.columns)
        origin = {k: k for k in cols}
        if "t" in cols and (f := time_factor(table, "t", sampling)) != 1.0:
            cols["t"] = cols["t"] * f
        for k in cols:
            passthrough_unit(table, k)
            if k.startswith("theta"):
                cols[k] = _unwrapped(cols[k], 2 * math.pi, table, k, "one revolution", warnings)
        return cols, kinds, origin
    for source, cm in cmap.items():
        kind = check_mapped_column(source, cm, list(table.columns), cols, path)
        raw = table.columns[source]
        modulus = cm.wrap if cm.wrap is not None else (_one_rev(cm) if kind == "angle" else None)
        if modulus is not None and cm.column.startswith("theta"):
            raw = _unwrapped(raw, modulus, table, source, f"{modulus:g} {cm.unit}", warnings)
            if cm.wrap is None:
                _refuse_counter_wrap(raw, modulus, table, source, cm.unit)
        cols[cm.column] = raw * _factor(cm, table, source, warnings) * cm.scale + cm.offset
        kinds[cm.column] = kind
        origin[cm.column] = source
    # Unmapped source columns that already carry a Trace name pass through as SI, so a
    # [columns] table need only name what must be renamed or converted.
    for name, raw in table.columns.items():
        if name in TRACE_UNITS and name != "t" and name not in cols and name not in cmap:
            passthrough_unit(table, name)
            if name.startswith("theta"):
                raw = _unwrapped(raw, 2 * math.pi, table, name, "one revolution", warnings)
            cols[name] = raw
            origin[name] = name
    return cols, kinds, origin


def _used_text_column(table: RawTable, cmap: dict[str, ColumnMap] | None) -> str | None:
    """The first column the mapping uses that the reader left unread as text, else None.

    Used: a mapped source, or (unmapped) a column carrying a Trace name that is not mapped
    from another source; ``t`` too without a mapping. Other text columns (a CNC's status or
    comment column) are dropped as a Parquet file's string columns are.
    """
    for name in table.unread:
        if cmap is not None and name in cmap:
            return name
        if name in TRACE_UNITS and (cmap is None or name != "t"):
            if cmap is None or all(cm.column != name for cm in cmap.values()):
                return name
    return None


def check_mapped_column(source: str, cm: ColumnMap, available: list[str], taken: Any, path: str) -> str:
    """Check one ``[columns]`` entry against the file's columns; return its unit kind.

    One rule for the whole-file loader and the chunked stream: the source column exists, no two
    sources map to the same Trace column (``taken`` holds those already mapped), and the unit's
    kind fits the Trace column. Raises :class:`DataError` naming the file and column.
    """
    if source not in available:
        avail = ", ".join(available[:20])
        raise DataError(f"missing required column (available: {avail})", path=path, column=source)
    if cm.column in taken:
        raise DataError(f"two source columns map to Trace column '{cm.column}'", path=path, column=source)
    kind = UNIT_KIND[cm.unit]
    acc = _ACCEPTS.get(cm.column)
    if acc is not None and kind not in acc:
        raise DataError(
            f"unit '{cm.unit}' ({kind}) does not fit Trace column '{cm.column}' (needs {' or '.join(acc)})",
            path=path,
            column=source,
        )
    return kind


def unread_column(name: str, cmap: Mapping[str, ColumnMap] | None, required: Iterable[str]) -> bool:
    """True for a source column that no drivelash computation reads: without a mapping, a
    column that carries no Trace name (:data:`drivelash.io.trace.UNITS`), is not required and is
    not the time (``t``/``time``) — e.g. a logger's status flag. With a mapping only mapped and
    Trace-named columns are taken, so none is unread. One rule for the file loader and the stream."""
    if cmap is not None or name in TRACE_UNITS or name in ("t", "time"):
        return False
    return name not in set(required)


def unread_note(path: str, column: str, what: str, row: int, bad: int, rows: DataRows) -> str:
    """The warning for an unread column (:func:`unread_column`) with ``bad`` NaN/inf values
    (``what``: ``"NaN"`` or ``"infinite value"``, the first in data row ``row``, named as
    ``rows`` does): such a column is left out of the trace instead of refusing the recording
    (the file loader's and the stream's text)."""
    return (
        f"{path}, column '{column}', {rows.where(row)}: {what} ({bad} bad sample(s)) in a column"
        " drivelash does not read; left out of the trace"
    )


def _check_finite(
    cols: Mapping[str, np.ndarray], origin: Mapping[str, str], path: str, rows: DataRows
) -> None:
    for name, a in cols.items():
        bad = ~np.isfinite(a)
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            what = "NaN" if np.isnan(a[row]) else "infinite value"
            raise DataError(
                f"{what} ({int(bad.sum())} bad sample(s))",
                path=path,
                column=origin.get(name, name),
                row=row,
                rows=rows,
            )


#: What to do about non-uniform sampling, on the command line …
RESAMPLE_HINT = "resample explicitly with --resample or [sampling] resample = true"
#: … and in Python (the notebook API has no --resample option).
RESAMPLE_HINT_API = (
    "resample explicitly: [sampling] resample = true in the configuration, or read it with "
    "drivelash.load_trace(path, cfg, resample=True) / drivelash.Trace.from_frame(df, cfg, resample=True) "
    "and pass that Trace"
)


def with_resample_hint(exc: DataError, hint: str = RESAMPLE_HINT_API) -> DataError:
    """``exc`` with the command-line hint (``--resample``) replaced by ``hint``: what to do where
    there is no ``--resample`` option — in Python (:data:`RESAMPLE_HINT_API`, the default), in an
    iso230 configuration or in a TE axis file."""
    text = str(exc)
    if RESAMPLE_HINT in text:
        exc.args = (text.replace(RESAMPLE_HINT, hint),)
    return exc


#: Sample period [s] from which a recording is refused as implausible, its time unit declared
#: or not (docs/assumptions.md): the slowest series the project reads are ISO 230-2 time series
#: at 10 Hz (0.1 s); drive recordings run at 100 Hz–10 kHz. Time stamps in ms read as seconds
#: at ≤ 2 kHz (EMPS 1 kHz, KUKA 250 Hz) give 0.5–4 s — EMPS's ms stamps as a decimal CSV have
#: a median step of 0.999984 "s" (B4), which the former limit of 1.0 s let through.
MAX_PLAUSIBLE_T_S = 0.5


def _check_plausible_period(
    med: float,
    path: str,
    column: str,
    sampling: SamplingSection,
    declared: str | None = None,
) -> None:
    """Refuse a sample period that betrays time stamps in ns/µs/ms read as seconds.

    Rule: a median period of at least :data:`MAX_PLAUSIBLE_T_S` — also when the time
    column's unit is declared in ``[columns]`` (``declared``): a declared unit is checked
    against the data like an assumed one. (This replaces the former rules — above 10 s, or a
    whole number of seconds in an integer column — which both pass 4 s of KUKA's ms stamps.)
    The message names the unit that gives a period closest to 1 ms.
    """
    if not med >= MAX_PLAUSIBLE_T_S:
        return
    unit = declared or sampling.time_unit
    period = med / _TO_SI[unit]  # in the file's unit
    cands = [
        (u, period * f) for u, f in (("ns", 1e-9), ("us", 1e-6), ("ms", 1e-3)) if 1e-7 <= period * f <= 1.0
    ]
    if cands:
        u, v = min(cands, key=lambda c: abs(math.log10(c[1]) + 3.0))
        if declared:
            hint = (
                f"the [columns] entry of '{column}' declares unit = \"{declared}\"; time stamps in {u}?"
                f' that gives {v:.6g} s; set unit = "{u}" there'
            )
        else:
            hint = (
                f'time stamps in {u}? that gives {v:.6g} s; set [sampling] time_unit = "{u}"'
                f" or unit = \"{u}\" in the [columns] entry of '{column}'"
            )
    else:
        hint = "check the time column and its unit ([sampling] time_unit or [columns] unit)"
    raise DataError(
        f"implausible sample period {med:.6g} s (recordings are sampled at ≥ 10 Hz): {hint}",
        path=path,
        column=column,
    )


def _check_time(
    t: np.ndarray,
    path: str,
    column: str,
    sampling: SamplingSection,
    warnings: list[str],
    declared: str | None = None,
    rows: DataRows | None = None,
) -> np.ndarray | None:
    """Validate the time column; return a uniform grid to resample onto, or None.

    ``declared``: the time column's unit as declared in ``[columns]`` (for the message of the
    plausibility rule, :func:`_check_plausible_period`); ``rows``: where the samples' rows are
    in the file (for the messages; default: ``data row N (1-based)``).
    """
    rows = rows or NO_LINES
    if t.size < 3:
        raise DataError(f"only {t.size} sample(s); need at least 3", path=path, column=column)
    from drivelash.io._unitcheck import step_scan

    first_bad, lo, hi = step_scan(np.ascontiguousarray(t, dtype=np.float64))
    if first_bad < 0 and hi < MAX_PLAUSIBLE_T_S and (hi - lo) / lo <= sampling.tolerance:
        # every step lies in [lo, hi] and so does the median: no step deviates from it by more
        # than (hi − lo)/lo (rounding is monotone), and no median reaches MAX_PLAUSIBLE_T_S —
        # the rules below would pass, exactly
        return None
    steps = np.diff(t)
    if np.any(steps <= 0):
        i = int(np.flatnonzero(steps <= 0)[0])
        what = "duplicated time stamp" if steps[i] == 0 else "time goes backwards (non-increasing)"
        raise DataError(
            f"{what}: t={float(t[i + 1])!r} after t={float(t[i])!r}"
            + float32_time_hint(float(t[i]), float(t[i + 1])),
            path=path,
            column=column,
            row=i + 1,
            rows=rows,
        )
    med = float(np.median(steps))
    _check_plausible_period(med, path, column, sampling, declared)
    dev = np.abs(steps - med) / med
    if np.any(dev > sampling.tolerance):
        i = int(np.flatnonzero(dev > sampling.tolerance)[0])
        if not sampling.resample:
            raise DataError(
                f"non-uniform sampling: interval {steps[i]:.6g} s vs median {med:.6g} s"
                f" (deviation {dev[i]:.1%} > tolerance {sampling.tolerance:.1%});"
                f" {RESAMPLE_HINT}",
                path=path,
                column=column,
                row=i + 1,
                rows=rows,
            )
        n = int(math.floor((t[-1] - t[0]) / med + 1e-9)) + 1
        from drivelash.io.budget import check_budget

        check_budget(
            n * 8.0 * WHOLE_READ_FACTOR,
            what=f"{path}: resampling onto {n} samples of {med:.6g} s",
            option="cut the recording at its gaps",
        )
        warnings.append(
            f"{path}, column '{column}', {rows.where(i + 1)}: non-uniform sampling;"
            f" resampled linearly onto a {med:.6g} s grid ({n} samples)"
        )
        return t[0] + med * np.arange(n)
    return None


def _check_signals(
    cols: Mapping[str, np.ndarray], origin: Mapping[str, str], path: str, names: Iterable[str], rows: DataRows
) -> None:
    for name in names:
        if name not in cols or name == "t":
            continue
        a = cols[name]
        src = origin.get(name, name)
        if np.ptp(a) == 0 and name not in MAY_STAND_STILL:
            raise DataError(
                f"constant signal (every sample is {a[0]:.6g})", path=path, column=src, row=0, rows=rows
            )
        if name.startswith("torque") or name.startswith("F_"):
            positions = {p: cols[p] for p in DWELL_POSITIONS if p in cols}
            for ext, label in ((a.max(), "maximum"), (a.min(), "minimum")):
                at = a == ext
                if at.mean() < SATURATION_FRACTION:
                    continue  # fewer at the extreme than the rule needs, dwells or not
                runs = ExtremeRuns(positions)
                runs.feed(at, positions, 0)
                raise_saturated(runs, a.size, label, float(ext), path, src, rows)


class ExtremeRuns:
    """Runs of samples at one extreme of a torque/force column, fed in chunks (the loader feeds
    the whole column once, :class:`~drivelash.io.stream.TraceStream` chunk by chunk: one rule).

    Each run keeps its length, its first row and the range each position column (``names``, of
    :data:`DWELL_POSITIONS`) covers over it; :meth:`clipped` classifies the runs once the whole
    recording was fed: a run over which no moving position travels faster than
    :data:`DWELL_SPEED` × the recording's mean speed — or, when more, than :data:`DWELL_COUNTS`
    of its encoder counts over the whole run (the smallest non-zero step between consecutive
    samples, over every chunk and across their boundaries) — is a dwell (the axis stands still
    holding a current), every other run counts as clipping.

    Parameters
    ----------
    names : iterable of str
        The position columns fed with every chunk.
    """

    def __init__(self, names: Iterable[str]) -> None:
        self.names = list(names)
        self.n = 0
        self.lengths: list[np.ndarray] = []
        self.starts: list[np.ndarray] = []
        self.spans: dict[str, list[np.ndarray]] = {p: [] for p in self.names}
        self.lo = dict.fromkeys(self.names, math.inf)
        self.hi = dict.fromkeys(self.names, -math.inf)
        # smallest non-zero |step| between consecutive samples (the encoder count) and the last
        # sample fed, so that a step across a chunk boundary counts as in the whole column
        self.step = dict.fromkeys(self.names, math.inf)
        self.last: dict[str, float] = {}
        # the run still open at the end of the last chunk: [length, start, {name: (lo, hi)}]
        self.open: tuple[int, int, dict[str, tuple[float, float]]] | None = None

    def feed(self, hit: np.ndarray, positions: Mapping[str, np.ndarray], row0: int) -> None:
        """One chunk: ``hit`` marks the samples at the extreme, ``positions`` the position columns
        (SI, unwrapped) of the same rows, ``row0`` the row of its first sample."""
        m = hit.size
        self.n += m
        for p in self.names:
            x = positions[p]
            if m:
                self.lo[p], self.hi[p] = min(self.lo[p], float(x.min())), max(self.hi[p], float(x.max()))
                d = np.abs(np.diff(x, prepend=self.last[p]) if p in self.last else np.diff(x))
                d = d[d > 0]
                if d.size:
                    self.step[p] = min(self.step[p], float(d.min()))
                self.last[p] = float(x[-1])
        if not hit.any():
            self._close()
            return
        edges = np.diff(np.concatenate(([0], hit.view(np.int8), [0])))
        starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        lengths = stops - starts
        # the range of each position over each run: reduceat over [start, stop) pairs
        idx = np.column_stack((starts, stops)).ravel()
        rng: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        # a run that ends where the chunk ends has stop == m: one sentinel sample makes it an index
        for p in self.names:
            x = np.append(positions[p], 0.0)
            rng[p] = (np.minimum.reduceat(x, idx)[::2], np.maximum.reduceat(x, idx)[::2])
        seg = {p: (lo, hi) for p, (lo, hi) in rng.items()}
        first = 0
        if self.open is not None:
            if starts[0] == 0:  # the open run goes on into this chunk
                k, s0, r = self.open
                r = {p: (min(r[p][0], float(seg[p][0][0])), max(r[p][1], float(seg[p][1][0]))) for p in r}
                self.open = (k + int(lengths[0]), s0, r)
                if stops[0] == m:  # and on past it
                    return
                first = 1
            self._close()
        last = len(starts) - 1 if stops[-1] == m else len(starts)  # a run reaching the end stays open
        if first < last:
            self._keep(
                lengths[first:last],
                row0 + starts[first:last],
                {p: (lo[first:last], hi[first:last]) for p, (lo, hi) in seg.items()},
            )
        if last < len(starts):
            self.open = (
                int(lengths[last]),
                row0 + int(starts[last]),
                {p: (float(lo[last]), float(hi[last])) for p, (lo, hi) in seg.items()},
            )

    def _keep(
        self, lengths: np.ndarray, starts: np.ndarray, rng: Mapping[str, tuple[np.ndarray, np.ndarray]]
    ) -> None:
        self.lengths.append(np.asarray(lengths, dtype=np.int64))
        self.starts.append(np.asarray(starts, dtype=np.int64))
        for p in self.names:
            self.spans[p].append(np.asarray(rng[p][1] - rng[p][0], dtype=np.float64))

    def _close(self) -> None:
        if self.open is not None:
            k, s0, r = self.open
            self._keep(
                np.array([k]), np.array([s0]), {p: (np.array([r[p][0]]), np.array([r[p][1]])) for p in r}
            )
            self.open = None

    def clipped(self) -> tuple[int, int, int | None]:
        """``(samples, longest run, first row)`` of the runs that are not dwells (after the last
        chunk); ``first row`` None when there is none."""
        self._close()
        if not self.lengths:
            return 0, 0, None
        lengths, starts = np.concatenate(self.lengths), np.concatenate(self.starts)
        moving = [p for p in self.names if self.hi[p] - self.lo[p] > 0]
        dwell = np.ones(lengths.size, dtype=bool) if moving else np.zeros(lengths.size, dtype=bool)
        for p in moving:
            per_sample = DWELL_SPEED * (self.hi[p] - self.lo[p]) / max(self.n - 1, 1)
            limit = np.maximum(per_sample * lengths, DWELL_COUNTS * self.step[p])
            dwell &= np.concatenate(self.spans[p]) <= limit
        keep = ~dwell
        if not keep.any():
            return 0, 0, None
        return int(lengths[keep].sum()), int(lengths[keep].max()), int(starts[keep][0])


def raise_saturated(
    runs: ExtremeRuns, n: int, label: str, ext: float, path: str, column: str, rows: DataRows
) -> None:
    """Refuse a torque/force column clipped at ``ext`` (its ``label``: ``"maximum"`` or
    ``"minimum"``): at least :data:`SATURATION_FRACTION` of the ``n`` samples sit there outside
    dwells, in a run of at least :data:`SATURATION_MIN_RUN` (the loader's and the stream's text)."""
    count, best, start = runs.clipped()
    frac = count / n if n else 0.0
    if start is None or frac < SATURATION_FRACTION or best < SATURATION_MIN_RUN:
        return
    raise DataError(
        f"saturated signal: {frac:.1%} of samples sit at the {label} {ext:.6g} (clipped recording?)",
        path=path,
        column=column,
        row=start,
        rows=rows,
    )


def _check_units(
    cols: Mapping[str, np.ndarray], origin: Mapping[str, str], path: str, rows: DataRows
) -> None:
    """Velocity against the derivative of position: factor ≈ 57.3 / 9.55 means deg or rpm.

    Robust scale ratio Σ ω̄·d̄ / Σ d̄² on the samples with motion (|d̄| > 0.1 max |d̄|), d = dθ/dt
    (``np.gradient``), both lightly smoothed (moving mean over k = clip(n/50, 1, 25) samples);
    one compiled pass (:func:`drivelash.io._unitcheck.unit_ratio_sums`).
    """
    from drivelash.io._unitcheck import unit_ratio_sums

    t = np.ascontiguousarray(cols["t"], dtype=np.float64)
    for side in ("m", "l"):
        th, om = cols.get(f"theta_{side}"), cols.get(f"omega_{side}")
        if th is None or om is None or t.size < 2:
            continue
        k = max(1, min(25, t.size // 50))
        s_od, s_dd, count, row = unit_ratio_sums(
            t, np.ascontiguousarray(th, dtype=np.float64), np.ascontiguousarray(om, dtype=np.float64), k
        )
        if count < 10:
            continue
        column = origin.get(f"omega_{side}", f"omega_{side}")
        check_unit_ratio(float(s_od / s_dd), side, path, column, int(row), rows)


def _check_velocity_scales(cols: Mapping[str, np.ndarray], origin: Mapping[str, str], path: str) -> None:
    """Each position with its velocity through :class:`~drivelash.io._velscale.VelocityScaleFit`
    and :func:`check_velocity_scale` (after the unit and seam checks)."""
    from drivelash.io._velscale import VelocityScaleFit

    for side in ("m", "l"):
        th, om = cols.get(f"theta_{side}"), cols.get(f"omega_{side}")
        if th is None or om is None or th.size < 3:
            continue
        fit = VelocityScaleFit()
        fit.feed(cols["t"], th, om)
        check_velocity_scale(fit, side, path, origin.get(f"omega_{side}", f"omega_{side}"))


#: The traces :func:`trace_from_table` returned, by identity and held weakly: their velocities were
#: checked there. Any other Trace — also a loaded one changed with ``with_columns``, whose copied
#: ``meta["format"]`` said nothing about its new columns (session 33) — is checked again.
_CHECKED: weakref.WeakValueDictionary[int, Trace] = weakref.WeakValueDictionary()


def velocities_checked(trace: Any) -> bool:
    """True for the very Trace object the loader returned (its velocity checks ran there)."""
    return _CHECKED.get(id(trace)) is trace


def check_trace_velocities(trace: Any, caller: str) -> None:
    """The loader's velocity checks on a :class:`~drivelash.io.trace.Trace` built in Python
    (the API's ``data=Trace``): each velocity against its position — sign, a unit factor
    (:func:`check_unit_ratio`) and its scale (:func:`check_velocity_scale`). The file and
    DataFrame paths run them in the loader; a Trace went unchecked until session 32 (a velocity
    counting against its position reached the estimator from Python, not from a file)."""
    cols = {n: np.asarray(trace[n], dtype=np.float64) for n in ("t", *_VELOCITY_PAIRS) if n in trace.names}
    if "t" not in cols:
        return
    where = f"{caller}(data=Trace)"
    _check_units(cols, {}, where, NO_LINES)
    _check_velocity_scales(cols, {}, where)


#: The position/velocity columns the velocity checks pair (motor and load side).
_VELOCITY_PAIRS = ("theta_m", "omega_m", "theta_l", "omega_l")


def check_velocity_scale(fit: Any, side: str, path: str, column: str) -> None:
    """Refuse a velocity whose integral follows its position with a scale off 1 by more than
    :data:`VELOCITY_SCALE_FACTOR` either way (the fit explaining at least
    :data:`VELOCITY_SCALE_MIN_R2`): the sample rate or the velocity's scale is wrong — a rate
    stated 2× too high makes the velocity 0.5× the derivative (session 30, M8: the estimator
    then said "not converged" with no reason and ``identify`` called the shaft rigid)."""
    s, r2 = fit.result()
    if not (math.isfinite(s) and s > 0 and r2 >= VELOCITY_SCALE_MIN_R2):
        return
    if 1 / VELOCITY_SCALE_FACTOR <= s <= VELOCITY_SCALE_FACTOR:
        return
    raise DataError(
        f"velocity is {1 / s:.3g}× the derivative of theta_{side} (its integral follows the"
        " position at that scale): the time axis ([sampling] sample_rate, or the time column's"
        " unit) or the velocity's scale/unit in [columns] is wrong; a correct recording gives 1",
        path=path,
        column=column,
    )


def _check_seams(
    cols: Mapping[str, np.ndarray],
    kinds: Mapping[str, str],
    origin: Mapping[str, str],
    path: str,
    rows: DataRows,
) -> None:
    """Refuse a position step that no recorded velocity allows (joined recordings; B5).

    Each position with its velocity column (θ_m/ω_m, θ_l/ω_l) through
    :class:`drivelash.io._seam.SeamScan`; the rule and its thresholds are in that module and in
    docs/assumptions.md. Without a velocity column nothing is checked.
    """
    from drivelash.io._seam import SeamScan

    for side in ("m", "l"):
        th, om = cols.get(f"theta_{side}"), cols.get(f"omega_{side}")
        if th is None or om is None or th.size < 3:
            continue
        scan = SeamScan(origin.get(f"theta_{side}", f"theta_{side}"))
        scan.feed(cols["t"], th, om, 0, final=True)
        raise_seam(scan, kinds.get(f"theta_{side}") == "length", path, rows)


def raise_seam(scan: Any, linear: bool, path: str, rows: DataRows) -> None:
    """Raise the loader's one-line :class:`DataError` for the first seam ``scan`` found, if any."""
    from drivelash.io._seam import seam_message

    seam = scan.first_seam()
    if seam is None:
        return
    i, size, allowed, t_i = seam
    raise DataError(
        seam_message(size, allowed, t_i, linear), path=path, column=scan.column, row=i + 1, rows=rows
    )


#: Float32 resolution of a time stamp [s] from which two equal or reversed float32-exact stamps
#: are put down to the float32 type rather than to the logger (a collision needs a resolution of
#: about the sample period; 1 µs = a 1 MHz rate).
FLOAT32_TIME_RESOLUTION = 1e-6


def float32_time_hint(a: float, b: float) -> str:
    """``"; …"`` when two successive stamps ``a``, ``b`` [s] that do not increase are both exact
    float32 values whose float32 resolution at ``b`` is at least
    :data:`FLOAT32_TIME_RESOLUTION`: the stamps were (most likely) stored as float32, which at
    3000 s resolves 0.24 ms — coarser than a 0.125 ms period (session 31 tester C, C14 b: the
    message named the duplicate but not the cause)."""
    exact = all(math.isfinite(v) and float(np.float32(v)) == v for v in (a, b))
    ulp = float(np.spacing(np.float32(abs(b)))) if exact else 0.0
    if not exact or ulp < FLOAT32_TIME_RESOLUTION:
        return ""
    return (
        f"; the stamps look like float32, which resolves only {ulp:.2g} s at t = {b:.6g} s:"
        " store the time as float64 (e.g. astype('float64') before adding an offset)"
    )


def time_hint(names: list[str], meta: dict[str, Any] | None = None) -> str:
    """``"; …"`` naming what looks like the time in a table without a ``t`` column: a column
    whose name differs from ``t``/``time`` only in case or by a suffix (``Time``, ``time_s``), or
    a DataFrame's unnamed increasing float, time-stamp or duration index
    (``meta["unnamed_time_index"]``: what it holds); ``""`` when there is none (session 31
    tester C, C14: "missing required column 't'" left the cause out; session 34 tester G, G14:
    an unnamed DatetimeIndex got no hint).
    """
    near = [n for n in names if n.lower() in ("t", "time") or n.lower().startswith(("time", "t_", "t ["))]
    if near:
        return (
            f'; a column {near[0]!r} is there: map it ([columns."{near[0]}"] column = "t", unit = "s"; '
            f"or columns={{{near[0]!r}: 't'}} in Python) or rename it 't'"
        )
    held = (meta or {}).get("unnamed_time_index")
    if held:
        what = "" if held == "numbers" else f" ({held})"
        return f"; the DataFrame's unnamed index looks like time{what}: df.rename_axis('t').reset_index()"
    return ""


def check_unit_ratio(ratio: float, side: str, path: str, column: str, row: int, rows: DataRows) -> None:
    """Refuse a velocity/derivative-of-position ratio that is a known unit mix-up factor: an
    angle or speed unit (57.3, 9.55) or a factor 1000 / 10⁶ (time in ms or µs read as s, or
    mm against m on a linear axis), and a negative ratio below :data:`NEGATIVE_UNIT_RATIO`
    or a negative known factor (the velocity counts against its position, a sign-convention
    slip); the message names data row
    ``row`` (the first with motion) as ``rows`` does."""
    if ratio < NEGATIVE_UNIT_RATIO or (ratio < 0 and _factor_hint(-ratio)):
        raise DataError(
            f"velocity counts against the derivative of theta_{side} (ratio {ratio:.4g}): set"
            f" scale = -1 on one of them in [columns]{_factor_hint(-ratio)}",
            path=path,
            column=column,
            row=row,
            rows=rows,
        )
    hint = _factor_hint(ratio)
    if hint:
        raise DataError(
            f"implausible units: velocity is {ratio:.4g}× the derivative of"
            f" theta_{side}; {hint[2:]} — fix the unit in [columns]",
            path=path,
            column=column,
            row=row,
            rows=rows,
        )


def _factor_hint(ratio: float) -> str:
    """``"; <what the factor means>"`` when ``ratio`` (> 0) is a known unit mix-up factor
    (within :data:`UNIT_FACTOR_TOLERANCE`), else ``""``."""
    for factor, hint in (
        (180.0 / math.pi, "velocity looks like deg/s (or position like rad where deg was meant)"),
        (60.0 / (2 * math.pi), "velocity looks like rpm"),
        (math.pi / 180.0, "position looks like deg (declare unit 'deg')"),
        (2 * math.pi / 60.0, "position/velocity units inconsistent by 9.55 (rpm vs rad/s?)"),
        (1e3, "time in ms read as s ([sampling] time_unit = 'ms' or the time column's unit), or a"
         " velocity in mm/s against a position in m?"),
        (1e6, "time in µs read as s ([sampling] time_unit = 'us' or the time column's unit), or a"
         " velocity in µm/s against a position in m?"),
        (1e-3, "time in s declared as ms, or a position in mm against a velocity in m/s?"),
    ):  # fmt: skip
        if abs(ratio / factor - 1) < UNIT_FACTOR_TOLERANCE:
            return f"; {hint}"
    return ""


#: Positions that share one scale on a prismatic axis (m of carriage travel): the motor and load
#: positions, and a mapped reference (a Trace name ending in ``_ref``, e.g. EMPS ``qg``).
_LINEAR_POSITIONS = ("theta_m", "theta_l")


def check_position_spans(
    spans: Mapping[str, float], kinds: Mapping[str, str | None], origin: Mapping[str, str], path: str
) -> None:
    """Refuse two mapped linear positions whose spans differ by a unit factor (10³ or 10⁶).

    On a prismatic axis the motor position (in m of carriage travel), the load position and a
    mapped reference all follow the same motion: their spans (max − min, SI) agree up to the
    tracking error, backlash and deflection — far from a factor 1000. Only columns whose
    declared unit is a length are compared (an angle pair differs by the gear ratio).
    """
    pos = [
        n
        for n in spans
        if kinds.get(n) == "length" and (n in _LINEAR_POSITIONS or n.endswith("_ref"))
        and spans[n] > 0 and math.isfinite(spans[n])
    ]  # fmt: skip
    for i, a in enumerate(pos):
        for b in pos[i + 1 :]:
            ratio = spans[a] / spans[b]
            for factor in (1e3, 1e-3, 1e6, 1e-6):
                if abs(ratio / factor - 1) < UNIT_FACTOR_TOLERANCE:
                    raise DataError(
                        f"implausible units: {a} spans {ratio:.4g}× {b} (column '{origin.get(b, b)}'),"
                        " both positions of one linear axis: a position in mm declared as m (or m as"
                        " mm)? — fix the unit in [columns]",
                        path=path,
                        column=origin.get(a, a),
                    )


@dataclass(frozen=True)
class MappedTable:
    """Columns of a table that is not a time series, mapped and converted to SI.

    Attributes
    ----------
    columns : dict
        Mapped column name → values in SI units.
    kinds : dict
        Mapped column name → unit kind of its declared unit (``"length"``, ``"angle"``,
        …; absent for columns taken as they are).
    units : dict
        Mapped column name → the unit declared in ``[columns]`` (absent when unmapped).
    origin : dict
        Mapped column name → source column in the file.
    meta : dict
        ``source``, ``format`` and the file's own metadata.
    rows : DataRows
        Where the rows are in the file, for messages (the reader's ``rows``).
    """

    columns: dict[str, np.ndarray]
    kinds: dict[str, str]
    units: dict[str, str]
    origin: dict[str, str]
    meta: dict[str, Any]
    rows: DataRows = field(default=NO_LINES, repr=False, compare=False)


def load_table(
    path: str | Path,
    mapping: DriveConfig | Mapping[str, Any] | None = None,
    *,
    required: Iterable[str] = (),
) -> MappedTable:
    """Read a table (rows are records, not samples in time), map and convert its columns.

    The same readers and ``[columns]`` mapping as :func:`load_trace`, without the time
    checks: e.g. the approaches of an ISO 230-2 test (target, run, direction, deviation).

    Parameters
    ----------
    path : str or Path
        CSV, Parquet, HDF5 or MATLAB file.
    mapping : DriveConfig or dict, optional
        Column mapping, as for :func:`load_trace`.
    required : iterable of str
        Mapped column names the caller needs.

    Raises
    ------
    DataError
        Unreadable file, missing column, unit that does not fit, NaN or infinite value —
        one line naming file, column and row.
    """
    p = Path(path)
    cmap, sampling = _mapping_from(mapping)
    table = read_raw(p)
    warnings: list[str] = []
    cols, kinds, origin = _apply_mapping(table, cmap, sampling, warnings)
    missing = [r for r in required if r not in cols]
    if missing:
        raise DataError(
            f"missing required column (have: {', '.join(cols) or 'none'}); map it in [columns]",
            path=str(p),
            column=missing[0],
        )
    _check_finite(cols, origin, str(p), table.rows)
    units = {cm.column: cm.unit for cm in (cmap or {}).values()}
    meta: dict[str, Any] = dict(table.meta)
    # the reader's warnings (a skipped preamble, …) first, then the mapping's — as load_trace
    meta.update({"source": str(p), "format": table.fmt, "warnings": [*meta.get("warnings", []), *warnings]})
    return MappedTable(cols, kinds, units, origin, meta, table.rows)


def load_trace(
    path: str | Path,
    mapping: DriveConfig | Mapping[str, Any] | None = None,
    *,
    required: Iterable[str] = (),
    resample: bool | None = None,
    check_saturation: bool = True,
    data: bytes | None = None,
    max_rate_hz: float | None = None,
) -> Trace:
    """Read, map, convert and validate a recording.

    Parameters
    ----------
    path : str or Path
        CSV, Parquet, HDF5 or MATLAB (v5/v7.3) file.
    mapping : DriveConfig, str, Path or dict, optional
        Column mapping: a configuration (its ``[columns]`` and ``[sampling]``
        tables) or its TOML path, or a dict *source column → Trace column*: the
        Trace column's name (``{"pos_load": "theta_l"}``, values taken as SI), a
        ``[columns]``-style table (``{"column": "theta_l", "unit": "deg"}``) or a
        :class:`~drivelash.io.config.ColumnMap`. Without one, columns must already
        carry the Trace names in SI units; with one, unmapped columns that carry a
        Trace name are taken as SI as they are. Anything else is a
        :class:`~drivelash.errors.ParameterError`.
    required : iterable of str
        Trace columns the caller needs (``t`` is always required).
    resample : bool, optional
        Override ``[sampling] resample``: resample non-uniform time onto a
        uniform grid by linear interpolation (recorded in ``meta["warnings"]``).
    check_saturation : bool
        Refuse torque/force columns clipped at a constant extreme.
    data : bytes, optional
        The file's content when the caller has already read it (e.g. to hash it): a Parquet
        file is decoded from it instead of being read again.
    max_rate_hz : float, optional
        Keep every k-th sample, k the largest integer with ``rate / k >= max_rate_hz``
        (see :func:`trace_from_table`); default: every sample.

    Returns
    -------
    Trace
        SI columns; ``meta`` holds ``source``, ``format``, ``axis``
        (``"rotary"``/``"prismatic"``), ``units`` and ``warnings``.

    Raises
    ------
    DataError
        One line naming file, column and first bad row.
    """
    p = Path(path)
    cmap, sampling = _mapping_from(mapping)
    if resample is not None:
        sampling = sampling.model_copy(update={"resample": resample})
    return trace_from_table(
        read_raw(p, data),
        cmap,
        sampling,
        required=required,
        check_saturation=check_saturation,
        max_rate_hz=max_rate_hz,
    )


def trace_from_table(
    table: RawTable,
    cmap: dict[str, ColumnMap] | None,
    sampling: SamplingSection,
    *,
    required: Iterable[str] = (),
    check_saturation: bool = True,
    max_rate_hz: float | None = None,
) -> Trace:
    """Map, convert and validate source columns (the part of :func:`load_trace` after reading).

    With ``max_rate_hz`` a recording sampled faster keeps every k-th sample (k ≥ 1, the
    largest integer with ``rate / k >= max_rate_hz``; the rate from the median of the first
    4096 intervals): the columns are mapped, unwrapped and checked for non-finite values at
    the full rate, then sampled down; the other checks and the trace see the kept samples.
    Plain sampling, no anti-aliasing filter: what a trace recorded at the lower rate would
    hold. ``meta["sampled_down"]`` records ``k``, the file's sample period [s] and samples.
    """
    spath = table.path
    rows = table.rows  # where a row of the columns is in the file (for the messages)
    required = list(required)
    warnings: list[str] = []
    cols, kinds, origin = _apply_mapping(table, cmap, sampling, warnings)

    if "t" not in cols and sampling.sample_rate is None:
        for name in ("t", "time"):  # an unmapped time column in [sampling] time_unit
            if name in table.unread:
                raise table.unread[name]
            if name in table.columns:
                cols = {"t": table.columns[name] * time_factor(table, name, sampling), **cols}
                origin["t"] = name
                break
    if "t" not in cols:
        if sampling.sample_rate is None:
            raise DataError(
                "missing required column 't' (no time column mapped and no [sampling] sample_rate)"
                + time_hint(list(table.columns), table.meta),
                path=spath,
                column="t",
            )
        n = next(iter(cols.values())).size if cols else 0
        cols = {"t": np.arange(n) / sampling.sample_rate, **cols}
        origin["t"] = "t"
    missing = [r for r in required if r not in cols]
    if missing:
        raise DataError(
            f"missing required column (have: {', '.join(cols)}); map it in [columns]",
            path=spath,
            column=missing[0],
        )
    for name in [k for k in cols if unread_column(k, cmap, required)]:
        bad = ~np.isfinite(cols[name])
        if bad.any():  # a column no computation reads does not refuse the recording
            row = int(np.flatnonzero(bad)[0])
            what = "NaN" if np.isnan(cols[name][row]) else "infinite value"
            warnings.append(unread_note(spath, origin.get(name, name), what, row, int(bad.sum()), rows))
            del cols[name]
            origin.pop(name, None)
    # every sample of what is read: a corrupt file is refused either way
    _check_finite(cols, origin, spath, rows)
    down = _sample_down(cols, max_rate_hz) if max_rate_hz is not None else None
    if down is not None:
        n_file = next(iter(cols.values())).size
        cols = {k: np.ascontiguousarray(v[:: down["k"]]) for k, v in cols.items()}
        rows = rows.taken(np.arange(0, n_file, down["k"]))  # kept sample i is the file's row i·k
    t_unit = next((cm.unit for cm in (cmap or {}).values() if cm.column == "t"), None)
    grid = _check_time(cols["t"], spath, origin.get("t", "t"), sampling, warnings, t_unit, rows)
    if grid is not None:
        t_old = cols["t"]
        cols = {k: (grid if k == "t" else np.interp(grid, t_old, v)) for k, v in cols.items()}
        # a sample of the grid is named by the first row of the file at or after its time
        rows = rows.taken(np.minimum(np.searchsorted(t_old, grid), t_old.size - 1))
    signal_names = list(dict.fromkeys([*SIGNAL_COLUMNS, *required]))
    if check_saturation:
        _check_signals(cols, origin, spath, signal_names, rows)
    else:
        _check_signals(
            {k: v for k, v in cols.items() if not k.startswith("torque")}, origin, spath, signal_names, rows
        )
    check_position_spans({k: float(np.ptp(v)) for k, v in cols.items()}, kinds, origin, spath)
    _check_units(cols, origin, spath, rows)
    _check_seams(cols, kinds, origin, spath, rows)
    _check_velocity_scales(cols, origin, spath)

    prismatic = is_prismatic(kinds)
    kinds_m = {kinds.get("theta_m"), kinds.get("omega_m")} - {None, "dimensionless"}
    if prismatic and kinds_m & {"angle", "angular_velocity"}:
        raise DataError(
            "theta_m and omega_m mix a length and an angle unit", path=spath, column=origin.get("omega_m")
        )
    meta: dict[str, Any] = dict(table.meta)
    meta.update(
        {
            "source": spath,
            "format": table.fmt,
            "axis": "prismatic" if prismatic else meta.get("axis", "rotary"),
            "warnings": list(meta.get("warnings", [])) + warnings,
        }
    )
    if prismatic:
        meta["units"] = dict(PRISMATIC_UNITS)
    if down is not None:
        meta["sampled_down"] = down
    if table.scalars:
        meta["scalars"] = {k: float(v) for k, v in table.scalars.items()}
    if cmap is not None:
        meta["mapping"] = {k: v.model_dump(exclude_defaults=True) for k, v in cmap.items()}
    trace = Trace(cols, meta, rows)
    _CHECKED[id(trace)] = trace
    return trace
