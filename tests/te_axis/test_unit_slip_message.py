"""A unit slip in x_T is named against the unit declared in [columns] (finding A3).

Before (session 20, tester A): a file holding µm under ``unit = "mm"`` was refused with
"x_T looks like millimetres read as metres (declare unit 'mm')" — the unit already declared.
"""

from __future__ import annotations

import dataclasses

import pandas as pd
import pytest

from drivelash.errors import DataError
from drivelash.te.protocol.importer import import_campaign

from .synth import standard_runs, write_axis


def _axis(tmp_path, factor: float):
    runs = [dataclasses.replace(r, lo=0.05, hi=0.45) for r in standard_runs(loads=(0.0, 1500.0, 3000.0))]
    axis = write_axis(tmp_path / "rec", runs)
    f = sorted((tmp_path / "rec").glob("run04_*.csv"))[0]
    df = pd.read_csv(f)
    df["pos_scale_mm"] = df["pos_scale_mm"] * factor  # the file's unit, the mapping still "mm"
    df.to_csv(f, index=False, float_format="%.9f")
    return axis, f


@pytest.mark.parametrize(
    ("factor", "needle"),
    [
        (
            1e3,
            "column 'pos_scale_mm' looks like um declared as mm (set unit = 'um' in [columns.pos_scale_mm])",
        ),
    ],
)
def test_the_slip_is_named_against_the_declared_unit(tmp_path, factor, needle):
    axis, f = _axis(tmp_path, factor)
    with pytest.raises(DataError) as err:
        import_campaign(axis, tmp_path / "camp")
    msg = str(err.value)
    assert str(f) in msg and needle in msg and "\n" not in msg, msg
    assert "declare unit 'mm'" not in msg
