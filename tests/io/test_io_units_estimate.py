"""The same recording in deg / rpm / counts (mapped by the config) gives the same `estimate`
result as in SI units."""

from __future__ import annotations

import numpy as np
import pytest
import tomli_w

from drivelash.io import Trace, write_trace
from identify.helpers import simulated_trace

CPR = 2**20  # counts per revolution of the (load) encoder


@pytest.fixture(scope="module")
def recording():
    tr = simulated_trace(2.0)
    # the "true" recording: the load encoder delivers whole counts; SI and unit files hold it exactly
    counts_l = np.round(tr["theta_l"] * CPR / (2 * np.pi))
    return tr, counts_l


def _config(tr, columns: dict) -> dict:
    return {
        "drivetrain": dict(tr.meta["estimator_drivetrain"]),
        "backlash": {"delta1": tr.meta["estimator_backlash"]["delta1"]},
        "columns": columns,
    }


def test_units_mapped_by_config_give_the_same_estimate(tmp_path, recording):
    from drivelash.commands.estimate import run_estimate

    tr, counts_l = recording
    theta_l_si = counts_l * (2 * np.pi / CPR)
    si = Trace(
        {
            "t": tr["t"],
            "theta_m": tr["theta_m"],
            "omega_m": tr["omega_m"],
            "theta_l": theta_l_si,
            "omega_l": tr["omega_l"],
            "torque_m": tr["torque_m"],
        }
    )
    odd = Trace(
        {
            "t": tr["t"] * 1e3,  # milliseconds
            "motor_deg": np.degrees(tr["theta_m"]),
            "motor_rpm": tr["omega_m"] * 60 / (2 * np.pi),
            "load_counts": counts_l,
            "load_degs": np.degrees(tr["omega_l"]),
            "current_A": tr["torque_m"] / 0.25,
        }
    )
    write_trace(odd, tmp_path / "odd.parquet")
    write_trace(si, tmp_path / "si.csv")
    si_cfg = _config(tr, {n: {"column": n, "unit": u} for n, u in [
        ("t", "s"), ("theta_m", "rad"), ("omega_m", "rad/s"), ("theta_l", "rad"), ("omega_l", "rad/s"),
        ("torque_m", "N·m")]})  # fmt: skip
    odd_cfg = _config(
        tr,
        {
            "t": {"column": "t", "unit": "ms"},
            "motor_deg": {"column": "theta_m", "unit": "deg"},
            "motor_rpm": {"column": "omega_m", "unit": "rpm"},
            "load_counts": {"column": "theta_l", "unit": "counts", "counts_per_rev": CPR},
            "load_degs": {"column": "omega_l", "unit": "deg/s"},
            "current_A": {"column": "torque_m", "unit": "A", "torque_constant": 0.25},
        },
    )
    (tmp_path / "si.toml").write_text(tomli_w.dumps(si_cfg))
    (tmp_path / "odd.toml").write_text(tomli_w.dumps(odd_cfg))
    a = run_estimate(tmp_path / "si.csv", tmp_path / "si.toml", quiet=True)
    b = run_estimate(tmp_path / "odd.parquet", tmp_path / "odd.toml", quiet=True)
    # unit conversions differ from SI by a few ulp; the estimate must agree far below the
    # estimator's own resolution (its convergence band is ~mrad)
    assert b["delta"] == pytest.approx(a["delta"], rel=1e-9)
    assert b["excitation_ok"] == a["excitation_ok"]
    assert b["T_s"] == pytest.approx(a["T_s"], rel=1e-12)
    if a["convergence_time_s"] is None:
        assert b["convergence_time_s"] is None
    else:
        assert b["convergence_time_s"] == pytest.approx(a["convergence_time_s"], abs=2 * a["T_s"])
