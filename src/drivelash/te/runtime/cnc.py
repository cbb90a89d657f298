"""The geometric (no-load) transmission error in layouts CNCs load (issue 12 item 6).

A rack-and-pinion axis whose position loop closes on the motor encoder (no linear
scale, or the scale used for monitoring only) sees the transmission error TE = x_T − x_M
as a measuring-system error: the table stands TE ahead of where the motor encoder says.
The no-load part of it, per direction of travel, is what a CNC's position-dependent
compensation tables can hold. The load-dependent part is not in them, and the 5 ms
velocity channel of :mod:`drivelash.te.runtime.compensator` is the paper's scheme for a loop
closed on the linear scale: on a loop closed on the motor encoder the position controller takes
an added velocity back (of a correction TE only TE·s/(s+K_v) reaches the load: none in steady
state, ≈ 20 % of a 7.5 Hz meshing component at K_v = 231 1/s), so there the load part has to
enter as a position offset, v_c being only its feed-forward. The compensator's table holds the
whole TE, the no-load part included: used beside these tables it would count that part twice.

Layouts
-------
``sinumerik``
    SINUMERIK 840D sl measuring-system error compensation (function manual K3,
    "interpolatory compensation"): the init program ``%_N_AX_EEC_INI`` with
    ``$AA_ENC_COMP[0,N,AX]`` (measuring system 1) and ``$AA_ENC_COMP_STEP``, ``_MIN``,
    ``_MAX``, ``_IS_MODULO`` holding the **mean of both directions** — that table has no
    direction index — and ``%_N_NC_CEC_INI`` with two tables ``$AN_CEC`` whose
    ``$AN_CEC_DIRECTION`` is +1 and −1 (input axis = output axis: Siemens' documented way
    to a position-dependent backlash compensation) holding the **direction-dependent
    rest**. The control adds the LEC value to the actual position ("A positive
    compensation value causes the corresponding machine axis to move in the negative
    direction", K3 03/2013 §4.4.2.1), so the LEC value is +TE. For the CEC output K3 states
    no sign (it is "applied" to the compensation axis, its input is the base axis' set
    position); drivelash assumes it is added to the set position and writes the direction
    part negated — the one sign to check on the machine. Values in mm; the file starts with
    the program header (K3 example §4.4.2.3), its description is ``;`` comment lines inside
    the program, axes are assigned in parentheses (``$AN_CEC_INPUT_AXIS[0]=(X1)``, K3 p. 268),
    and the header names what the control needs: MD38000/MD18342[t] points, loading with
    MD32700/MD32710 = 0 (p. 237), then those = 1 and SD41300 ``$SN_CEC_TABLE_ENABLE[t]`` = 1
    (p. 245).
``heidenhain``
    HEIDENHAIN nonlinear axis-error compensation table ``<AXIS>.COM``: columns ``NR``,
    ``AXISPOS`` (compensation point, mm), ``<AXIS>`` (value in the positive direction of
    traverse) and ``BACKLASH`` (value in the negative direction), between ``BEGIN
    <AXIS>.COM MM`` and ``[END]`` (columns as in the MANUALplus 620 Technical Manual 01/2012
    p. 716: AXISPOS from the machine datum, BACKLASH "the compensation values measured in the
    negative direction of traverse"). Values are TE in mm, the convention of the LEC above —
    an assumption: the HEIDENHAIN pages found state no sign.

The **valid range** is where the model was measured (its no-load runs of both directions,
where its no-load curves hold data: :func:`~drivelash.te.runtime.table.measured_range`); the
table spans exactly that range (the first and last points are its ends; a SINUMERIK holds the
edge values beyond it, Function Manual Extended Functions 03/2013, K3 §4.4; for a HEIDENHAIN
control we found no statement), the SINUMERIK header states it in comments, the HEIDENHAIN file
after its ``[END]`` marker (a TNC table has no comment syntax). Positions outside it are
refused. Check the sign once on the machine (one laser or scale pass with the table
loaded) before production — the SINUMERIK LEC sign is quoted from its manual, the CEC and
HEIDENHAIN signs are assumed, and nothing was tested on a control here. The positions are the
campaign's x_T; they must be the machine coordinates of the control (its reference point
setting), and K3 (p. 238) asks for a compensation value of zero at the reference point (the
value there is a jump when the compensation switches on after referencing).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from drivelash.errors import DataError, ParameterError

__all__ = [
    "CNC_LAYOUTS",
    "GeometricTable",
    "geometric_table",
    "write_cnc",
    "write_heidenhain",
    "write_sinumerik",
]

#: Layout name → default file suffix.
CNC_LAYOUTS = {"sinumerik": ".ini", "heidenhain": ".com"}
#: Largest |TE| accepted in a CNC table [m]: a larger geometric error is a unit or sign
#: mistake, not a rack (ISO 230-2 positioning deviations of such axes are tens of µm).
TE_LIMIT = 1e-3
#: Largest CEC table index accepted (``$AN_CEC[t, ...]``): only a guard against typos — the
#: control checks the number of tables it is configured for when the init program is loaded.
MAX_CEC_TABLE = 999
#: Largest number of compensation points written.
MAX_POINTS = 100_000


class GeometricModel(Protocol):
    """What the export needs of a model (:class:`drivelash.te.runtime.predictor.TEModel`)."""

    def geometric(self, x_T: Any, direction: int) -> np.ndarray: ...

    def geometric_range(self) -> tuple[float, float]: ...


def _noload(model: GeometricModel, x: np.ndarray, direction: int) -> tuple[np.ndarray, np.ndarray | None]:
    """TE_geo and the ``te update`` change of the model's no-load TE (None if never updated) [m]."""
    geo = np.asarray(model.geometric(x, direction), dtype=np.float64)
    change = getattr(model, "noload_change", None)
    delta = change(x, direction) if callable(change) else None
    return geo, (None if delta is None else np.asarray(delta, dtype=np.float64))


