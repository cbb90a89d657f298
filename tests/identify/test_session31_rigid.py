"""Session 31 (tester C): rigid IDIM-LS — one-way recordings (C5), honest intervals (C1),
cross-test warnings (C13), prismatic units and the rigid model's own refusal text (C7)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import drivelash as dl
from drivelash.estimation import identify as _identify
from drivelash.estimation.identify import identify_rigid
from drivelash.io import Trace
from realdata import shared_data

DT = 1e-3
TRUE = {"M": 2.5, "F_v": 0.8, "F_c": 0.6, "offset": -0.15}


def _rigid(q: np.ndarray, rng: np.random.Generator, noise: float = 0.05) -> Trace:
    """τ = M q̈ + F_v q̇ + F_c sign q̇ + offset + white noise for the position ``q`` [rad]."""
    dq = np.gradient(q, DT)
    ddq = np.gradient(dq, DT)
    tau = TRUE["M"] * ddq + TRUE["F_v"] * dq + TRUE["F_c"] * np.sign(dq) + TRUE["offset"]
    t = np.arange(q.size) * DT
    return Trace({"t": t, "theta_m": q, "torque_m": tau + noise * rng.standard_normal(q.size)})


def _one_way(n: int = 20000) -> np.ndarray:
    """Forward only: q̇ = 1 + 0.5 sin(2π 0.7 t) + 0.2 sin(2π 1.9 t) > 0 throughout [rad/s]."""
    t = np.arange(n) * DT
    return (
        t
        - 0.5 / (2 * np.pi * 0.7) * np.cos(2 * np.pi * 0.7 * t)
        - 0.2 / (2 * np.pi * 1.9) * np.cos(2 * np.pi * 1.9 * t)
    )


def _both_ways(n: int = 20000) -> np.ndarray:
    t = np.arange(n) * DT
    return (
        np.sin(2 * np.pi * 0.3 * t) + 0.4 * np.sin(2 * np.pi * 0.71 * t) + 0.08 * np.sin(2 * np.pi * 1.9 * t)
    )


def _cfg(tmp_path, unit: str = "rad", force: str = "N·m") -> str:
    p = tmp_path / "cfg.toml"
    p.write_text(
        f'[columns.t]\ncolumn = "t"\nunit = "s"\n[columns.theta_m]\ncolumn = "theta_m"\nunit = "{unit}"\n'
        f'[columns.torque_m]\ncolumn = "torque_m"\nunit = "{force}"\n'
    )
    return str(p)


def _parquet(tmp_path, trace: Trace, name: str) -> str:
    p = tmp_path / name
    pd.DataFrame({k: trace[k] for k in ("t", "theta_m", "torque_m")}).to_parquet(p)
    return str(p)


# ---------------------------------------------------------------- C5: one direction only
def test_one_way_recording_leaves_coulomb_and_offset_undetermined(rng):
    """Before: F_c = 3.6e15 N ± 44 % (cond 3.8e16) on EMPS 0.5–3.0 s; here F_c and the offset
    are not determined, their sum is stated, M and F_v stay right."""
    r = identify_rigid(_rigid(_one_way(), rng))
    assert set(r.not_determined) == {"F_c", "offset"}
    why = r.not_determined["F_c"]
    assert "the axis moved in one direction only" in why and "not separable" in why
    total = TRUE["F_c"] + TRUE["offset"]
    assert (
        f"their sum F_c + offset is {total:.2f}" in why
        or abs(float(why.split("is ")[1].split(" ")[0]) - total) < 0.01
    )
    assert np.isnan(r.std_of("F_c")) and np.isnan(r.std_of("offset"))
    assert r["M"] == pytest.approx(TRUE["M"], rel=0.01) and r["F_v"] == pytest.approx(TRUE["F_v"], rel=0.02)
    assert r.condition < 1e6
    assert "T_Cm" not in r.drivetrain_values() and set(r.drivetrain_values()) == {"J_m", "beta_m"}
    assert any("moved in one direction only" in n for n in r.notes)
    d = r.as_dict()["parameters"]
    assert d["F_c"]["value"] is None and "not separable" in d["F_c"]["not_determined"]


def test_one_way_backward_states_offset_minus_coulomb(rng):
    r = identify_rigid(_rigid(-_one_way(), rng))
    assert "offset − F_c is" in r.not_determined["offset"] and "(backward;" in r.not_determined["offset"]


def test_one_way_api_marks_them_not_identified_and_writes_no_coulomb(rng):
    tr = _rigid(_one_way(), rng)
    df = pd.DataFrame({k: tr[k] for k in ("t", "theta_m", "torque_m")})
    r = dl.identify_drive(df, model="rigid")
    assert not r["T_Cm"].identifiable and not r["torque_offset"].identifiable
    assert "one direction only" in r["T_Cm"].reason
    assert r["J_m"].identifiable and r["J_m"].covers(TRUE["M"])
    assert "T_Cm" not in r.to_config()["drivetrain"]
    assert r.plausible


def test_one_way_cli_writes_no_coulomb_and_says_why(tmp_path, rng, capsys):
    from drivelash.commands.data import run_identify

    pq = _parquet(tmp_path, _rigid(_one_way(), rng), "fwd.parquet")
    out = tmp_path / "drive.toml"
    summary = run_identify(pq, _cfg(tmp_path), model="rigid", out=out, json_out=tmp_path / "id.json")
    text = out.read_text()
    assert "T_Cm =" not in text and "J_m =" in text and "beta_m =" in text
    assert "F_c not determined" in text and "moved in one direction only" in text
    assert summary["parameters"]["F_c"]["value"] is None
    cap = capsys.readouterr()
    assert "moved in one direction only" in " ".join((cap.out + cap.err).split())


def test_a_short_reversal_is_still_not_enough(rng):
    """A few rows the other way (fewer than REVERSAL_MIN_ROWS): the four-parameter fit keeps
    M and F_v, F_c and the offset are still withheld."""
    q = _one_way()
    n_back = 120  # 0.12 s backward at the end: ~ 12 decimated rows
    v = np.gradient(q, DT)
    v[-n_back:] = -0.8
    q = np.cumsum(v) * DT
    r = identify_rigid(_rigid(q, rng))
    assert 0 < r.options["rows_backward"] < _identify.REVERSAL_MIN_ROWS
    assert set(r.not_determined) == {"F_c", "offset"}
    assert r["M"] == pytest.approx(TRUE["M"], rel=0.02)


def test_both_directions_are_identified_negative_control(rng):
    r = identify_rigid(_rigid(_both_ways(), rng))
    assert r.not_determined == {} and min(r.options["rows_forward"], r.options["rows_backward"]) > 500
    for name, value in TRUE.items():
        assert abs(r[name] - value) < 4 * r.std_of(name) + 1e-3 * abs(value), name
    assert "T_Cm" in r.drivetrain_values() and not r.notes


def test_rigid_refusal_does_not_blame_the_two_mass_model(rng):
    """Force sign flipped (one way, so the Coulomb clause alone is shown negative before the fix
    on some recordings): the causes name the rigid model."""
    tr = _rigid(_both_ways(), rng)
    tr = Trace({"t": tr["t"], "theta_m": tr["theta_m"], "torque_m": -tr["torque_m"]})
    df = pd.DataFrame({k: tr[k] for k in ("t", "theta_m", "torque_m")})
    r = dl.identify_drive(df, model="rigid")
    assert not r.plausible and r.warnings
    assert all("two-mass model" not in w for w in r.warnings)
    assert any("negative motor friction" in w and "the rigid model lacks" in w for w in r.warnings)


# ---------------------------------------------------------------- C1: HAC intervals
def _coloured(n: int, rng: np.random.Generator, rho: float = 0.995) -> np.ndarray:
    """AR(1) noise at the sample rate (time constant 0.2 s: autocorrelated at the 100 Hz rows)."""
    from scipy.signal import lfilter

    return lfilter([np.sqrt(1 - rho * rho)], [1.0, -rho], rng.standard_normal(n))


def test_hac_sandwich_is_newey_west_with_the_two_mass_lag_rule(rng):
    """The streamed sandwich equals statsmodels' S_hac_simple with andrews_bandwidth (the two-mass
    fit's rule) on the same scores, whatever the block sizes."""
    from statsmodels.stats.sandwich_covariance import S_hac_simple

    from drivelash.estimation.identify import andrews_lag, hac_sandwich
    from drivelash.estimation.identify_two_mass import andrews_bandwidth

    n = 3000
    W = np.column_stack(
        [rng.standard_normal(n), _coloured(n, rng, 0.9), np.sign(rng.standard_normal(n)), np.ones(n)]
    )
    y = W @ np.array([1.0, 2.0, 0.5, -0.1]) + _coloured(n, rng, 0.8)
    theta = np.linalg.lstsq(W, y, rcond=None)[0]
    g = W * (y - W @ theta)[:, None]
    L = andrews_bandwidth(g)
    assert L > 3
    x = g - g.mean(0)
    assert andrews_lag(n, (x * x).sum(0), (x[1:] * x[:-1]).sum(0)) == L
    B = np.linalg.inv(W.T @ W)
    ref = B @ S_hac_simple(g, nlags=L) @ B
    A = np.column_stack([W, y])
    cuts = [0, 7, 500, 501, 1800, n]
    cov, lags = hac_sandwich(
        lambda: (A[a:b] for a, b in zip(cuts[:-1], cuts[1:], strict=True)), theta, [0, 1, 2, 3], B
    )
    assert lags == L
    np.testing.assert_allclose(cov, ref, rtol=1e-9, atol=0)


