"""Load-side parameters when K_S is not determined, and intervals spanning orders of magnitude
beyond their value, are "not determined" and never written (B3).

Reference: the tester's user config for KUKA axis 1 with the recorded velocities mapped (they
lag the positions by one 4 ms sample); the authors' link-side inertia is nowhere near 3e8 kg·m².
"""

from __future__ import annotations

import math

import tomli_w

from drivelash.estimation.identify_result import ParameterEstimate
from drivelash.estimation.identify_two_mass import LOAD_SIDE, SPAN_LIMIT, meaningless_intervals
from realdata import shared_data


def _k1(N: float) -> dict:
    """The tester's k1.toml: N, motor position × N, both velocities and the motor torque mapped."""
    return {
        "drivetrain": {"N": N},
        "columns": {
            "rec.time_cont": {"column": "t", "unit": "s"},
            "rec.act_pos_mot_deg(1,:)": {"column": "theta_m", "unit": "deg", "scale": N},
            "rec.act_pos_se_deg(1,:)": {"column": "theta_l", "unit": "deg"},
            "rec.act_vel_mot_deg_per_s(1,:)": {"column": "omega_m", "unit": "deg/s", "scale": N},
            "rec.act_vel_se_deg_per_s(1,:)": {"column": "omega_l", "unit": "deg/s"},
            "rec.act_torque_abs_nm(1,:)": {"column": "torque_m", "unit": "N·m"},
        },
    }


def test_kuka_own_config_writes_no_load_side_values(tmp_path, capsys):
    import json

    from cli_runner import run_in_process

    rec = shared_data("kuka-kr300", "rec_B.mat")
    (tmp_path / "k1.toml").write_text(tomli_w.dumps(_k1(256.86)))
    code, _, err = run_in_process(
        ["identify", str(rec), "-c", str(tmp_path / "k1.toml"), "--out", str(tmp_path / "o.toml"),
         "--json", str(tmp_path / "o.json")],
        capsys,
    )  # fmt: skip
    assert code == 0, err
    js = json.loads((tmp_path / "o.json").read_text())
    par = js["parameters"]
    assert par["K_S"]["identifiable"] is False
    for n in LOAD_SIDE:  # was: J_l = 3.07e8 kg·m² ± 2.1e13, T_Cl = 3.76e6 N·m ± 2.6e11, written
        assert par[n]["identifiable"] is False, (n, par[n])
        assert "K_S is not determined" in par[n]["reason"]
    import tomllib

    written = tomllib.loads((tmp_path / "o.toml").read_text())["drivetrain"]
    assert not set(LOAD_SIDE) & set(written), written
    # nothing the tool writes as a drive-train value has an interval beyond SPAN_LIMIT × its value
    for n in written:
        if n == "N":
            continue
        lo, hi = par[n]["ci95"]
        assert 0.5 * (hi - lo) <= SPAN_LIMIT * abs(par[n]["value"]), (n, par[n])


def _p(name, v, s):
    return ParameterEstimate.normal(name, v, s)


def test_rules_on_hand_made_estimates():
    """The rules alone (numbers by hand); negative controls keep a determined K_S's load side
    and a weakly determined friction (interval reaching 0 within 100× its value)."""
    from types import SimpleNamespace

    import numpy as np

    data = SimpleNamespace(dth=np.array([-0.1, 0.1]), wl=np.array([0.0, 1.0]))
    ok = {
        "K_S": _p("K_S", 32.9, 0.7),
        "J_l": _p("J_l", 8.3e-4, 1e-5),
        "T_Cl": _p("T_Cl", 0.023, 0.02),  # reaches 0, 1.7× its value: weakly determined, kept
        "beta_l": _p("beta_l", 1.6e-3, 1e-4),
        "D_S": _p("D_S", 0.05, 0.01),
    }
    params = dict(ok)
    assert meaningless_intervals(params, data) == []
    assert all(params[n].identifiable for n in ok)
    # K_S reaching 0: the load side goes with it
    params = dict(ok, K_S=_p("K_S", 5.0, 10.0))
    out = {n for n, _, _ in meaningless_intervals(params, data)}
    assert out == {"K_S", *LOAD_SIDE}
    # K_S already withheld for another reason (too few gap crossings): the load side stays
    params = dict(ok, K_S=ParameterEstimate.unknown("K_S", "not determined: the gap was crossed only 1 time"))
    assert meaningless_intervals(params, data) == []
    # a friction 3.8e6 ± 1.3e11 with K_S determined: beyond SPAN_LIMIT
    params = dict(ok, T_Cl=_p("T_Cl", 3.76e6, 1.34e11))
    out = {n for n, _, _ in meaningless_intervals(params, data)}
    assert out == {"T_Cl"} and not params["T_Cl"].identifiable and math.isnan(params["T_Cl"].value)
    # just inside the limit: kept
    params = dict(ok, T_Cl=_p("T_Cl", 1.0, 0.99 * SPAN_LIMIT / 1.959963984540054))
    assert meaningless_intervals(params, data) == []


def test_kuka_axis2_delta_interval_reaching_below_0_is_a_bound(tmp_path, capsys):
    """B13: KUKA rec_B axis 2 (gravity axis) with the user's config wrote δ = 0.039 mrad
    [−0.053, 0.130] as "identifiable" and δ1 = −0.041 mrad into [backlash]. A δ whose interval
    reaches below 0 is an upper bound (the rule axis 1 gets when δ̂ < 0), nothing in [backlash]."""
    import json
    import tomllib

    from cli_runner import run_in_process

    rec = shared_data("kuka-kr300", "rec_B.mat")
    N = 267.43
    cfg = _k1(N)
    cfg["columns"] = {k.replace("(1,:)", "(2,:)"): v for k, v in cfg["columns"].items()}
    (tmp_path / "k2.toml").write_text(tomli_w.dumps(cfg))
    code, _, err = run_in_process(
        ["identify", str(rec), "-c", str(tmp_path / "k2.toml"), "--out", str(tmp_path / "o.toml"),
         "--json", str(tmp_path / "o.json")],
        capsys,
    )  # fmt: skip
    assert code == 0, err
    par = json.loads((tmp_path / "o.json").read_text())["parameters"]
    d = par["delta"]
    assert d["identifiable"] is False, d
    assert d["reason"].startswith("backlash below what the recording resolves: δ ≤ ")
    assert d["ci95"][0] == 0.0 and 0.0 < d["ci95"][1] < 1e-3
    assert par["delta1"]["identifiable"] is False
    assert "backlash" not in tomllib.loads((tmp_path / "o.toml").read_text())