@dataclass(frozen=True)
class GeometricTable:
    """No-load TE per direction on an equidistant grid.

    Attributes
    ----------
    x0 : float
        First compensation point [m].
    step : float
        Distance of the points [m].
    te_pos, te_neg : numpy.ndarray
        TE = x_T − x_M in the positive and negative direction of travel [m].
    valid : tuple of float
        The model's valid range (x_min, x_max) [m].
    interpolation_error : float
        Largest |linear interpolation between the points − model| on a 50 µm grid [m].
    source : str
        Provenance (model directory).
    update_note : str
        Empty for a model that was never updated; else what the values hold beyond the fit's
        no-load curves (the ``te update`` change, :meth:`TEModel.noload_change`), written into
        the file's header.
    """

    x0: float
    step: float
    te_pos: np.ndarray
    te_neg: np.ndarray
    valid: tuple[float, float]
    interpolation_error: float
    source: str = ""
    update_note: str = ""

    @property
    def x(self) -> np.ndarray:
        """Compensation points [m]."""
        return self.x0 + self.step * np.arange(self.te_pos.size)

    @property
    def x_max(self) -> float:
        """Last compensation point [m]."""
        return float(self.x[-1])

    @property
    def constant(self) -> float:
        """Constant part of the table: mean over the points of the mean of both directions [m]
        (a zero offset between the scale and the motor encoder ends up here)."""
        return float(np.mean(0.5 * (self.te_pos + self.te_neg)))

    @property
    def backlash_range(self) -> tuple[float, float]:
        """Smallest and largest TE_neg − TE_pos over the points [m]: the backlash the tables hold."""
        b = self.te_neg - self.te_pos
        return float(np.min(b)), float(np.max(b))

    def backlash_note(self, control: str) -> str:
        """Header line: the tables hold the backlash, so ``control``'s own backlash compensation
        must be 0 (finding D5: else every reversal is compensated twice)."""
        lo, hi = self.backlash_range
        return (
            f"the tables hold the backlash (TE- minus TE+ {lo * 1e6:.3f} ... {hi * 1e6:.3f} um):"
            f" set {control} = 0, else every reversal is compensated twice"
        )

    def constant_note(self) -> str:
        """Header line: the table's constant part (finding D10)."""
        return (
            f"constant part (mean of both directions over the table) {self.constant * 1e6:+.3f} um:"
            " a zero offset between scale and motor encoder is in it (the value at the reference point"
            " should be 0)"
        )


