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
    """A linear axis moving ±0.066 m (× ``scale`` in position) at 0.25 Hz, 1 kHz.

    Positions and velocities × ``scale``, J and β ÷ ``scale``, the force unchanged: the same
    physics in other units (the disturbance in N must not change)."""
    t = np.arange(int(duration / T_S)) * T_S
    q = 0.06 * np.sin(2 * np.pi * 0.25 * t) + 0.006 * np.sin(2 * np.pi * 0.75 * t)  # max |q̇| 0.12 m/s
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


# ----------------------------------------------------------------------------------------- C12
@pytest.mark.parametrize("scale", [1e-3, 100.0, 1000.0])
def test_default_gains_follow_the_units(scale):
    """The same axis in other units (positions × s, J and β ÷ s, force unchanged): the same d̂ in N.
    Before, ρ = 20 was absolute: EMPS in motor rad (× 1000) gave 0.97 / −5.14 N for 17.0 / −24.2."""
    ref = observe_disturbance(rigid_axis(), J=J, beta=BETA)
    assert ref.mean_positive == pytest.approx(F_C + OFFSET, rel=0.05)  # the truth
    got = observe_disturbance(rigid_axis(scale), J=J / scale, beta=BETA / scale)
    assert got.mean_positive == pytest.approx(ref.mean_positive, rel=1e-6)
    assert got.mean_negative == pytest.approx(ref.mean_negative, rel=1e-6)
    assert got.k2 == pytest.approx(ref.k2 * scale, rel=1e-12)


def test_given_gains_stay_as_given():
    """Negative control: [estimator] k1/k2 (the API's k1, k2) are used as they are."""
    got = observe_disturbance(rigid_axis(1000.0), J=J / 1000, beta=BETA / 1000, k1=6.0, k2=20.0)
    assert (got.k1, got.k2) == (6.0, 20.0)


def test_emps_keeps_its_gains_and_figures():
    """EMPS in m (README, docs/assumptions.md "Observer gains"): ρ = 20 exactly, d̂ 17.00 / −24.19 N;
    the same recording as motor rad (× 1000) now gives the same figures."""
    from drivelash.io import load_trace
    from identify.helpers import EMPS_CONFIG, emps_file

    tr = load_trace(emps_file("DATA_EMPS.mat"), EMPS_CONFIG)
    M, F_v = 95.11323491247255, 203.37028053902424  # identify --model rigid on this file
    r = observe_disturbance(tr, J=M, beta=F_v)
    assert (r.k1, r.k2) == (1.5 * math.sqrt(20.0), 1.1 * 20.0)
    assert r.mean_positive == pytest.approx(17.003, abs=5e-4)
    assert r.mean_negative == pytest.approx(-24.193, abs=5e-4)
    motor = Trace({"t": tr["t"], "theta_m": 1000 * tr["theta_m"], "torque_m": tr["torque_m"]})
    m = observe_disturbance(motor, J=M / 1000, beta=F_v / 1000)
    assert m.mean_positive == pytest.approx(r.mean_positive, rel=1e-6)  # was 0.971
    assert m.mean_negative == pytest.approx(r.mean_negative, rel=1e-6)  # was -5.138


# ----------------------------------------------------------------------------------------- C10
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_stsmo_refuses_non_finite_input_state_unchanged(bad):
    from drivelash.errors import DataError
    from drivelash.estimation.stsmo import STSMOParams, SuperTwistingObserver

    rng = np.random.default_rng(0)
    w, a = np.cumsum(rng.normal(0, 0.01, 2000)), rng.normal(0, 1, 2000)
    obs = SuperTwistingObserver(STSMOParams.from_rho(20.0, 1e-3))
    obs.run(w[:1000], a[:1000])
    before = obs.state.copy()
    ww = w[1000:].copy()
    ww[5] = bad
    with pytest.raises(DataError, match=r"sample 5 \(0-based in this call\).*omega_meas must be finite") as e:
        obs.run(ww, a[1000:])
    assert "\n" not in str(e.value)
    aa = a[1000:].copy()
    aa[7] = bad
    with pytest.raises(DataError, match=r"sample 7 .*known_accel must be finite"):
        obs.run(w[1000:], aa)
    with pytest.raises(DataError, match="omega_meas must be finite"):
        obs.step(bad)
    with pytest.raises(DataError, match="known_accel must be finite"):
        obs.step(0.1, bad)
    np.testing.assert_array_equal(obs.state, before)
    # negative control: the clean block continues exactly as an uninterrupted run
    om, phi = obs.run(w[1000:], a[1000:])
    ref = SuperTwistingObserver(STSMOParams.from_rho(20.0, 1e-3))
    om_ref, phi_ref = ref.run(w, a)
    np.testing.assert_array_equal(phi, phi_ref[1000:])
    assert np.isfinite(om).all()


# ------------------------------------------------------------------- C2 (observe's own check)
@pytest.mark.parametrize("flip", ["torque_m", "theta_m"])
def test_observe_warns_on_negative_friction(tmp_path, capsys, flip):
    """The force or the position with the other sign: d̂ pushes along the motion (EMPS −55.3 /
    +61.7 N with a correct drive table, exit 0, no word before)."""
    tr = rigid_axis()
    r = observe_disturbance(tr.with_columns({flip: -tr[flip]}), J=J, beta=BETA)
    assert r.mean_positive < r.mean_negative
    assert len(r.warnings) == 1 and "pushes along the motion" in r.warnings[0]
    assert r.as_dict()["warnings"] == list(r.warnings)
    rec, cfg, dtp = _files(tmp_path)
    bad = write_trace(tr.with_columns({flip: -tr[flip]}), tmp_path / "bad.parquet")
    code, _, err = run_in_process(
        ["observe", str(bad), "--config", str(cfg), "--drivetrain", str(dtp)], capsys
    )
    assert code == 0
    w = [ln for ln in err.splitlines() if "warning" in ln]
    assert len(w) == 1 and "scale = -1" in w[0]


def test_no_negative_friction_warning_on_a_correct_axis():
    """Negative control: the correct axis, and a frictionless one (both means ≈ the offset)."""
    r = observe_disturbance(rigid_axis(), J=J, beta=BETA)
    assert r.warnings == () and "warnings" not in r.as_dict()
    tr = rigid_axis()
    v = np.gradient(tr["theta_m"], T_S)
    no_friction = tr.with_columns({"torque_m": tr["torque_m"] - F_C * np.tanh(v / 1e-3)})
    assert observe_disturbance(no_friction, J=J, beta=BETA).warnings == ()
