"""``te import`` of a CNC's current trace in milliamps (tester H, TH13 a).

``unit = "mA"`` with ``torque_constant`` in ``[columns]`` was refused as an unknown unit; now the
campaign imports with the same torques as the one recorded in A, and milliamps declared as A are
named in the torque-growth error.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from drivelash.te.protocol.campaign import load_campaign

from .synth import standard_runs, write_axis
from .test_import_cli import SHORT, _invoke, _run

RUNS = [dataclasses.replace(r, **SHORT) for r in standard_runs(loads=(0.0, 1500.0, 3000.0))]


def test_a_current_in_milliamps_imports_like_amperes(tmp_path):
    camps = {}
    for unit in ("A", "mA"):
        axis = write_axis(tmp_path / unit, RUNS, current_unit=unit)
        assert f'unit = "{unit}"' in axis.read_text()
        r = _invoke("te", "import", str(axis), "-o", str(tmp_path / f"camp_{unit}"))
        assert r.exit_code == 0, r.output
        assert "0 warning(s), no error" in r.output
        camps[unit] = load_campaign(tmp_path / f"camp_{unit}")
    for ra, rm in zip(camps["A"].runs, camps["mA"].runs, strict=True):
        ta, tm = ra.trace()["torque_m"], rm.trace()["torque_m"]
        assert np.max(np.abs(ta - tm)) <= 1e-9 * np.max(np.abs(ta)), ra.name


@pytest.mark.parametrize(
    ("written", "declared", "said"),
    [
        ("mA", "A", 'torque_m is 1000× too large (a current in mA declared as unit = "A"'),
        # the other way round (the message used to say "1000× too small (mA read as A", which
        # makes a torque 1000× too large)
        ("A", "mA", 'torque_m is 1000× too small (a current in A declared as unit = "mA"'),
    ],
)
def test_a_current_unit_slip_is_named(tmp_path, written, declared, said):
    axis = write_axis(tmp_path / "rec", RUNS, current_unit=written, declared=declared)
    r = _run("te", "import", str(axis), "-o", str(tmp_path / "camp"))
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert said in r.stderr, r.stderr
    assert not (tmp_path / "camp").exists()
