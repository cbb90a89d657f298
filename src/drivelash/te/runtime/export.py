"""Export of the runtime table for a CNC (CSV or JSON) and reading it back."""

from __future__ import annotations

import csv
import json
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import DataError
from drivelash.io.outputs import dumps_json, final_suffix, write_json, write_target
from drivelash.te.runtime.compensator import CompensatorParams
from drivelash.te.runtime.persist import TE_MAX
from drivelash.te.runtime.table import DIRECTIONS, TETable

__all__ = ["export_table", "load_table"]

_CSV_HEADER = ("direction", "x_T_mm", "torque_Nm", "TE_um")


def export_table(table: TETable, path: Path, params: CompensatorParams | None = None) -> Path:
    """Write the table as CSV (long format) or JSON, chosen by the file suffix.

    Units in the file: position in mm (table axis, linear scale coordinates), motor
    torque in N·m, TE = x_T − x_M in µm. Interpolate bilinearly, clamp outside the grid.

    Parameters
    ----------
    table : TETable
        The table to export.
    path : pathlib.Path
        ``*.csv`` or ``*.json``.
    params : CompensatorParams, optional
        Written into the JSON (and the CSV comment header) for the CNC integrator.

    Returns
    -------
    pathlib.Path
        The written file.

    Raises
    ------
    DataError
        A table with |TE| beyond ``TE_MAX`` (an implausible model), a no-load TE beyond the CNC
        layouts' ``TE_LIMIT`` (:func:`_check_noload`), or a suffix other than ``.csv``/``.json``.
    """
    path = Path(path)
    suffix = final_suffix(path)  # a staging name of drivelash.io.outputs keeps the final suffix
    worst = float(np.max(np.abs(table.te)))
    if worst > TE_MAX:
        raise DataError(
            f"refusing to export a table with |TE| up to {worst * 1e6:.4g} um (limit {TE_MAX * 1e6:g} um):"
            " the model is implausible",
            path=str(path),
        )
    _check_noload(table, path)
    doc = _grid_doc(table, params)
    path.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".json":
        doc["te_um"] = {str(sgn): np.round(table.te[d] * 1e6, 6).tolist() for d, sgn in enumerate(DIRECTIONS)}
        write_json(path, doc, indent=1)
    elif suffix == ".csv":
        with write_target(path) as target, target.open("w", newline="") as fh:
            fh.write("# drivelash transmission-error table; " + dumps_json(doc, indent=None).strip() + "\n")
            w = csv.writer(fh)
            w.writerow(_CSV_HEADER)
            xs = table.x_grid * 1e3
            for d, sgn in enumerate(DIRECTIONS):
                ts = table.torque_grid(sgn)
                for i, xv in enumerate(xs):
                    for j, tv in enumerate(ts):
                        w.writerow((sgn, f"{xv:.6f}", f"{tv:.6f}", f"{table.te[d, i, j] * 1e6:.6f}"))
    else:
        raise DataError(f"unknown export format '{path.suffix}', use .csv or .json", path=str(path))
    return path


def _check_noload(table: TETable, path: Path) -> None:
    """The no-load TE (each flank's torque nearest 0) within the CNC layouts' limit
    (:data:`drivelash.te.runtime.cnc.TE_LIMIT`): the runtime table holds the whole TE, so a no-load
    TE the ``.ini``/``.COM`` export refuses as a unit, sign or zero-offset error must not reach
    the CNC through it either (finding TH14: a 2 mm zero offset was refused by the CNC layouts and
    written to the ``.csv``)."""
    from drivelash.te.runtime.cnc import check_noload_te

    for d, sgn in enumerate(DIRECTIONS):
        j = int(np.argmin(np.abs(table.torque_grid(sgn))))
        check_noload_te(float(np.max(np.abs(table.te[d, :, j]))), sgn, str(path))


