"""IDIM-LS and the disturbance observer on the measured EMPS data (acceptance of issue 4).

Reference values: Janot, Gautier, Brunot (2019), EMPS benchmark — IDIM-LS on DATA_EMPS.mat:
M = 95.1089 kg, F_v = 203.5034 N·s/m, F_c = 20.3935 N, offset = −3.1648 N, relative force
error 4.08 %; cross-test on DATA_EMPS_PULSES.mat 5.98 %.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from drivelash.estimation.identify import cross_test, identify, observe_disturbance
from drivelash.io import load_config, load_trace
from drivelash.io.config import loads_config
from identify.helpers import EMPS_CONFIG, emps_file

PUBLISHED = {"M": 95.1089, "F_v": 203.5034, "F_c": 20.3935, "offset": -3.1648}


@pytest.fixture(scope="module")
def cfg():
    return load_config(EMPS_CONFIG)


@pytest.fixture(scope="module")
def emps(cfg):
    return load_trace(emps_file("DATA_EMPS.mat"), cfg)


@pytest.fixture(scope="module")
def pulses(cfg):
    return load_trace(emps_file("DATA_EMPS_PULSES.mat"), cfg)


@pytest.fixture(scope="module")
def result(emps, cfg):
    return identify(emps, cfg.identification)


def test_parameters_match_published_idim_ls(result):
    """M, F_v, F_c within 2 % and the offset within 0.5 N of the published estimates."""
    for name in ("M", "F_v", "F_c"):
        assert result[name] == pytest.approx(PUBLISHED[name], rel=0.02), name
    assert abs(result["offset"] - PUBLISHED["offset"]) < 0.5


def test_standard_deviations_reported_and_plausible(result):
    """σ̂√diag((WᵀW)⁻¹): positive, and small relative to the estimates on 2 475 decimated rows
    (the published relative std devs are all below 2 %). Session 31 (C1): that white-residual
    std is ``std_ols`` now — ``std`` is the Newey–West one, 2.3–3.9× wider on these rows."""
    rel = result.std_ols / np.abs(result.theta)
    assert np.all(result.std_ols > 0) and np.all(result.std > result.std_ols)
    assert np.all(rel < 0.02), rel
    assert result.n_rows == pytest.approx(24841 / 10, rel=0.01)


def test_readme_figures(result):
    """The README's EMPS sentence, at the digits it quotes: "M = 95.11 ± 0.24 kg, F_v = 203.4 ±
    4.5 N·s/m, F_c = 20.41 ± 0.35 N, offset −3.17 N" (± one Newey–West std, session 31), relative
    force error 4.04 %."""
    sd = dict(zip(result.names, result.std, strict=True))
    assert f"{result['M']:.2f} {sd['M']:.2f}" == "95.11 0.24"
    assert f"{result['F_v']:.1f} {sd['F_v']:.1f}" == "203.4 4.5"
    assert f"{result['F_c']:.2f} {sd['F_c']:.2f}" == "20.41 0.35"
    assert f"{result['offset']:.2f}" == "-3.17" and f"{100 * result.relative_error:.2f}" == "4.04"


def test_relative_error_close_to_published(result):
    assert result.relative_error == pytest.approx(0.0408, abs=0.005)
    assert result.notes == []  # a rigid axis: no "needs --model two-mass" warning


def test_cross_test_on_pulses_file(result, pulses):
    """Inverse model of DATA_EMPS on DATA_EMPS_PULSES: published 5.98 %, goal ≤ 7 %."""
    ct = cross_test(result, pulses)
    assert ct.relative_error <= 0.07
    assert ct.relative_error == pytest.approx(0.0598, abs=0.005)


def test_pulses_enter_as_control_voltage(cfg):
    """README check: the 0/5 'pulses_N' square wave is added to the control voltage, so the
    recorded vir already contains it — vir jumps by ≈ 5 V (≈ 176 N) at every pulse edge, and
    the inverse-model residual is uncorrelated with the pulses."""
    import scipy.io

    d = scipy.io.loadmat(emps_file("DATA_EMPS_PULSES.mat"))
    vir, pl = d["vir"].ravel(), d["pulses_N"].ravel().astype(float)
    rise = np.flatnonzero(np.diff(pl) > 0) + 1
    fall = np.flatnonzero(np.diff(pl) < 0) + 1
    assert len(rise) >= 20
    jump_up = np.mean(vir[rise] - vir[rise - 1])
    jump_dn = np.mean(vir[fall] - vir[fall - 1])
    assert jump_up == pytest.approx(5.0, rel=0.05) and jump_dn == pytest.approx(-5.0, rel=0.05)
    typical = np.median(np.abs(np.diff(vir)))
    assert typical < 0.05  # an ordinary sample-to-sample change is 100× smaller


@pytest.fixture(scope="module")
def observed(emps, result):
    return observe_disturbance(emps, J=result["M"], beta=result["F_v"])


def test_observer_matches_identified_coulomb_plus_offset(observed, result):
    """Mean STSMO disturbance over constant-velocity stretches vs F_c·sign(q̇) + offset: within 15 %."""
    fwd = result["F_c"] + result["offset"]
    bwd = -result["F_c"] + result["offset"]
    assert observed.constant_velocity.sum() > 5000
    assert observed.mean_positive == pytest.approx(fwd, rel=0.15)
    assert observed.mean_negative == pytest.approx(bwd, rel=0.15)


def test_observer_sees_pulses_removed_from_the_force(cfg, result):
    """If the pulse voltage is taken out of the measured force (force = gtau·(vir − pulses)), the
    pulses become an unmeasured input and the observer must find them: the disturbance changes
    by ≈ −gtau·5 V ≈ −176 N while a pulse is on (within 15 %)."""
    from drivelash.io.config import ColumnMap

    cm = dict(cfg.columns)
    cm["pulses_N"] = ColumnMap(column="pulse_V", unit="1")
    tr = load_trace(emps_file("DATA_EMPS_PULSES.mat"), cm)
    gtau = tr.meta["scalars"]["gtau"]
    tr = tr.with_columns({"torque_m": tr["torque_m"] - gtau * tr["pulse_V"]})
    est = observe_disturbance(tr, J=result["M"], beta=result["F_v"])
    on = tr["pulse_V"] > 2.5
    # compare each "on" sample with the friction model, which knows nothing of the pulses
    model = result["F_c"] * np.sign(est.velocity) + result["offset"]
    settled = on & np.roll(on, 50) & est.constant_velocity  # 50 ms after the edge
    step = np.mean(est.disturbance[settled] - model[settled])
    assert step == pytest.approx(-5.0 * gtau, rel=0.15)


def test_cli_identify_writes_fragment_json_and_report(tmp_path):
    from drivelash.commands.data import run_identify

    frag, js, rep = tmp_path / "dt.toml", tmp_path / "id.json", tmp_path / "id.html"
    summary = run_identify(
        emps_file("DATA_EMPS.mat"),
        EMPS_CONFIG,
        json_out=js,
        out=frag,
        report=rep,
        cross=emps_file("DATA_EMPS_PULSES.mat"),
        quiet=True,
    )
    got = loads_config(frag.read_text())
    assert got.drivetrain.J_m == pytest.approx(PUBLISHED["M"], rel=0.02)
    assert got.drivetrain.beta_m == pytest.approx(PUBLISHED["F_v"], rel=0.02)
    assert got.drivetrain.T_Cm == pytest.approx(PUBLISHED["F_c"], rel=0.02)
    data = json.loads(js.read_text())
    assert data.pop("generator").startswith("drivelash ")  # the write_json signature
    assert data == json.loads(json.dumps(summary, default=float))
    assert set(data["parameters"]) == {"M", "F_v", "F_c", "offset"}
    assert all(p["std"] > 0 for p in data["parameters"].values())
    assert data["cross_test"]["relative_error"] <= 0.07
    obs = data["observer"]  # the observer runs with the identified M, F_v and is plotted
    assert obs["mean_disturbance_forward"] == pytest.approx(obs["identified_forward"], rel=0.15)
    assert obs["mean_disturbance_backward"] == pytest.approx(obs["identified_backward"], rel=0.15)
    html = rep.read_text()
    assert 'id="fig-observer"' in html
    assert html.count("data:image/png;base64,") >= 3 and "http" not in html.lower().replace("http-equiv", "")


def test_cli_observe_uses_identified_fragment(tmp_path, result):
    from drivelash.commands.data import run_identify, run_observe

    frag = tmp_path / "dt.toml"
    run_identify(emps_file("DATA_EMPS.mat"), EMPS_CONFIG, out=frag, quiet=True)
    out = tmp_path / "dist.parquet"
    summary = run_observe(
        emps_file("DATA_EMPS.mat"),
        EMPS_CONFIG,
        drivetrain=frag,
        out=out,
        report=tmp_path / "o.html",
        quiet=True,
    )
    fwd = result["F_c"] + result["offset"]
    assert summary["mean_disturbance_forward"] == pytest.approx(fwd, rel=0.15)
    back = load_trace(out)
    assert set(back.names) == {"t", "velocity", "disturbance"}


def test_pulses_example_config_maps_the_pulse_column():
    from identify.helpers import REPO

    cfg = load_config(REPO / "examples" / "emps_pulses.toml")
    tr = load_trace(emps_file("DATA_EMPS_PULSES.mat"), cfg)
    assert set(np.unique(tr["pulse_V"])) == {0.0, 5.0}
    first_rise = tr["t"][np.flatnonzero(np.diff(tr["pulse_V"]) > 0)[0] + 1]
    assert first_rise == pytest.approx(0.343, abs=0.002)  # as the data README states


def test_observer_figure_title_prints_its_four_forces_alike(emps, result, observed, monkeypatch):
    """The observer figure's title printed ``.3g``: "17 / −24.2 N … vs 17.2 / −23.6" — one value
    without its decimal (session 17's report audit, left then as cosmetic). The four forces of one
    quantity now share one number of decimals (three significant digits of the largest)."""
    import re

    from matplotlib.axes import Axes

    from drivelash.report import render_identify_report

    titles: list[str] = []
    real = Axes.set_title
    monkeypatch.setattr(
        Axes, "set_title", lambda self, label, *a, **k: (titles.append(label), real(self, label, *a, **k))[1]
    )
    render_identify_report(emps, result, observer=observed)
    (title,) = [t for t in titles if t.startswith("Observer:")]
    values = re.findall(r"−?-?\d+(?:\.\d+)?", title)
    assert len(values) == 4, title
    assert {len(v.split(".")[1]) if "." in v else 0 for v in values} == {1}, title
