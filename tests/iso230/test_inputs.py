"""Reading ISO 230-2 measurements: table forms, rotary axes, formats."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from drivelash.errors import DataError, ParameterError
from drivelash.io import Trace
from drivelash.iso230 import approaches_from_rows, evaluate
from drivelash.iso230.inputs import Iso230Params, read_measurement
from drivelash.iso230.synthetic import SyntheticAxis, synthetic_table

AXIS = SyntheticAxis()


def test_commanded_and_measured_positions_give_the_same_result(tmp_path):
    """Table with P_cmd and P_actual in mm (Parquet) = the same table as deviations in µm (CSV)."""
    tb = synthetic_table(AXIS, m=7, n=5, seed=2)
    ref = evaluate(approaches_from_rows(tb["P_target"], tb["run"], tb["direction"], tb["x_dev"]))
    pq = tmp_path / "pos.parquet"
    Trace(
        {
            "t": np.arange(tb["run"].size, dtype=float),  # a row counter; ignored for a table
            "cmd_mm": tb["P_target"] * 1e3,
            "meas_mm": (tb["P_target"] + tb["x_dev"]) * 1e3,
            "j": tb["run"],
            "dir": tb["direction"],
        }
    ).to_parquet(pq)
    mapping = {
        "cmd_mm": {"column": "P_cmd", "unit": "mm"},
        "meas_mm": {"column": "P_actual", "unit": "mm"},
        "j": {"column": "run"},
        "dir": {"column": "direction"},
    }
    m = read_measurement(pq, mapping)
    assert m.kind == "table" and m.unit == "m"
    res = evaluate(m.approaches)
    # positions in mm → m and a difference of two large numbers: agreement to 1e-12 m
    for key in ("A", "B", "B_mean", "E", "M", "R"):
        assert getattr(res, key) == pytest.approx(getattr(ref, key), abs=1e-12), key


def test_rotary_axis_in_degrees_and_arcsec(tmp_path):
    """A rotary table: targets in deg, deviations in arcsec → rad; B of 10″ comes out as 10″."""
    rows = []
    rng = np.random.default_rng(0)
    for P in (0.0, 45.0, 90.0, 180.0, 270.0):
        for j in range(1, 6):
            for d in (1, -1):
                rows.append((P, j, d, -d * 5.0 + rng.normal(0, 0.3)))
    df = pd.DataFrame(rows, columns=["deg", "run", "direction", "err"])
    p = tmp_path / "rot.csv"
    df.to_csv(p, index=False)
    mapping = {
        "deg": {"column": "P_target", "unit": "deg"},
        "run": {"column": "run"},
        "direction": {"column": "direction"},
        "err": {"column": "x_dev", "unit": "arcsec"},
    }
    m = read_measurement(p, mapping)
    assert m.unit == "rad"
    res = evaluate(m.approaches)
    arcsec = math.pi / 648000
    assert -res.B_mean / arcsec == pytest.approx(10.0, abs=4 * res.u_B_mean / arcsec)
    with pytest.raises(DataError, match=r"units mismatch: \[iso230\] axis = 'linear'"):
        read_measurement(p, mapping, params=Iso230Params(axis="linear"))


def test_rotary_angles_read_modulo_360_are_taken_on_the_targets_turn(tmp_path):
    """Found by an exploratory tester (s19 F4): a rotary table whose measured angle is exported
    0…360° (target 0° approached from below reads 359.9998°) was refused as "units mismatch:
    'actual' moves 0.6667× as far as 'target' … wrong unit?". Now those readings are taken on
    the target's turn, with a warning, and the result equals the unwrapped file's. Negative
    control: a measured column in the wrong unit (mdeg declared as deg) is still refused."""
    rng = np.random.default_rng(3)
    rows = []
    for P in np.arange(0.0, 360.0, 45.0):
        for j in range(1, 6):
            for d in (1, -1):
                rows.append((P, j, d, P + (-d * 4.0 + rng.normal(0, 0.5)) / 3600.0))
    df = pd.DataFrame(rows, columns=["target", "run", "direction", "actual"])
    mapping = {
        "target": {"column": "P_target", "unit": "deg"},
        "run": {"column": "run"},
        "direction": {"column": "direction"},
        "actual": {"column": "P_actual", "unit": "deg"},
    }
    plain, wrapped = tmp_path / "plain.csv", tmp_path / "mod360.csv"
    df.to_csv(plain, index=False)
    df.assign(actual=np.mod(df["actual"], 360.0)).to_csv(wrapped, index=False)
    n_wrapped = int((df["actual"] < 0).sum())
    assert n_wrapped > 0  # the approach to 0° from below reads 359.99…°
    ref, got = read_measurement(plain, mapping), read_measurement(wrapped, mapping)
    r0, r1 = evaluate(ref.approaches), evaluate(got.approaches)
    for key in ("A", "B", "B_mean", "E", "M", "R"):
        assert getattr(r1, key) == pytest.approx(getattr(r0, key), rel=1e-9, abs=1e-15), key
    assert any(
        f"{n_wrapped} measured angle(s) differ from their target by a whole turn" in w for w in got.warnings
    )
    assert not any("whole turn" in w for w in ref.warnings)
    df.assign(actual=df["actual"] * 1000.0).to_csv(plain, index=False)
    with pytest.raises(DataError, match="units mismatch"):
        read_measurement(plain, mapping)


def test_nominal_targets_must_match_the_table(tmp_path):
    tb = synthetic_table(AXIS, m=5, n=3, seed=2)
    p = tmp_path / "t.csv"
    pd.DataFrame(tb).to_csv(p, index=False)
    m = read_measurement(p, None, params=Iso230Params(targets=tuple(np.unique(tb["P_target"]))))
    assert m.approaches.m == 5
    with pytest.raises(DataError, match="do not match the 4 nominal"):
        read_measurement(p, None, params=Iso230Params(targets=tuple(np.unique(tb["P_target"])[:4])))


def test_params_are_validated():
    with pytest.raises(ParameterError, match="Iso230Params.input"):
        Iso230Params(input="csv")  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="Iso230Params.coverage"):
        Iso230Params(coverage=1.0)
    with pytest.raises(ParameterError, match="Iso230Params.targets: contains a target twice"):
        Iso230Params(targets=(0.0, 0.0))


def test_rotary_summary_names_its_unit(tmp_path, capsys):
    """The command's summary line ends with the deviation unit in brackets; Rich took ``[arcsec]``
    (and ``[mm]``-like labels) for a style tag and printed nothing (found in session 9). Negative
    control: the same text printed without escaping loses the unit."""
    from rich.console import Console

    from drivelash.commands.iso230 import _print_summary

    rows = [(P, j, d, -d * 5.0) for P in (0.0, 90.0, 180.0) for j in range(1, 6) for d in (1, -1)]
    p = tmp_path / "rot.csv"
    pd.DataFrame(rows, columns=["deg", "run", "direction", "err"]).to_csv(p, index=False)
    mapping = {
        "deg": {"column": "P_target", "unit": "deg"},
        "run": {"column": "run"},
        "direction": {"column": "direction"},
        "err": {"column": "x_dev", "unit": "arcsec"},
    }
    _print_summary(evaluate(read_measurement(p, mapping).approaches), None)
    first = capsys.readouterr().out.splitlines()[0]
    assert first.rstrip().endswith("runs per direction  [arcsec]"), first
    Console().print("runs per direction  [arcsec]")
    assert "[arcsec]" not in capsys.readouterr().out