def geometric_table(
    model: GeometricModel,
    step: float = 1e-3,
    x_min: float | None = None,
    x_max: float | None = None,
    source: str = "",
) -> GeometricTable:
    """Sample the model's geometric (no-load) error per direction for a CNC table.

    For a model changed by ``te update`` the values are its no-load TE including the update:
    TE_geo + the change of its prediction at the no-load torque (``model.noload_change``),
    and the table's ``update_note`` says so (in the file's header); for a model never
    updated they are TE_geo, as before.

    Parameters
    ----------
    model : TEModel
        Loaded model (``geometric``, ``geometric_range``).
    step : float
        Distance of the compensation points [m].
    x_min, x_max : float, optional
        Range [m]; default the model's valid range — where it was measured: its stored
        valid range ∩ the span of its no-load curves
        (:func:`~drivelash.te.runtime.table.measured_range`). Positions outside it are refused.
    source : str
        Provenance written into the file.

    Returns
    -------
    GeometricTable
    """
    from drivelash.te.runtime.table import check_measured, measured_range

    lo, hi = measured_range(model)
    a = lo if x_min is None else float(x_min)
    b = hi if x_max is None else float(x_max)
    if not (math.isfinite(step) and step > 0):
        raise ParameterError("te export", "--step-mm", f"must be > 0, got {step * 1e3!r} mm")
    if math.isfinite(a) and math.isfinite(b):
        # first: a value outside the valid range (e.g. mm typed for m) is named with the range
        check_measured(a, b, (lo, hi), unit="mm")
    if not (math.isfinite(a) and math.isfinite(b) and b > a):
        raise ParameterError("te export", "--x-max", f"range [{a * 1e3:g}, {b * 1e3:g}] mm is empty")
    n = int(math.floor((b - a) / step + 1e-9)) + 1
    if n < 2:
        raise ParameterError("te export", "--step-mm", f"{step * 1e3:g} mm leaves fewer than 2 points")
    if n > MAX_POINTS:
        raise ParameterError(
            "te export", "--step-mm", f"{step * 1e3:g} mm gives {n} points (limit {MAX_POINTS})"
        )
    x = a + step * np.arange(n)
    parts = [_noload(model, x, d) for d in (1, -1)]
    te = [g if c is None else g + c for g, c in parts]
    note = ""
    if any(c is not None for _, c in parts):
        worst = max(float(np.max(np.abs(c))) for _, c in parts if c is not None)
        info = getattr(model, "info", {}) or {}
        note = (
            f"no-load TE of model version {info.get('model_version', '?')}: the fit's no-load curves"
            f" + the te update change of the model's no-load prediction (up to {worst * 1e6:.3f} um)"
        )
    for d, v in zip((1, -1), te, strict=True):
        if not np.all(np.isfinite(v)):
            raise DataError(f"the model's no-load curve of direction {d:+d} is not finite")
        check_noload_te(float(np.max(np.abs(v))), d)
    # what linear interpolation between the points loses against the model (50 µm grid)
    xf = np.arange(a, x[-1], 50e-6)
    err = 0.0
    for d, v in zip((1, -1), te, strict=True):
        g, c = _noload(model, xf, d)
        err = max(err, float(np.max(np.abs(np.interp(xf, x, v) - (g if c is None else g + c)))))
    return GeometricTable(float(a), float(step), te[0], te[1], (lo, hi), err, source, note)


def _mm(v: float, decimals: int = 6) -> str:
    s = f"{v * 1e3:.{decimals}f}"
    return "0." + "0" * decimals if s.lstrip("-") == "0." + "0" * decimals else s


def _check_axis(axis: str) -> str:
    if not (axis and axis.replace("_", "").isalnum() and axis[0].isalpha() and len(axis) <= 16):
        raise ParameterError("te export", "--axis", f"must be a machine axis name like X1, got {axis!r}")
    return axis


def _check_cec(tables: tuple[int, int]) -> None:
    ok = len(tables) == 2 and all(isinstance(t, int) and 0 <= t <= MAX_CEC_TABLE for t in tables)
    if not ok or tables[0] == tables[1]:
        raise ParameterError(
            "te export",
            "--cec-tables",
            f"must be two different table indices 0 ... {MAX_CEC_TABLE} (positive, negative direction),"
            f" got {','.join(str(t) for t in tables)}",
        )