def test_intervals_cover_the_truth_with_autocorrelated_noise(rng):
    """Coloured torque noise: the OLS 95 % interval of F_c covered the truth in about half of the
    runs (12/30); the HAC one in most (24/30; white-noise negative control: HAC ≈ OLS)."""
    q = _both_ways(12000)
    hit_hac = hit_ols = 0
    runs = 30
    for _ in range(runs):
        tr = _rigid(q, rng, noise=0.0)
        tau = tr["torque_m"] + 0.1 * _coloured(q.size, rng)
        r = identify_rigid(Trace({"t": tr["t"], "theta_m": q, "torque_m": tau}))
        i = r.names.index("F_c")
        hit_hac += abs(r["F_c"] - TRUE["F_c"]) < 1.96 * r.std[i]
        hit_ols += abs(r["F_c"] - TRUE["F_c"]) < 1.96 * r.std_ols[i]
    # measured: HAC 24/30, OLS 12/30
    assert hit_hac >= 0.7 * runs and hit_hac - hit_ols >= 0.25 * runs, (hit_hac, hit_ols)
    white = identify_rigid(_rigid(q, rng, noise=0.05))
    assert np.all(white.std / white.std_ols < 1.5) and np.all(white.std / white.std_ols > 0.6)


def test_emps_recordings_of_the_same_axis_agree_within_their_intervals():
    """DATA_EMPS vs DATA_EMPS_PULSES (same axis): |z| of the difference was 5.9 (M), 3.4 (F_v),
    2.6 (F_c) with the OLS std. With HAC F_v, F_c, offset agree (|z| < 2); M still differs by
    1.1 % (z ≈ 3.4, both halves of each recording agree): excitation-dependent model error, which
    no single-recording interval contains (docs/assumptions.md). The estimates are unchanged."""
    from pathlib import Path

    from drivelash.io import load_config

    ex = Path(__file__).resolve().parents[2] / "examples"
    a = dl.identify_drive(shared_data("emps", "DATA_EMPS.mat"), load_config(ex / "emps.toml"), model="rigid")
    b = dl.identify_drive(
        shared_data("emps", "DATA_EMPS_PULSES.mat"), load_config(ex / "emps_pulses.toml"), model="rigid"
    )
    z = _emps_z(a, b)
    for k in ("beta_m", "T_Cm", "torque_offset"):
        assert abs(z[k]) < 2.0, z
    assert z["J_m"] < 5.9 / 1.5, z  # was 5.9 with the OLS std; the rest: test below (known miss)
    # point estimates unchanged by the HAC covariance (session 30 values, the reference Xeon); to
    # 1e-12 relative, not bit-identical: the least-squares solve's last digits follow the CPU's
    # BLAS kernels (session 36's AMD EPYC: J_m 95.113234912475, 2.6e-14 relative)
    assert a["J_m"].value == pytest.approx(95.11323491247255, rel=1e-12)
    assert a["T_Cm"].value == pytest.approx(20.40893356950891, rel=1e-12)
    assert a["J_m"].std / a.source.std_ols[0] > 2.0


