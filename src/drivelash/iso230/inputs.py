"""Reading an ISO 230-2 measurement through the project's readers.

Two kinds of file, any format :func:`drivelash.io.read_raw` knows (CSV, Parquet, HDF5,
MAT), with a ``[columns]`` mapping that names and converts the columns:

- **a table of approaches** — ``P_target`` (or ``P_cmd``), ``run``, ``direction`` (+1 for
  an approach in the positive direction, −1 for the negative) and either the deviation
  ``x_dev`` or the measured position ``P_actual`` (then x = P_actual − P_target);
- **a raw time series** — ``t``, the commanded position ``P_cmd``, the reference
  measurement ``P_actual`` and optionally the axis's own position ``P_axis``; the dwells
  are found by :func:`drivelash.iso230.dwell.detect_dwells`.

A file with a ``run`` and a ``direction`` column is a table, otherwise a time series
(``[iso230] input`` forces one). Positions in a length unit make a linear axis (m), in
an angle unit a rotary axis (rad); mixing the two is refused, as is a measurement that
does not move with the command (a factor 1000 or a reversed sign between them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from drivelash.errors import DataError, ParameterError
from drivelash.iso230.dwell import (
    Drift,
    DwellParams,
    Dwells,
    detect_dwells,
    estimate_drift,
    settle_dwells,
    targets_unit_hint,
)
from drivelash.iso230.evaluate import COVERAGE, Approaches, approaches_from_rows

__all__ = ["Iso230Params", "Measurement", "read_measurement"]

#: Position columns of either kind of input.
POSITION_COLUMNS = ("P_target", "P_cmd", "P_actual", "P_axis", "x_dev")

#: A measurement whose deviations spread over more than this fraction of the travel,
#: or whose scale differs from the command's by more than this fraction, is refused
#: as a unit mix-up (real positioning errors are ~1e-5 of the travel, lead errors ~1e-4).
MAX_DEVIATION_FRACTION = 0.01

#: What to do about non-uniform sampling of a time series: ``iso230`` (and the Python API)
#: take it from the configuration only.
RESAMPLE_HINT_ISO230 = "resample explicitly: [sampling] resample = true in the iso230 configuration"

#: An offset of the reference larger than this fraction of the travel is reported.
OFFSET_WARNING_FRACTION = 0.01

#: Deviations of a linear axis spreading less than this over the whole test [m] are reported
#: as a likely unit slip (docs/assumptions.md, "ISO 230-2"): 50 nm is below the positioning error
#: of ultra-precision axes over their travel and below a laser interferometer's environmental
#: uncertainty (≈ 1 ppm of the distance: 1 µm per m); a column in mm declared as µm reads
#: 1000× small (the tester's 3–21 µm test read 3–21 nm).
MIN_DEVIATION_SPREAD = 50e-9

#: Deviations of a linear axis spreading more than this over the whole test [m] *and* more than
#: :data:`LARGE_DEVIATION_FRACTION` of the travel are reported as a likely unit slip, the mirror of
#: :data:`MIN_DEVIATION_SPREAD` (docs/assumptions.md, "ISO 230-2"): a column in µm declared as mm
#: reads 1000× large (session 32 tester E3: a good 500 mm axis's 4.9 µm read 4.9 mm, 0.98 % of the
#: travel, just under the 1 % refusal). The shipped tables spread 18–26 µm; the largest genuine
#: spread seen is PSI ecmc's mcu1025 stage, 0.13 mm over 40.8 mm (3.2e-3 of its travel): 0.5 mm
#: leaves it a factor 3.8.
MAX_DEVIATION_SPREAD = 0.5e-3

#: The relative half of that rule [-]: a laser's environmental uncertainty is ≈ 1 ppm of the
#: distance, so a measurable spread is ≥ 1e-6 of the travel and reads ≥ 1e-3 of it after a µm→mm
#: slip; genuine axes spread 1e-5…1e-4 of the travel (shipped tests 3.7e-5…5.2e-5), long axes with
#: a millimetre of lead error stay below 1e-3.
LARGE_DEVIATION_FRACTION = 1e-3


@dataclass(frozen=True)
class Iso230Params:
    """``[iso230]``: what the measurement is and how it is evaluated.

    Parameters
    ----------
    input : {"auto", "table", "timeseries"}
        Kind of input; ``"auto"`` takes a file with ``run`` and ``direction`` columns as
        a table, anything else as a time series.
    axis : {"auto", "linear", "rotary"}
        Kind of axis; ``"auto"`` follows the units of the mapped position columns
        (linear when none is declared).
    targets : tuple of float
        Nominal target positions [m or rad]; empty: the targets are the clusters of
        the dwells (time series) or of the table's target column.
    coverage : float
        Coverage probability of the intervals of B and B̄ [-].
    compensation : float
        Reversal (backlash) compensation the control applied during the test [m or rad];
        added back to the measured lost motion before it is compared with the deadzone.
        Its plausibility (at most 2 mm or 1°) is checked once the axis's unit is known
        (:func:`drivelash.iso230.compare.check_compensation`).

    Raises
    ------
    ParameterError
        A field outside its valid range (one line naming the class and the field).
    """

    input: Literal["auto", "table", "timeseries"] = "auto"
    axis: Literal["auto", "linear", "rotary"] = "auto"
    targets: tuple[float, ...] = ()
    coverage: float = COVERAGE
    compensation: float = 0.0

    def __post_init__(self) -> None:
        if self.input not in ("auto", "table", "timeseries"):
            raise ParameterError(
                "Iso230Params", "input", f"must be auto, table or timeseries, got {self.input!r}"
            )
        if self.axis not in ("auto", "linear", "rotary"):
            raise ParameterError("Iso230Params", "axis", f"must be auto, linear or rotary, got {self.axis!r}")
        if not (isinstance(self.coverage, int | float) and 0.5 <= self.coverage < 1):
            raise ParameterError("Iso230Params", "coverage", f"must lie in [0.5, 1), got {self.coverage!r}")
        if not (isinstance(self.compensation, int | float) and math.isfinite(self.compensation)):
            raise ParameterError(
                "Iso230Params", "compensation", f"must be a finite number, got {self.compensation!r}"
            )
        t = np.asarray(self.targets, dtype=np.float64)
        if t.size and not np.all(np.isfinite(t)):
            raise ParameterError("Iso230Params", "targets", "must be finite numbers")
        if t.size and np.unique(t).size != t.size:
            raise ParameterError("Iso230Params", "targets", "contains a target twice")


@dataclass(frozen=True)
class Measurement:
    """An ISO 230-2 measurement read from a file.

    Attributes
    ----------
    kind : {"table", "timeseries"}
    unit : {"m", "rad"}
        SI unit of positions and deviations (linear or rotary axis).
    approaches : Approaches
        Deviations of the reference measurement by target, direction and run.
    approaches_axis : Approaches or None
        P_actual − P_axis (reference against the axis's own encoder), time series only.
    dwells : Dwells or None
        The dwells found (time series only).
    series : dict or None
        ``t``, ``P_cmd``, ``P_actual`` (and ``P_axis``) of a time series, for plots.
    source : str
        The file.
    warnings : list of str
        Load warnings, skipped dwells, departures from the standard's test conditions.
    drift : Drift or None
        Drift of the reference across the runs (time series only).
    """

    kind: Literal["table", "timeseries"]
    unit: Literal["m", "rad"]
    approaches: Approaches
    approaches_axis: Approaches | None
    dwells: Dwells | None
    series: dict[str, np.ndarray] | None
    source: str
    warnings: list[str] = field(default_factory=list)
    drift: Drift | None = None


def _axis_unit(kinds: dict[str, str], params: Iso230Params, source: str, origin: dict[str, str]) -> str:
    """``"m"`` or ``"rad"`` from the declared units; refuse a mix of length and angle."""
    declared = {c: kinds[c] for c in POSITION_COLUMNS if c in kinds}
    found = set(declared.values())
    if len(found) > 1:
        lin = next(c for c, k in declared.items() if k == "length")
        rot = next(c for c, k in declared.items() if k == "angle")
        raise DataError(
            f"units mismatch: '{origin.get(lin, lin)}' ({lin}) is a length but '{origin.get(rot, rot)}'"
            f" ({rot}) an angle; declare all positions in length units (linear axis) or all in angle"
            " units (rotary axis)",
            path=source,
            column=origin.get(rot, rot),
        )
    if params.axis != "auto":
        want = "length" if params.axis == "linear" else "angle"
        if found and found != {want}:
            col = next(iter(declared))
            raise DataError(
                f"units mismatch: [iso230] axis = '{params.axis}' but the positions are declared in"
                f" {next(iter(found))} units",
                path=source,
                column=origin.get(col, col),
            )
        return "m" if params.axis == "linear" else "rad"
    return "rad" if found == {"angle"} else "m"


def _check_scale(ref: np.ndarray, cmd: np.ndarray, source: str, ref_col: str, cmd_col: str) -> None:
    """Refuse a reference that does not move one-to-one with the command (units, sign)."""
    c = cmd - cmd.mean()
    var = float(np.dot(c, c))
    if var <= 0:
        return
    slope = float(np.dot(c, ref - ref.mean()) / var)
    if abs(slope - 1.0) > MAX_DEVIATION_FRACTION:
        hint = (
            "the reference runs opposite to the command (set scale = -1 in its [columns] entry)"
            if slope < 0
            else "wrong unit in [columns]?"
        )
        raise DataError(
            f"units mismatch: '{ref_col}' moves {slope:.4g}× as far as '{cmd_col}' (expected 1 within"
            f" {MAX_DEVIATION_FRACTION:g}); {hint}",
            path=source,
            column=ref_col,
        )


def _unwrap_angles(
    actual: np.ndarray, target: np.ndarray, unit: str, travel: float, col: str
) -> tuple[np.ndarray, str | None]:
    """Measured angles of a rotary axis brought to the turn of their targets (s19 F4).

    Rotary tables and their encoder/laser software read 0…360°: the approach to 0° from below
    reads 359.9998°. Where P_actual − P_target, wrapped into (−180°, 180°], is small for every
    row (within :data:`MAX_DEVIATION_FRACTION` of the travel, or of a turn) and the raw
    difference is not, the measured angles are taken modulo a turn.

    Parameters
    ----------
    actual, target : numpy.ndarray
        Measured and target angles [rad] (or positions [m]: returned unchanged).
    unit : {"m", "rad"}
    travel : float
        Range of the targets [rad].
    col : str
        The measured column's name in the file (for the warning).

    Returns
    -------
    actual : numpy.ndarray
        The measured angles on the targets' turn [rad].
    note : str or None
        The warning when any angle was moved by a turn.
    """
    if unit != "rad":
        return actual, None
    turn = 2.0 * math.pi
    d = actual - target
    wrapped = d - turn * np.round(d / turn)
    moved = np.abs(wrapped - d) > 0.5 * math.pi
    if not moved.any():
        return actual, None
    small = MAX_DEVIATION_FRACTION * max(travel, turn / 4)
    if float(np.ptp(wrapped)) > small:
        return actual, None  # not a wrap: the scale check names the problem
    return target + wrapped, (
        f"column {col!r}: {int(moved.sum())} measured angle(s) differ from their target by a whole turn"
        " (read 0…360°): taken on the target's turn"
    )


def _on_nominal_targets(
    target: np.ndarray,
    x: np.ndarray,
    from_actual: bool,
    nominal: tuple[float, ...],
    travel: float,
    unit: str,
    col: str,
) -> tuple[np.ndarray, np.ndarray, str | None]:
    """Rows of a table assigned to the nominal ``[iso230] targets`` (s19 F14).

    A target column that holds the control's actual position scatters by µm between runs;
    clustered at float round-off, its rows were "unequal targets". When every row lies within
    1e-4 of the travel of a nominal target (the tolerance the nominal targets are checked
    with), each row is that target; with ``P_actual`` given, x = P_actual − P_i of the
    nominal P_i (ISO 230-2's deviation). Otherwise nothing changes (the mismatch is reported
    as before).

    Parameters
    ----------
    target : numpy.ndarray
        The table's target column [m or rad].
    x : numpy.ndarray
        Deviations [m or rad].
    from_actual : bool
        ``x`` is P_actual − target (recomputed against the nominal target).
    nominal : tuple of float
        ``[iso230] targets`` [m or rad].
    travel : float
        Range of ``target`` [m or rad].
    unit : {"m", "rad"}
    col : str
        The target column's name in the file (for the warning).

    Returns
    -------
    target, x : numpy.ndarray
    note : str or None
        The warning when a row was moved beyond float round-off.
    """
    nom = np.sort(np.asarray(nominal, dtype=np.float64))
    idx = np.argmin(np.abs(target[:, None] - nom[None, :]), axis=1)
    off = target - nom[idx]
    tol = 1e-4 * max(travel, 1e-300)
    if not np.all(np.abs(off) <= tol) or np.unique(idx).size != nom.size:
        return target, x, None
    snapped = nom[idx]
    x_new = x + off if from_actual else x  # P_actual − P_i = (P_actual − target) + (target − P_i)
    worst = float(np.max(np.abs(off)))
    note = None
    if worst > 1e-6 * max(travel, 1e-300):  # beyond the clustering's round-off (TARGET_TOLERANCE)
        shown = f"{worst * 1e6:.3g} µm" if unit == "m" else f"{math.degrees(worst) * 3600:.3g} arcsec"
        note = (
            f"column {col!r}: targets differ from the nominal [iso230] targets by up to {shown}"
            " (the control's actual position?): each row taken at its nominal target"
        )
    return snapped, x_new, note


def _scatter_hint(target: np.ndarray, travel: float, unit: str) -> str:
    """For "unequal targets": when the target column scatters by little around fewer positions
    (grouped at 1e-4 of the travel), say so and how to give the nominal targets (s19 F14)."""
    from drivelash.iso230.evaluate import TARGET_TOLERANCE, cluster_targets

    fine, _ = cluster_targets(target, TARGET_TOLERANCE)
    coarse, labels = cluster_targets(target, 1e-4)
    if coarse.size < 2 or coarse.size >= fine.size:
        return ""
    worst = float(np.max(np.abs(target - coarse[labels])))
    shown = f"{worst * 1e6:.3g} µm" if unit == "m" else f"{math.degrees(worst) * 3600:.3g} arcsec"
    return (
        f"; the column scatters by up to {shown} around {coarse.size} positions (the control's actual"
        " position?): give the nominal targets as [iso230] targets = [...] (m or rad)"
    )


def _check_spread(x: np.ndarray, travel: float, source: str, col: str, unit: str) -> None:
    spread = float(np.ptp(x))
    if travel > 0 and spread > MAX_DEVIATION_FRACTION * travel:
        shown = f"{spread * 1e3:.4g} mm" if unit == "m" else f"{math.degrees(spread):.4g} deg"
        raise DataError(
            f"units mismatch: the deviations spread over {shown}, {spread / travel:.1%} of the travel"
            f" (real positioning errors are far below {MAX_DEVIATION_FRACTION:.0%});"
            " wrong unit in [columns]?",
            path=source,
            column=col,
        )


def _tiny_warning(x: np.ndarray, unit: str, col: str) -> list[str]:
    """A warning when the deviations of a linear axis spread less than :data:`MIN_DEVIATION_SPREAD`
    — below what a machine axis positions to (a column in mm declared as µm reads 1000× small)."""
    spread = float(np.ptp(x))
    if unit == "m" and 0 < spread < MIN_DEVIATION_SPREAD:
        return [
            f"column {col!r}: the deviations spread over only {spread * 1e9:.3g} nm (all runs, all targets),"
            f" below what a machine axis positions to ({MIN_DEVIATION_SPREAD * 1e9:.0f} nm): is the column in"
            " a larger unit than [columns] says (mm declared as µm?)"
        ]
    return []


def _large_warning(x: np.ndarray, travel: float, unit: str, col: str, source: str) -> list[str]:
    """A warning when the deviations of a linear axis spread more than :data:`MAX_DEVIATION_SPREAD`
    and more than :data:`LARGE_DEVIATION_FRACTION` of the travel [m] — far beyond what a machine
    axis positions to (a column in µm declared as mm reads 1000× large; the mirror of
    :func:`_tiny_warning`). Beyond :data:`MAX_DEVIATION_FRACTION` :func:`_check_spread` refuses."""
    spread = float(np.ptp(x))
    if unit == "m" and travel > 0 and spread > max(MAX_DEVIATION_SPREAD, LARGE_DEVIATION_FRACTION * travel):
        return [
            f"{Path(source).name}, column {col!r}: the deviations spread over {spread * 1e3:.4g} mm"
            f" ({spread / travel:.2%} of the travel), far beyond what a machine axis positions to"
            f" (> {MAX_DEVIATION_SPREAD * 1e3:g} mm and > {LARGE_DEVIATION_FRACTION:.1%} of the travel):"
            " is the column in a smaller unit than [columns] says (µm declared as mm?)"
        ]
    return []


def _offset_warning(x: np.ndarray, travel: float, unit: str) -> list[str]:
    off = float(np.median(x))
    if travel > 0 and abs(off) > OFFSET_WARNING_FRACTION * travel:
        shown = f"{off * 1e3:.4g} mm" if unit == "m" else f"{math.degrees(off):.4g} deg"
        return [
            f"the reference is offset by {shown} from the commanded positions (not zeroed at the axis"
            " origin): the mean deviations carry it; B, R, E, M and A are differences and unaffected"
        ]
    return []


#: What a direction column holds (added to a "not a number" in it, s19 F9).
DIRECTION_HINT = (
    "a direction is +1 (approach in the positive direction) or -1 (negative):"
    " write the column as numbers (Up/Down, fwd/bwd, +/- are not read)"
)


def _direction_columns(mapping: Any) -> set[str]:
    """The file's column names that hold the approach direction (mapped or named so)."""
    cols = {"direction"}
    for src, cm in (getattr(mapping, "columns", None) or {}).items():
        if getattr(cm, "column", None) == "direction":
            cols.add(src)
    return cols


def _read_table(path: Path, mapping: Any, params: Iso230Params, table: Any) -> Measurement:
    src = str(path)
    cols, origin = table.columns, table.origin
    tcol = "P_target" if "P_target" in cols else "P_cmd" if "P_cmd" in cols else None
    if tcol is None:
        raise DataError(
            "a table of approaches needs a target position column (map it to P_target)",
            path=src,
            column="P_target",
        )
    for need in ("run", "direction"):
        if need not in cols:
            raise DataError(f"a table of approaches needs a '{need}' column", path=src, column=need)
    unit = _axis_unit(table.kinds, params, src, origin)
    target = cols[tcol]
    travel = float(np.ptp(target))
    if "x_dev" in cols:
        x = cols["x_dev"]
        dev_col = origin.get("x_dev", "x_dev")
    elif "P_actual" in cols:
        actual, wrap_note = _unwrap_angles(
            cols["P_actual"], target, unit, travel, origin.get("P_actual", "P_actual")
        )
        _check_scale(actual, target, src, origin.get("P_actual", "P_actual"), origin.get(tcol, tcol))
        x = actual - target
        dev_col = origin.get("P_actual", "P_actual")
    else:
        raise DataError(
            "a table of approaches needs the deviation (map it to x_dev) or the measured position (P_actual)",
            path=src,
            column="x_dev",
        )
    _check_spread(x, travel, src, dev_col, unit)
    snap_note = None
    if params.targets:
        target, x, snap_note = _on_nominal_targets(
            target, x, "x_dev" not in cols, params.targets, travel, unit, origin.get(tcol, tcol)
        )
    names = {"target": origin.get(tcol, tcol), "run": origin.get("run", "run")}
    names |= {"direction": origin.get("direction", "direction"), "deviation": dev_col}
    try:
        ap = approaches_from_rows(
            target, cols["run"], cols["direction"], x, unit=unit, source=src, columns=names, rows=table.rows
        )
    except DataError as exc:
        if not params.targets and "unequal targets" in str(exc):
            exc.args = (str(exc) + _scatter_hint(target, travel, unit),)
        raise
    if params.targets:
        nominal = np.sort(np.asarray(params.targets, dtype=np.float64))
        if nominal.size != ap.m or np.max(np.abs(nominal - ap.targets)) > 1e-4 * max(travel, 1e-300):
            raise DataError(
                f"the table's {ap.m} targets do not match the {nominal.size} nominal [iso230] targets"
                + targets_unit_hint(nominal, ap.targets, unit, travel),
                path=src,
                column=names["target"],
            )
    warnings = list(table.meta.get("warnings", [])) + list(ap.warnings) + _tiny_warning(x, unit, dev_col)
    warnings += _large_warning(x, travel, unit, dev_col, src)
    if "x_dev" not in cols and wrap_note:
        warnings.append(wrap_note)
    if snap_note:
        warnings.append(snap_note)
    return Measurement("table", unit, ap, None, None, None, src, warnings)  # type: ignore[arg-type]


def _read_series(path: Path, mapping: Any, params: Iso230Params, dwell: DwellParams) -> Measurement:
    from drivelash.io.config import UNIT_KIND
    from drivelash.io.load import load_trace, with_resample_hint

    src = str(path)
    try:
        trace = load_trace(path, mapping, required=("P_cmd", "P_actual"), check_saturation=False)
    except DataError as exc:  # iso230 has no --resample option: name only what it takes (s19 F21)
        raise with_resample_hint(exc, RESAMPLE_HINT_ISO230) from None
    origin: dict[str, str] = {}
    kinds: dict[str, str] = {}
    for source_col, cm in (trace.meta.get("mapping") or {}).items():
        origin[cm["column"]] = source_col
        kinds[cm["column"]] = UNIT_KIND[cm.get("unit", "1")]
    unit = _axis_unit(kinds, params, src, origin)
    t, cmd, ref = trace["t"], trace["P_cmd"], trace["P_actual"]
    axis = trace["P_axis"] if "P_axis" in trace else None
    _check_scale(ref, cmd, src, origin.get("P_actual", "P_actual"), origin.get("P_cmd", "P_cmd"))
    if axis is not None:
        _check_scale(axis, cmd, src, origin.get("P_axis", "P_axis"), origin.get("P_cmd", "P_cmd"))
    nominal = np.asarray(params.targets, dtype=np.float64) if params.targets else None
    d = detect_dwells(
        t, cmd, ref, axis, params=dwell, nominal=nominal, unit=unit, source=src, rows=trace.rows
    )
    d, settle_note = settle_dwells(
        d, t, cmd, ref, axis, params=dwell, nominal=nominal, unit=unit, source=src, rows=trace.rows
    )
    travel = float(np.ptp(cmd))
    warnings = list(trace.meta.get("warnings", [])) + list(d.warnings) + list(d.approaches.warnings)
    if settle_note:
        warnings.append(settle_note)
    warnings += _offset_warning(d.deviation, travel, unit)
    series = {"t": t, "P_cmd": cmd, "P_actual": ref}
    if axis is not None:
        series["P_axis"] = axis
    drift = estimate_drift(d) if d.approaches.n >= 2 else None
    return Measurement("timeseries", unit, d.approaches, d.approaches_axis, d, series, src, warnings, drift)  # type: ignore[arg-type]


def read_measurement(
    path: str | Path,
    mapping: Any = None,
    *,
    params: Iso230Params | None = None,
    dwell: DwellParams | None = None,
) -> Measurement:
    """Read an ISO 230-2 measurement: a table of approaches or a raw time series.

    Parameters
    ----------
    path : str or Path
        CSV, Parquet, HDF5 or MAT file.
    mapping : DriveConfig or dict, optional
        ``[columns]`` (and ``[sampling]``) mapping, as for :func:`drivelash.io.load_trace`.
    params : Iso230Params, optional
        ``[iso230]`` settings.
    dwell : DwellParams, optional
        ``[dwell]`` detection settings (time series).

    Returns
    -------
    Measurement

    Raises
    ------
    DataError
        One line naming the file, the column or target and the problem.
    """
    from drivelash.io.load import load_table

    p = Path(path)
    params = params or Iso230Params()
    dwell = dwell or DwellParams()
    kind = params.input
    table = None
    if kind in ("auto", "table"):
        try:
            table = load_table(p, mapping)
        except DataError as exc:  # words in the direction column (Up/Down, fwd/bwd): say what it holds
            if exc.column in _direction_columns(mapping) and "not a number" in str(exc):
                exc.args = (f"{exc}; {DIRECTION_HINT}",)
            raise
        if kind == "auto":
            cols = table.columns
            kind = "table" if ("run" in cols and "direction" in cols) else "timeseries"
            if kind == "timeseries" and not ("P_cmd" in cols and "P_actual" in cols):
                have = ", ".join(table.origin.get(c, c) for c in cols) or "none"
                raise DataError(
                    "neither a table of approaches (needs run, direction, P_target and x_dev or P_actual)"
                    f" nor a time series (needs t, P_cmd, P_actual); columns: {have}; map them in [columns]",
                    path=str(p),
                )
    if kind == "table":
        return _read_table(p, mapping, params, table)
    return _read_series(p, mapping, params, dwell)
