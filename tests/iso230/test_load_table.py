"""``drivelash.io.load_table``: the readers and [columns] mapping for tables that are not time series."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drivelash.errors import DataError
from drivelash.io.load import load_table

MAP = {
    "Target [mm]": {"column": "P_target", "unit": "mm"},
    "Run": {"column": "run"},
    "Dir": {"column": "direction"},
    "Error [um]": {"column": "x_dev", "unit": "um"},
}


def _write(tmp_path, text: str):
    p = tmp_path / "iso.csv"
    p.write_text(text, encoding="utf-8")
    return p


def test_units_converted_to_si(tmp_path):
    p = _write(tmp_path, "Target [mm],Run,Dir,Error [um]\n0,1,1,2.5\n100,1,-1,-3\n")
    t = load_table(p, MAP, required=("P_target", "run", "direction", "x_dev"))
    np.testing.assert_array_equal(t.columns["P_target"], [0.0, 0.1])
    np.testing.assert_allclose(t.columns["x_dev"], [2.5e-6, -3e-6], rtol=1e-15)
    assert t.kinds["P_target"] == "length" and t.units["x_dev"] == "um"
    assert t.origin["x_dev"] == "Error [um]"


def test_arcsec_is_an_angle(tmp_path):
    p = _write(tmp_path, "a,e\n90,3600\n180,-1\n")
    t = load_table(
        p, {"a": {"column": "P_target", "unit": "deg"}, "e": {"column": "x_dev", "unit": "arcsec"}}
    )
    assert t.columns["x_dev"][0] == pytest.approx(math.radians(1.0), rel=1e-15)
    assert t.kinds["x_dev"] == "angle"


def test_missing_column_and_nan_are_one_line(tmp_path):
    p = _write(tmp_path, "Target [mm],Run,Dir\n0,1,1\n")
    with pytest.raises(DataError, match=r"iso\.csv, column 'Error \[um\]': missing required column"):
        load_table(p, MAP)
    p = _write(tmp_path, "Target [mm],Run,Dir,Error [um]\n0,1,1,nan\n")
    with pytest.raises(DataError, match=r"column 'Error \[um\]', line 2: NaN") as e:
        load_table(p, MAP)
    assert "\n" not in str(e.value)


def test_unit_that_does_not_fit(tmp_path):
    p = _write(tmp_path, "Target [mm],Run,Dir,Error [um]\n0,1,1,2\n")
    bad = dict(MAP, Dir={"column": "direction", "unit": "mm"})
    with pytest.raises(DataError, match="unit 'mm' .length. does not fit Trace column 'direction'"):
        load_table(p, bad)
