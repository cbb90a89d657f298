"""The runtime table's step and ``TEModel.predict``'s inputs (finding A12, session 20 tester A).

The conftest's model (n_t 20, d_p 84.882 mm: tooth pitch 13.33 mm; low-pass at 3 × the mesh
frequency, so the model holds wavelengths down to pitch/3 and a table needs a step of at most
pitch/6 = 2.22 mm). Before: ``te export --dx-mm`` took any step silently, ``build_table``
with a step in mm given as m built a 2-node table, ``predict`` answered NaN for NaN and a
plausible TE for a position in mm.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from cli_runner import run_in_process
from drivelash.errors import ParameterError
from drivelash.te.runtime.persist import load_model, save_model
from drivelash.te.runtime.table import build_table, mesh_step_limit

from .conftest import GEOM


@pytest.fixture(scope="module")
def model_dir(small_trained, tmp_path_factory):
    return save_model(small_trained, tmp_path_factory.mktemp("guards") / "m")


@pytest.fixture(scope="module")
def model(model_dir):
    return load_model(model_dir)


def test_the_step_limit_is_the_mesh_nyquist_bound(model):
    limit, pitch = mesh_step_limit(model)
    assert pitch == pytest.approx(math.pi * GEOM.d_p / GEOM.n_t, rel=1e-12)  # 13.33 mm, by hand
    assert limit == pytest.approx(pitch / 6, rel=1e-12)


def test_a_step_coarser_than_the_mesh_is_refused_by_te_export(model, model_dir, tmp_path, capsys):
    """--dx-mm 5 (above pitch/6 = 2.22 mm) is refused in one line naming the option and the bound;
    --dx-mm 1 is written (negative control)."""
    out = tmp_path / "t5.csv"
    code, so, se = run_in_process(["te", "export", str(model_dir), "-o", str(out), "--dx-mm", "5"], capsys)
    assert code == 2 and not out.exists()
    line = se.strip()
    assert "\n" not in line and "--dx-mm" in line and "needs <= 2.22 mm" in line, line
    assert "Traceback" not in se
    code, so, se = run_in_process(
        ["te", "export", str(model_dir), "-o", str(tmp_path / "t1.csv"), "--dx-mm", "1"], capsys
    )
    assert code == 0, se


def test_build_table_refuses_a_step_above_one_pitch_and_warns_above_the_bound(model):
    with pytest.raises(ParameterError) as err:
        build_table(model, 0.0, 0.3, 0.2, 9.0, 10)  # 0.2 m: 0.2 mm meant
    msg = str(err.value)
    assert "dx" in msg and "tooth pitch (13.33 mm)" in msg and "in mm given in m?" in msg, msg
    with pytest.warns(UserWarning, match="needs <= 2.22 mm"):
        build_table(model, 0.0, 0.3, 5e-3, 9.0, 3)
    build_table(model, 0.0, 0.3, 2e-3, 9.0, 3)  # within the bound: no warning (pytest: -W error not set)


def test_predict_refuses_non_finite_input_and_strict_refuses_the_outside(model):
    x = np.linspace(0.01, 0.29, 50)
    with pytest.raises(ParameterError, match="x_T.*value 3 is nan"):
        model.predict(np.where(np.arange(50) == 3, np.nan, x), 1.0, 1)
    with pytest.raises(ParameterError, match="torque.*value 0 is nan"):
        model.predict(x, np.nan, 1)
    # strict: in range the same numbers, bit for bit; outside refused with the range in m and mm
    assert np.array_equal(model.predict(x, 2.0, 1, strict=True), model.predict(x, 2.0, 1))
    with pytest.raises(ParameterError, match=r"200 m is outside the model's valid range \[0, 0.3\] m"):
        model.predict(np.array([200.0]), 1.0, 1, strict=True)  # mm typed for m
    with pytest.raises(
        ParameterError, match=r"500 N·m is outside the model's valid torque range of flank \+1, \[0, 9\] N·m"
    ):
        model.predict(np.array([0.1]), 500.0, 1, strict=True)
