"""Units rows with a current: case and the torque constant (session 36, tester J, J9).

A units row of ``MA`` (megaampere) under a column mapped ``unit = "mA"`` was read as milliamps
without a word (an unknown stated unit under a mapping is only a warning), 10^9 × off; now a
unit named with the mega prefix ``M`` is refused in one line naming file, column and the unit.
A units row ``mA`` under a column with no unit in the mapping advised "set unit = 'mA' in
[columns.cur]", which the next run refused for the missing torque_constant; the advice now names
both. The README says torque_constant is per ampere even for a column in mA.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from drivelash.errors import DataError
from drivelash.io import load_trace
from drivelash.io.stream import TraceStream

K_T = 1.8  # N·m/A
README = Path(__file__).resolve().parents[2] / "README.md"


def _csv(path, unit_row: str, current: str = "cur"):
    t = np.arange(2000) * 1e-3
    th = 0.3 * np.sin(2 * np.pi * 2 * t) + 0.2 * t
    tq = 1.5 * np.sin(2 * np.pi * 2 * t + 0.3) + 0.1 * np.cos(2 * np.pi * 7 * t)
    lines = [f"t,theta_m,{current}", unit_row]
    lines += [f"{a:.3f},{b:.12g},{c / K_T * 1e3:.6f}" for a, b, c in zip(t, th, tq, strict=True)]
    path.write_text("\n".join(lines) + "\n")
    return path, tq


def _mapping(unit: str = "mA"):
    return {
        "t": "t",
        "theta_m": "theta_m",
        "cur": {"column": "torque_m", "unit": unit, "torque_constant": K_T},
    }


@pytest.mark.parametrize("stream", [False, True])
@pytest.mark.parametrize(("cell", "unit"), [("MA", "mA"), ("[MA]", "mA"), ("MA", "A")])
def test_a_megaampere_units_row_is_not_read_as_milliamps(tmp_path, stream, cell, unit):
    p, _ = _csv(tmp_path / "mega.csv", f"s,rad,{cell}")
    with pytest.raises(DataError) as ei:
        if stream:
            TraceStream(p, _mapping(unit), required=["theta_m", "torque_m"])
        else:
            load_trace(p, _mapping(unit), required=["theta_m", "torque_m"])
    msg = str(ei.value)
    assert "\n" not in msg and msg.startswith(f"{p}, column 'cur': "), msg
    assert msg.endswith(
        f"the file's units row says {cell!r}: M is mega (10^6 A; milli is a lower-case m, a unit's case"
        f" matters), but the column would be read in {unit!r}; drivelash reads no mega unit — if the"
        " column is in 'mA', write that in the units row"
    ), msg


def test_a_milliamps_units_row_is_read(tmp_path):
    """Negative control: the units row says what the mapping reads."""
    p, tq = _csv(tmp_path / "milli.csv", "s,rad,mA")
    tr = load_trace(p, _mapping(), required=["theta_m", "torque_m"])
    assert np.max(np.abs(tr["torque_m"] - tq)) < 1e-8


def test_the_unit_advice_names_the_torque_constant_too(tmp_path):
    p, _ = _csv(tmp_path / "nounit.csv", "s,rad,mA")
    with pytest.raises(DataError) as ei:
        load_trace(p, {"t": "t", "theta_m": "theta_m", "cur": "torque_m"}, required=["torque_m"])
    msg = str(ei.value)
    assert "\n" not in msg and f"{p}, column 'cur'" in msg, msg
    assert msg.endswith(
        "the file's units row says 'mA', but the column would be read in 'N·m'; set unit = 'mA' and"
        " torque_constant (N·m/A, or N/A for a force; per ampere even for a column in mA) in [columns.cur]"
    ), msg
    # an unmapped column read under its Trace name: the same advice
    p, _ = _csv(tmp_path / "passthrough.csv", "s,rad,mA", current="torque_m")
    with pytest.raises(DataError) as ei:
        load_trace(p, required=["torque_m"])
    assert str(ei.value).endswith(
        "map it in [columns.torque_m] with unit = 'mA' and torque_constant (N·m/A, or N/A for a force;"
        " per ampere even for a column in mA)"
    ), str(ei.value)
    # negative control: a torque constant already mapped is not asked for again
    p, _ = _csv(tmp_path / "amps.csv", "s,rad,A")
    with pytest.raises(DataError) as ei:
        load_trace(p, _mapping("mA"), required=["torque_m"])
    assert str(ei.value).endswith("set unit = 'A' in [columns.cur]"), str(ei.value)


def test_the_readme_says_the_torque_constant_is_per_ampere():
    text = " ".join(README.read_text(encoding="utf-8").split())
    assert "`torque_constant` is in N·m/A (N/A for a force) even when the column is in mA" in text