def write_sinumerik(
    tab: GeometricTable, path: Path, axis: str = "X1", cec_tables: tuple[int, int] = (0, 1)
) -> Path:
    """Write the SINUMERIK 840D sl init programs (LEC + two direction CEC tables); see the module doc.

    Parameters
    ----------
    tab : GeometricTable
        From :func:`geometric_table`.
    path : pathlib.Path
        Output file.
    axis : str
        Machine axis name (MD10000), e.g. ``X1``.
    cec_tables : tuple of int
        CEC table indices of the positive and negative direction.
    """
    axis = _check_axis(axis)
    _check_cec(cec_tables)
    n = tab.te_pos.size
    mean = 0.5 * (tab.te_pos + tab.te_neg)
    t_pos, t_neg = cec_tables
    # The file starts with the program header, as the K3 example does (Function Manual Extended
    # Functions 03/2013, §4.4.2.3): the description is NC comment lines inside the program.
    lines = [
        "%_N_AX_EEC_INI",
        f"; drivelash geometric (no-load) transmission error of machine axis {axis}, {n} points",
        f"; valid range {_mm(tab.valid[0], 3)} ... {_mm(tab.valid[1], 3)} mm (the model's no-load runs); "
        f"table {_mm(tab.x0, 3)} ... {_mm(tab.x_max, 3)} mm, step {_mm(tab.step, 3)} mm; "
        "the control holds the first/last value outside it",
        "; TE = x_T - x_M [mm]: table position minus motor-encoder position, per direction of travel",
        "; $AA_ENC_COMP (measuring system 1, motor encoder): mean of both directions,"
        " added to the actual value",
        f"; $AN_CEC[{t_pos}] / [{t_neg}] ($AN_CEC_DIRECTION +1 / -1):"
        " direction-dependent rest TE_dir - mean, negated (assumed added to the set position:"
        " check its sign on the machine)",
        f"; needs MD38000 $MA_MM_ENC_COMP_MAX_POINTS[0] >= {n}, MD18342 $MN_MM_CEC_MAX_POINTS[{t_pos}]"
        f" and [{t_neg}] >= {n}",
        "; load with MD32700 $MA_ENC_COMP_ENABLE[0] = 0 and MD32710 $MA_CEC_ENABLE = 0 (tables are only"
        " loaded while inactive), then set both to 1",
        f"; and SD41300 $SN_CEC_TABLE_ENABLE[{t_pos}] = 1, SD41300 $SN_CEC_TABLE_ENABLE[{t_neg}] = 1"
        " (else the CEC tables are not evaluated)",
        f"; interpolation between the points differs from the model by <= {_um(tab)} um",
        f"; {tab.backlash_note('MD32450 $MA_BACKLASH[0] (backlash compensation)')}",
        f"; {tab.constant_note()}",
    ]
    if tab.update_note:
        lines.append(f"; {tab.update_note}")
    if tab.source:
        lines.append(f"; model: {tab.source}")
    lines += ["CHANDATA(1)"]
    lines += [f"$AA_ENC_COMP[0,{i},{axis}]={_mm(v)}" for i, v in enumerate(mean)]
    lines += [
        f"$AA_ENC_COMP_STEP[0,{axis}]={_mm(tab.step)}",
        f"$AA_ENC_COMP_MIN[0,{axis}]={_mm(tab.x0)}",
        f"$AA_ENC_COMP_MAX[0,{axis}]={_mm(tab.x_max)}",
        f"$AA_ENC_COMP_IS_MODULO[0,{axis}]=0",
        "M17",
        "%_N_NC_CEC_INI",
        "CHANDATA(1)",
    ]
    for t, direction, te in ((t_pos, 1, tab.te_pos), (t_neg, -1, tab.te_neg)):
        lines += [f"$AN_CEC[{t},{i}]={_mm(-v)}" for i, v in enumerate(te - mean)]
        lines += [
            # an axis is assigned in parentheses, as in every K3 example: "$AN_CEC_INPUT_AXIS[0] = (AX1)"
            # (Function Manual Extended Functions 03/2013 p. 268; 802D sl K3 11/2012 p. 222)
            f"$AN_CEC_INPUT_AXIS[{t}]=({axis})",
            f"$AN_CEC_OUTPUT_AXIS[{t}]=({axis})",
            f"$AN_CEC_STEP[{t}]={_mm(tab.step)}",
            f"$AN_CEC_MIN[{t}]={_mm(tab.x0)}",
            f"$AN_CEC_MAX[{t}]={_mm(tab.x_max)}",
            f"$AN_CEC_DIRECTION[{t}]={direction}",
            f"$AN_CEC_IS_MODULO[{t}]=0",
        ]
    lines.append("M17")
    return _write(path, lines)