def _grid_doc(table: TETable, params: CompensatorParams | None) -> dict[str, Any]:
    n_x, n_t = table.te.shape[1:]
    doc: dict[str, Any] = {
        "format": "drivelash-te-table",
        "version": 1,
        "definition": "TE = x_T - x_M (table position by linear scale minus motor position "
        "theta_M*d_p/(2*i_PG)), per flank in contact; flank +1 = positive direction of travel",
        "units": {"x_T": "mm", "torque": "N*m (motor side)", "TE": "um"},
        "interpolation": "bilinear in (x_T, torque); the grid is the valid range (where the model was"
        " trained): drivelash builds and exports no table beyond it; at run time its compensator holds the"
        " edge value for positions outside it and counts those cycles, as a real-time kernel should",
        "grid": {
            "x_T": {"start_mm": table.x0 * 1e3, "step_mm": table.dx * 1e3, "count": int(n_x)},
            "torque": {
                str(sgn): {
                    "start_Nm": float(table.torque0[d]),
                    "step_Nm": float(table.dtorque[d]),
                    "count": int(n_t),
                }
                for d, sgn in enumerate(DIRECTIONS)
            },
        },
        "usage": "every t_sc: v_c = (TE(x_d[n+1],T)-TE(x_d[n],T))/t_sc + d/dt[b*s(t/t_ss)] with T = motor "
        "torque - J_model*alpha and TE of the flank in contact; flank from the mesh torque T_M - friction - "
        "J_flank*alpha (sign beyond 'hysteresis': step over t_ss_sign; below 'release' for three "
        "cycles while the plan reverses: step over t_ss); b = bl_gain*(TE_new - TE_old) at x_d[n]; "
        "subtract v_c from the table velocity command",
        "meta": table.meta,
    }
    if params is not None:
        doc["compensator"] = asdict(params)
        doc["compensator_units"] = "SI: times s, torques N*m, inertias kg*m^2, omega_reg rad/s, v_max m/s"
    return doc


def load_table(path: Path) -> TETable:
    """Read a table written by :func:`export_table` (CSV or JSON) back, in SI units.

    Parameters
    ----------
    path : pathlib.Path
        The ``*.csv`` or ``*.json`` file (positions in mm, TE in µm, torque in N·m).

    Returns
    -------
    TETable
        Positions [m], torques [N·m], TE [m].

    Raises
    ------
    DataError
        Missing file, unknown suffix, not a drivelash table, or malformed content.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError("no such file", path=str(path))
    suffix = path.suffix.lower()
    try:
        if suffix == ".json":
            doc = json.loads(path.read_text())
            te = np.stack([np.asarray(doc["te_um"][str(s)], dtype=np.float64) for s in DIRECTIONS]) * 1e-6
        elif suffix == ".csv":
            with path.open() as fh:
                first = fh.readline()
                if not first.startswith("# drivelash transmission-error table; "):
                    raise DataError("not a drivelash TE table (missing header line)", path=str(path))
                doc = json.loads(first.split("; ", 1)[1])
                rows = np.loadtxt(fh, delimiter=",", skiprows=1, ndmin=2)
            n_x = doc["grid"]["x_T"]["count"]
            n_t = doc["grid"]["torque"]["1"]["count"]
            if rows.shape != (2 * n_x * n_t, 4):
                msg = f"expected {2 * n_x * n_t} rows of 4 values, got {rows.shape}"
                raise DataError(msg, path=str(path))
            te = rows[:, 3].reshape(2, n_x, n_t) * 1e-6
        else:
            raise DataError(f"unknown table format '{path.suffix}', use .csv or .json", path=str(path))
        g = doc["grid"]
        torque0 = np.array([g["torque"][str(s)]["start_Nm"] for s in DIRECTIONS])
        dtorque = np.array([g["torque"][str(s)]["step_Nm"] for s in DIRECTIONS])
        return TETable(
            g["x_T"]["start_mm"] * 1e-3, g["x_T"]["step_mm"] * 1e-3, torque0, dtorque, te, doc.get("meta", {})
        )
    except (KeyError, ValueError, TypeError) as exc:
        if isinstance(exc, DataError):
            raise
        raise DataError(f"malformed TE table ({exc.__class__.__name__}: {exc})", path=str(path)) from None