def _emps_z(a, b) -> dict[str, float]:
    return {k: (a[k].value - b[k].value) / np.hypot(a[k].std, b[k].std) for k in a.parameters}


@pytest.mark.xfail(
    strict=True,
    reason="known miss: the EMPS mass from DATA_EMPS and DATA_EMPS_PULSES (same axis) differs by "
    "1.1 % (95.11 vs 94.06 kg), z = 3.4 of the HAC intervals (5.9 with the old OLS std); goal: "
    "|z| < 2 like F_v, F_c and the offset; because of an excitation-dependent model error (the "
    "two halves of each recording agree), which no single-recording interval contains",
)
def test_emps_masses_of_the_two_recordings_agree_within_their_intervals():
    from pathlib import Path

    from drivelash.io import load_config

    ex = Path(__file__).resolve().parents[2] / "examples"
    a = dl.identify_drive(shared_data("emps", "DATA_EMPS.mat"), load_config(ex / "emps.toml"), model="rigid")
    b = dl.identify_drive(
        shared_data("emps", "DATA_EMPS_PULSES.mat"), load_config(ex / "emps_pulses.toml"), model="rigid"
    )
    assert abs(_emps_z(a, b)["J_m"]) < 2.0


# ---------------------------------------------------------------- C13: cross-test warnings
def test_cross_test_names_a_flipped_sign_a_unit_and_a_poor_fit(rng):
    """Before: 199.88 % (force sign flipped) and 79 142 % (mm read as m) printed without a word."""
    from drivelash.estimation.identify import cross_test

    q = _both_ways()
    r = identify_rigid(_rigid(q, rng))
    val = _rigid(q[::-1].copy(), rng)
    ok = cross_test(r, val)
    assert ok.relative_error < 0.2 and ok.notes == [] and ok.scale == pytest.approx(1.0, abs=0.05)
    flipped = cross_test(r, Trace({"t": val["t"], "theta_m": val["theta_m"], "torque_m": -val["torque_m"]}))
    assert flipped.relative_error == pytest.approx(2.0, abs=0.1)
    assert len(flipped.notes) == 1 and "sign" in flipped.notes[0] and "likely flipped" in flipped.notes[0]
    mm = cross_test(r, Trace({"t": val["t"], "theta_m": 1e3 * val["theta_m"], "torque_m": val["torque_m"]}))
    assert len(mm.notes) == 1 and "a unit of the validation file" in mm.notes[0]
    other = _rigid(q, rng)  # another axis: twice the inertia and friction
    poor = cross_test(r, Trace({"t": other["t"], "theta_m": q, "torque_m": 2.2 * other["torque_m"]}))
    assert poor.relative_error > 0.2 and "does not describe the validation recording" in poor.notes[0]