def write_heidenhain(tab: GeometricTable, path: Path, axis: str = "X", table_name: str | None = None) -> Path:
    """Write a HEIDENHAIN ``.COM`` table (NR, AXISPOS, axis value, BACKLASH); see the module doc.

    Parameters
    ----------
    tab : GeometricTable
        From :func:`geometric_table`.
    path : pathlib.Path
        Output file (the table name in ``BEGIN`` is the file name, upper case).
    axis : str
        Axis key of CfgAxes/axisList, e.g. ``X`` (the value column's name).
    table_name : str, optional
        Name in the ``BEGIN`` line (the final file name); default the name of ``path``.
    """
    from drivelash.io.outputs import final_name

    axis = _check_axis(axis)
    name = (table_name or final_name(path)).upper()
    w = (8, 14, 14, 14)
    lines = [
        f"BEGIN {name} MM",
        f"{'NR':<{w[0]}}{'AXISPOS':<{w[1]}}{axis:<{w[2]}}{'BACKLASH':<{w[3]}}".rstrip(),
    ]
    for i, (x, p, q) in enumerate(zip(tab.x, tab.te_pos, tab.te_neg, strict=True)):
        lines.append(f"{i:<{w[0]}}{_signed(x, 4):<{w[1]}}{_signed(p, 5):<{w[2]}}{_signed(q, 5)}")
    lines += [
        "[END]",
        f"drivelash geometric (no-load) transmission error of axis {axis}, {tab.te_pos.size} points",
        f"valid range {_mm(tab.valid[0], 3)} ... {_mm(tab.valid[1], 3)} mm (the model's no-load runs); "
        f"table {_mm(tab.x0, 3)} ... {_mm(tab.x_max, 3)} mm, step {_mm(tab.step, 3)} mm",
        f"values TE = x_T - x_M [mm]: {axis} in the positive, BACKLASH in the negative direction of traverse",
        f"interpolation between the points differs from the model by <= {_um(tab)} um",
        tab.backlash_note("the control's backlash compensation (MP710, backLash in CfgAxisComp)"),
        tab.constant_note(),
    ]
    if tab.update_note:
        lines.append(tab.update_note)
    if tab.source:
        lines.append(f"model: {tab.source}")
    return _write(path, lines)


def _um(tab: GeometricTable) -> str:
    return f"{tab.interpolation_error * 1e6:.3f}"


def _signed(v: float, decimals: int) -> str:
    s = _mm(v, decimals)
    return s if s.startswith("-") else "+" + s


def _write(path: Path, lines: list[str]) -> Path:
    from drivelash.io.outputs import write_target

    path = Path(path)
    with write_target(path) as target, target.open("w", encoding="ascii", newline="\r\n") as fh:
        fh.write("\n".join(lines) + "\n")  # CNC text files: ASCII, CR LF
    return path


def write_cnc(
    tab: GeometricTable,
    path: Path,
    layout: str,
    axis: str | None = None,
    cec_tables: tuple[int, int] = (0, 1),
) -> Path:
    """Write ``tab`` in ``layout`` (``"sinumerik"``, ``"heidenhain"``) to ``path`` (may be a staging path);
    ``cec_tables`` (SINUMERIK only): the CEC table indices of the positive and negative direction."""
    if layout == "sinumerik":
        return write_sinumerik(tab, path, axis or "X1", cec_tables)
    if layout == "heidenhain":
        return write_heidenhain(tab, path, axis or "X")
    raise ParameterError(
        "te export", "--format", f"must be one of table, {', '.join(CNC_LAYOUTS)}, got {layout!r}"
    )


def check_noload_te(worst: float, direction: int, path: str | None = None) -> None:
    """Refuse a no-load TE whose largest magnitude ``worst`` [m] in ``direction`` (±1) exceeds
    :data:`TE_LIMIT` — a unit, sign or zero-offset error, not a rack (the CNC layouts here and the
    runtime table, :func:`drivelash.te.runtime.export.export_table`, share it)."""
    if worst > TE_LIMIT:
        raise DataError(
            f"refusing to export a no-load TE of {worst * 1e3:.4g} mm in direction {direction:+d} "
            f"(limit {TE_LIMIT * 1e3:g} mm): a unit, sign or zero-offset error, not a rack",
            path=path,
        )
