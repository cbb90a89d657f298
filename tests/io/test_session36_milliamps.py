"""A current column in milliamps (session 36, tester H, TH13 a).

A CNC's current trace in mA with ``unit = "mA"`` and ``torque_constant`` was refused: "unknown
unit 'mA' (did you mean 'm'?)". ``"mA"`` is a current unit like ``"A"`` — one rule: ×1e-3 to
amperes, then the torque constant [N·m/A] — everywhere ``"A"`` is handled (the loader, the chunked
stream, the conversion-key check, the units row of a CSV).
"""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.errors import ConfigError, DataError, ParameterError
from drivelash.io import load_trace
from drivelash.io.config import UNIT_KIND, load_config
from drivelash.io.stream import TraceStream

K_T = 1.8  # N·m/A


def _csv(path, unit_row: str | None = None):
    t = np.arange(2000) * 1e-3
    th = 0.3 * np.sin(2 * np.pi * 2 * t) + 0.2 * t
    tq = 1.5 * np.sin(2 * np.pi * 2 * t + 0.3) + 0.1 * np.cos(2 * np.pi * 7 * t)
    lines = ["t,theta_m,cur"] + ([unit_row] if unit_row else [])
    lines += [f"{a:.3f},{b:.12g},{c / K_T * 1e3:.6f}" for a, b, c in zip(t, th, tq, strict=True)]
    path.write_text("\n".join(lines) + "\n")
    return path, tq


def _mapping(unit: str = "mA", **kw):
    return {
        "t": "t",
        "theta_m": "theta_m",
        "cur": {"column": "torque_m", "unit": unit, "torque_constant": K_T, **kw},
    }


def test_a_current_in_milliamps_is_converted_with_the_torque_constant(tmp_path):
    p, tq = _csv(tmp_path / "ma.csv")
    tr = load_trace(p, _mapping(), required=["theta_m", "torque_m"])
    assert np.max(np.abs(tr["torque_m"] - tq)) < 1e-8  # mA × 1e-3 × 1.8 N·m/A
    with TraceStream(p, _mapping(), required=["theta_m", "torque_m"], chunk_rows=333) as s:
        got = np.concatenate([c["torque_m"] for c in s.chunks()])
    assert got.tolist() == tr["torque_m"].tolist()
    assert UNIT_KIND["mA"] == UNIT_KIND["A"] == "current"
    # negative control: the same numbers declared as A are 1000× the torque
    tr_a = load_trace(p, _mapping("A"), required=["theta_m", "torque_m"])
    assert np.allclose(tr_a["torque_m"], 1e3 * tr["torque_m"])


def test_a_units_row_is_checked_against_milliamps(tmp_path):
    p, tq = _csv(tmp_path / "row.csv", unit_row="s,rad,mA")
    tr = load_trace(p, _mapping(), required=["torque_m"])
    assert np.max(np.abs(tr["torque_m"] - tq)) < 1e-8
    with pytest.raises(DataError, match=r"column 'cur': the file's units row says 'mA', but the column would"
                       r" be read in 'A'; set unit = 'mA' in \[columns.cur\]"):  # fmt: skip
        load_trace(p, _mapping("A"), required=["torque_m"])


def test_milliamps_need_the_torque_constant_and_only_currents_take_it(tmp_path):
    p, _ = _csv(tmp_path / "ma.csv")
    with pytest.raises(DataError) as e:
        load_trace(p, {"t": "t", "theta_m": "theta_m", "cur": {"column": "torque_m", "unit": "mA"}})
    msg = str(e.value)
    assert "\n" not in msg and str(p) in msg and "column 'cur'" in msg, msg
    assert "unit 'mA' needs torque_constant (N·m/A or N/A) in [columns]" in msg, msg
    with pytest.raises(ParameterError, match=r"torque_constant applies only with unit = 'A' or 'mA'"):
        load_trace(p, _mapping("N"))
    # the unknown-unit message lists it
    (tmp_path / "c.toml").write_text('[columns.cur]\ncolumn = "torque_m"\nunit = "uA"\n')
    with pytest.raises(ConfigError) as e:
        load_config(tmp_path / "c.toml")
    assert "unknown unit 'uA'" in str(e.value) and ", A, mA, V," in str(e.value), str(e.value)