def test_cross_test_warning_reaches_the_command(tmp_path, rng, capsys):
    from drivelash.commands.data import run_identify

    q = _both_ways()
    est = _parquet(tmp_path, _rigid(q, rng), "est.parquet")
    v = _rigid(q, rng)
    neg = _parquet(
        tmp_path, Trace({"t": v["t"], "theta_m": v["theta_m"], "torque_m": -v["torque_m"]}), "neg.parquet"
    )
    s = run_identify(est, _cfg(tmp_path), model="rigid", cross=neg, out=tmp_path / "d.toml")
    assert "likely flipped" in s["cross_test"]["notes"][0]
    assert "# warning: the cross-test leaves" in (tmp_path / "d.toml").read_text()
    cap = capsys.readouterr()
    assert "likely flipped" in " ".join((cap.out + cap.err).split())
    ok = _parquet(tmp_path, v, "ok.parquet")
    s = run_identify(est, _cfg(tmp_path), model="rigid", cross=ok, out=tmp_path / "e.toml", force=True)
    text = (tmp_path / "e.toml").read_text()
    assert s["cross_test"]["notes"] == [] and "cross-test leaves" not in text, text


# ---------------------------------------------------------------- C7: units of a prismatic axis
def test_prismatic_refusal_states_the_mass_in_kg(tmp_path, rng):
    """Force sign flipped on a linear axis (m, N): the refusal said 'J_m = … kg·m² < 0'."""
    v = _rigid(_both_ways(), rng)
    neg = _parquet(
        tmp_path, Trace({"t": v["t"], "theta_m": v["theta_m"], "torque_m": -v["torque_m"]}), "n.parquet"
    )
    r = dl.identify_drive(neg, _cfg(tmp_path, unit="m", force="N"), model="rigid")
    assert not r.plausible and r["J_m"].unit == "kg"
    assert any("J_m = " in w and " kg < 0" in w for w in r.warnings) and all(
        "kg·m²" not in w for w in r.warnings
    )
    # negative control: a rotary axis keeps kg·m²
    rot = dl.identify_drive(neg, _cfg(tmp_path), model="rigid")
    assert any("kg·m² < 0" in w for w in rot.warnings)
