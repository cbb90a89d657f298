"""Session 31 (tester C): the disturbance observer (`observe`, `observe_disturbance`,
:class:`SuperTwistingObserver`).

Reference: a simulated rigid axis J q̈ = u − β q̇ − F_c sign q̇ − offset (the force computed
from a known smooth motion, so the true disturbance is F_c sign q̇ + offset exactly).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from cli_runner import run_in_process
from drivelash.errors import ParameterError
from drivelash.estimation.identify import observe_disturbance
from drivelash.io import Trace, write_trace

J, BETA, F_C, OFFSET = 2.0, 5.0, 3.0, -0.5
T_S = 1e-3


def rigid_axis(scale: float = 1.0, duration: float = 12.0) -> Trace:
    """A linear axis moving ±0.22 m (× ``scale`` in position) at 0.25 Hz, 1 kHz.

    Positions and velocities × ``scale``, J and β ÷ ``scale``, the force unchanged: the same
    physics in other units (the disturbance in N must not change)."""
    t = np.arange(int(duration / T_S)) * T_S
    q = 0.2 * np.sin(2 * np.pi * 0.25 * t) + 0.02 * np.sin(2 * np.pi * 0.75 * t)
    v = np.gradient(q, T_S)
    a = np.gradient(v, T_S)
    u = J * a + BETA * v + F_C * np.tanh(v / 1e-3) + OFFSET
    return Trace({"t": t, "theta_m": scale * q, "torque_m": u}, meta={"axis": "prismatic"})


CONFIG = """[columns.t]
column = "t"
unit = "s"
[columns.theta_m]
column = "theta_m"
unit = "{unit}"
[columns.torque_m]
column = "torque_m"
unit = "{force}"
"""


def _files(tmp: Path, scale: float = 1.0, unit: str = "m", dt: str | None = None) -> tuple[Path, Path, Path]:
    tr = rigid_axis(scale)
    rec = write_trace(Trace({c: tr[c] for c in tr.columns}), tmp / "rec.parquet")
    cfg = tmp / "cfg.toml"
    cfg.write_text(CONFIG.format(unit=unit, force="N" if unit == "m" else "N·m"))
    dtp = tmp / "dt.toml"
    rigid = f"[drivetrain]\nJ_m = {J / scale!r}\nbeta_m = {BETA / scale!r}\nT_Cm = {F_C}\n"
    dtp.write_text(dt if dt is not None else rigid)
    return rec, cfg, dtp


# ------------------------------------------------------------------------------------------ C3
@pytest.mark.parametrize(
    ("line", "key", "problem"),
    [
        ("J_m = 2.0\nbeta_m = nan", "beta_m", "must be finite"),
        ("J_m = inf\nbeta_m = 5.0", "J_m", "must be finite"),
        ("J_m = 2.0\nbeta_m = -5.0", "beta_m", "must be >= 0"),
        ("J_m = -2.0\nbeta_m = 5.0", "J_m", "must be > 0"),
    ],
)
def test_observe_drivetrain_checked_like_estimate(tmp_path, capsys, line, key, problem):
    rec, cfg, dtp = _files(tmp_path, dt=f"[drivetrain]\n{line}\nT_Cm = 3.0\n")
    code, out, err = run_in_process(
        ["observe", str(rec), "--config", str(cfg), "--drivetrain", str(dtp)], capsys
    )
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "dt.toml: table [drivetrain]" in lines[0] and f"key '{key}'" in lines[0] and problem in lines[0]
    assert "nan" not in out


def test_observe_rigid_drivetrain_still_accepted(tmp_path, capsys):
    """Negative control: a rigid table (J_m, beta_m, T_Cm only, as `identify --model rigid` writes)."""
    rec, cfg, dtp = _files(tmp_path)
    js = tmp_path / "o.json"
    code, _, err = run_in_process(
        ["observe", str(rec), "--config", str(cfg), "--drivetrain", str(dtp), "--json", str(js)], capsys
    )
    assert code == 0, err
    s = json.loads(js.read_text())
    assert s["mean_disturbance_forward"] == pytest.approx(F_C + OFFSET, rel=0.05)
    assert s["mean_disturbance_backward"] == pytest.approx(-F_C + OFFSET, rel=0.05)


@pytest.mark.parametrize(
    ("kw", "name"),
    [
        ({"J": math.inf, "beta": BETA}, "J"),
        ({"J": math.nan, "beta": BETA}, "J"),
        ({"J": J, "beta": math.nan}, "beta"),
        ({"J": J, "beta": math.inf}, "beta"),
        ({"J": J, "beta": -BETA}, "beta"),
    ],
)
def test_observe_disturbance_requires_finite_J_and_beta(kw, name):
    with pytest.raises(ParameterError, match=rf"observer\.{name}: must be finite"):
        observe_disturbance(rigid_axis(duration=2.0), **kw)


def test_observe_disturbance_beta_zero_allowed():
    r = observe_disturbance(rigid_axis(), J=J, beta=0.0)  # the viscous force then counts as disturbance
    assert np.isfinite(r.mean_positive) and np.isfinite(r.mean_negative)
