"""The notebook API and the commands give the same answers for the same file and configuration.

Exploratory-test findings on ``estimate_backlash`` / ``identify_drive``: ``columns`` ignored with
a Trace, the API's ``method``/``model`` default overriding the configuration, ``--identify``
taking pydantic defaults (friction 0) for configured values, no ``identify=`` in the API, the
KUKA recording refused by ``estimate --identify`` before the identification spoke, missing
velocities reported as a standing recording, CLI hints and file names in the API's errors, the
configuration's ``[sampling]`` dropped by ``columns=``, NaN in "JSON-ready" results, and the
package's cosmetics (``python -m drivelash``, ``dir``, ``repr``).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import drivelash as dl
from drivelash.sim.scenarios import get_scenario
from identify.helpers import REPO, shared_data

BENCH = REPO / "examples" / "drive_bench.toml"
DELTA1 = 0.0525  # δ1 of bench-0C [rad]


@pytest.fixture(scope="module")
def rec(tmp_path_factory) -> tuple[pd.DataFrame, Path]:
    """bench-0C, 6 s at 8 kHz (true δ = 105 mrad, δ1 = 52.5 mrad) as a DataFrame and a Parquet file."""
    run = get_scenario("bench-0C").simulate(duration=6.0, seed=1)
    pq = tmp_path_factory.mktemp("rec") / "run.parquet"
    run.to_parquet(pq)
    return run.to_pandas(), pq


def _cfg(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def _bench_cfg(tmp_path: Path, extra: str = "") -> Path:
    text = BENCH.read_text().replace("delta1 = 0.093", f"delta1 = {DELTA1}")
    assert f"delta1 = {DELTA1}" in text
    return _cfg(tmp_path, "bench.toml", text + extra)


def _json(path: Path) -> dict:
    doc = json.loads(path.read_text())
    doc.pop("generator", None)
    return doc


def _api_doc(est: dl.BacklashEstimate, trace: Path, cfg: Path) -> dict:
    return json.loads(json.dumps({"trace": str(trace), "config": str(cfg), **est.summary}, allow_nan=False))


# ---------------------------------------------------------------- 1. columns with a Trace
def test_columns_with_a_trace_is_refused_and_applied_to_a_frame(rec, tmp_path):
    df, _ = rec
    rev = df.copy()
    for c in ("theta_m", "theta_l", "omega_m", "omega_l"):
        rev[c] = rev[c] / (2 * np.pi)
    m = {c: {"column": c, "unit": u} for c, u in [("theta_m", "rev"), ("theta_l", "rev")]}
    m |= {c: {"column": c, "unit": "rev/s"} for c in ("omega_m", "omega_l")}
    tr = dl.Trace({c: rev[c].to_numpy() for c in rev.columns})
    with pytest.raises(
        dl.ParameterError, match=r"^estimate_backlash\.columns: data is a Trace, already mapped"
    ):
        dl.estimate_backlash(tr, BENCH, DELTA1, columns=m)
    with pytest.raises(dl.ParameterError, match=r"^identify_drive\.columns: data is a Trace"):
        dl.identify_drive(tr, None, N=1.0, columns=m)
    # negative control: the same mapping on the DataFrame converts revolutions (δ̂ ≈ 105 mrad)
    est = dl.estimate_backlash(rev, BENCH, DELTA1, columns=m)
    assert abs(est.delta - 0.105) < 2e-3 and est.converged


# ---------------------------------------------------------------- 2. the configuration decides
def test_method_and_model_defaults_follow_the_configuration_like_the_commands(rec, tmp_path):
    from drivelash.commands.data import run_identify
    from drivelash.commands.estimate import run_estimate

    _, pq = rec
    paper = _cfg(
        tmp_path,
        "paper.toml",
        _bench_cfg(tmp_path).read_text().replace("[estimator]", '[estimator]\nmethod = "paper"'),
    )
    js = tmp_path / "e.json"
    run_estimate(pq, paper, json_out=js, quiet=True)
    cmd = _json(js)
    api = dl.estimate_backlash(pq, paper)
    assert cmd["method"] == api.method == "paper"
    assert _api_doc(api, pq, paper) == cmd  # the same numbers, key for key
    # an explicit argument wins, as --method does (and the laws differ: the check can fail)
    run_estimate(pq, paper, json_out=js, quiet=True, method="default", force=True)
    dflt = dl.estimate_backlash(pq, paper, method="default")
    assert dflt.method == "default" and dflt.delta == _json(js)["delta"] != api.delta

    rigid = _cfg(tmp_path, "rig.toml", '[drivetrain]\nN = 1.0\n[identification]\nmodel = "rigid"\n')
    jr = tmp_path / "i.json"
    run_identify(pq, rigid, json_out=jr, quiet=True)
    ident = dl.identify_drive(pq, rigid)
    cmd_rigid = _json(jr)["parameters"]  # the rigid JSON names M, F_v, F_c (the IDIM-LS names)
    assert ident.model == "rigid" and set(cmd_rigid) == {"M", "F_v", "F_c", "offset"}
    assert ident.value("J_m") == cmd_rigid["M"]["value"] and ident.value("T_Cm") == cmd_rigid["F_c"]["value"]
    assert dl.identify_drive(pq, rigid, model="two-mass").model == "two-mass"  # the argument wins
    # a configuration without [identification] model: the API's documented default
    n1 = _cfg(tmp_path, "n1.toml", "[drivetrain]\nN = 1.0\n")
    assert dl.identify_drive(pq, n1).model == "two-mass"


# ---------------------------------------------------------------- 3 + 5. --identify
def test_identify_keeps_only_configured_drive_values_and_the_api_equals_the_command(rec, tmp_path):
    from drivelash.commands.estimate import run_estimate

    _, pq = rec
    n1 = _cfg(tmp_path, "n1.toml", "[drivetrain]\nN = 1\n")
    js = tmp_path / "e.json"
    run_estimate(pq, n1, json_out=js, quiet=True, identify=True)
    cmd = _json(js)
    idt = cmd["identification"]["drivetrain"]
    used = cmd["drivetrain_used"]
    for k in ("T_Cm", "T_Cl", "beta_m", "beta_l", "J_m", "K_S"):
        assert used[k] == idt[k] and used[k] > 0, k  # identified, not the default 0
    assert 0.015 < used["T_Cm"] < 0.03 and 0.001 < used["beta_m"] < 0.005  # bench-0C: 0.0223, 0.0016
    api = dl.estimate_backlash(pq, n1, identify=True)
    assert _api_doc(api, pq, n1) == cmd
    assert abs(api.delta - 0.105) < 2e-3
    # a key the user set wins over the identification
    fixed = _cfg(tmp_path, "fixed.toml", "[drivetrain]\nN = 1\nT_Cm = 0.05\n")
    est = dl.estimate_backlash(pq, fixed, identify=True)
    assert est.summary["drivetrain_used"]["T_Cm"] == 0.05
    assert est.summary["drivetrain_used"]["T_Cl"] == est.summary["identification"]["drivetrain"]["T_Cl"]


def test_identify_without_velocities_says_the_online_law_needs_them(rec, tmp_path):
    df, _ = rec
    slow = df.iloc[::8].reset_index(drop=True).drop(columns=["omega_m", "omega_l"])  # 1 kHz, positions only
    n1 = _cfg(tmp_path, "n1.toml", "[drivetrain]\nN = 1.0\n")
    est = dl.estimate_backlash(slow, n1, identify=True)
    s = est.summary
    assert not s["online_run"] and s["delta"] is None and np.isnan(est.delta)
    assert "no 'omega_m' and no 'omega_l': the online law needs the recorded velocities" in s["reason"]
    off = s["identification"]["delta"]
    assert off["identifiable"] and off["ci95"][0] < 0.105 < off["ci95"][1]
    # negative control: without identify the estimator refuses the missing column at once
    with pytest.raises(dl.DataError, match="column 'omega_m': missing required column"):
        dl.estimate_backlash(slow, n1, DELTA1)


def test_kuka_estimate_identify_gives_the_stated_outcome_of_summary_py(tmp_path):
    from drivelash.commands.estimate import run_estimate
    from drivelash.estimation.backlash_api import estimate_with_identification

    mat = shared_data("kuka-kr300", "rec_A.mat")
    cfg = REPO / "examples" / "kuka" / "axis1.toml"
    js = tmp_path / "k.json"
    run_estimate(mat, cfg, json_out=js, quiet=True, identify=True)
    cmd = _json(js)
    c = dl.load_config(cfg)
    ref = estimate_with_identification(dl.load_trace(mat, c), c).summary  # as examples/kuka/summary.py
    assert cmd["online_run"] is False and cmd["reason"] == ref["reason"]
    # A1's delay fit now starts at the encoders' timing offset and is plausible (β_m 0.033; before
    # −0.70, "implausible"): what blocks the online law is J_l (motor equation only) and the
    # missing velocities — each named, as summary.py states it
    assert cmd["reason"].startswith("online estimate not run: the recording does not determine J_l (the load")
    assert "no 'omega_m' and no 'omega_l'" in cmd["reason"]
    assert dl.estimate_backlash(mat, cfg, identify=True).summary["reason"] == ref["reason"]
    # the result is JSON-clean (the KUKA fit has open intervals)
    ident = dl.identify_drive(mat, cfg)
    text = json.dumps(ident.as_dict(), allow_nan=False)
    assert "null" in text and not ident["delta"].identifiable
    # negative control: the plain estimate still needs the velocities and says so
    with pytest.raises(dl.DataError, match="missing required column"):
        dl.estimate_backlash(mat, cfg, delta1=0.0)


# ---------------------------------------------------------------- 7. velocities missing
def test_identify_without_motor_velocity_names_the_missing_column(rec, tmp_path):
    from drivelash.commands.data import run_identify

    df, pq = rec
    bare = df.drop(columns=["omega_m", "omega_l"])
    with pytest.raises(dl.DataError) as e:
        dl.identify_drive(bare, N=1.0)
    msg = str(e.value)
    assert msg.startswith("<DataFrame>, column 'omega_m': missing required column") and "\n" not in msg
    p = tmp_path / "bare.parquet"
    bare.to_parquet(p)
    n1 = _cfg(tmp_path, "n1.toml", "[drivetrain]\nN = 1.0\n")
    with pytest.raises(dl.DataError, match="column 'omega_m': missing required column"):
        run_identify(p, n1, model="two-mass", quiet=True, json_out=tmp_path / "x.json")
    # negative control: with the recorded velocities the same recording identifies δ
    r = dl.identify_drive(df, N=1.0)
    assert r["delta"].low < 0.105 < r["delta"].high


# ---------------------------------------------------------------- 9. messages in Python terms
def test_api_messages_name_the_argument_and_the_python_remedy(rec, tmp_path):
    df, _ = rec
    gap = pd.concat([df.iloc[:20000], df.iloc[20800:]])
    with pytest.raises(dl.DataError) as e:
        dl.estimate_backlash(gap, BENCH, DELTA1)
    assert "non-uniform sampling" in str(e.value) and "resample=True" in str(e.value)
    assert "--resample" not in str(e.value)
    # the command keeps its option (negative control)
    from drivelash.commands.estimate import run_estimate

    p = tmp_path / "gap.parquet"
    gap.to_parquet(p)
    with pytest.raises(dl.DataError, match="--resample"):
        run_estimate(p, _bench_cfg(tmp_path), quiet=True)
    # and the Python remedy works
    tr = dl.Trace.from_frame(gap, dl.load_config(BENCH), resample=True)
    assert len(tr) == 48000 - 800 + 800  # the gap filled on the 125 µs grid
    for bad in (-0.01, float("nan"), "0.05"):
        with pytest.raises(dl.ParameterError, match=r"^estimate_backlash\.delta1: the argument must be"):
            dl.estimate_backlash(df, BENCH, bad)


# ---------------------------------------------------------------- 10. columns keeps [sampling]
def test_columns_replaces_only_the_mapping(rec, tmp_path):
    df, _ = rec
    cfg = _bench_cfg(tmp_path, "\n[sampling]\nsample_rate = 8000\n")
    d = df.drop(columns="t").rename(columns={"theta_l": "pos_l"})
    est = dl.estimate_backlash(d, cfg, columns={"pos_l": "theta_l"})
    ref = dl.estimate_backlash(df, cfg)
    assert est.delta == ref.delta and est.summary["T_s"] == pytest.approx(1.0 / 8000, rel=1e-9)
    # negative control: without [sampling] there is no time
    with pytest.raises(dl.DataError, match="no \\[sampling\\] sample_rate"):
        dl.estimate_backlash(d, _bench_cfg(tmp_path), columns={"pos_l": "theta_l"})


# ---------------------------------------------------------------- 12. JSON-clean
def test_summary_is_the_commands_json_with_null_not_nan(rec, tmp_path):
    from drivelash.commands.estimate import run_estimate

    df, _ = rec
    still = df.copy()
    still["theta_l"], still["omega_l"] = 0.3, 0.0  # the load never moves: no interval
    p = tmp_path / "still.parquet"
    still.to_parquet(p)
    cfg = _bench_cfg(tmp_path)
    est = dl.estimate_backlash(p, cfg)
    assert est.summary["delta_interval_95"] == [None, None]
    js = tmp_path / "s.json"
    run_estimate(p, cfg, json_out=js, quiet=True)
    assert json.loads(
        json.dumps({"trace": str(p), "config": str(cfg), **est.summary}, allow_nan=False)
    ) == _json(js)


# ---------------------------------------------------------------- 13. cosmetics
def test_python_m_drivelash_dir_and_repr(rec):
    import os

    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    out = subprocess.run(
        [sys.executable, "-m", "drivelash", "--help"], capture_output=True, text=True, env=env
    )
    assert out.returncode == 0 and "estimate" in out.stdout and "identify" in out.stdout
    assert dir(dl) == sorted(dl.__all__)
    assert "TYPE_CHECKING" not in dir(dl) and "lazy_names" not in dir(dl)
    df, _ = rec
    est = dl.estimate_backlash(df, BENCH, DELTA1)
    r = repr(est)
    assert len(r) < 200 and r.startswith(
        "BacklashEstimate(delta=105 mrad, converged=True, excitation_ok=True"
    )
    assert "samples=48000" in r and est.warnings == [] and isinstance(est.warnings, list)


def test_kuka_estimate_identify_without_the_drive_writes_the_identification_report(tmp_path, capsys):
    """Found by an exploratory tester (session 13): KUKA rec_B axis 1 with --identify and
    --report: the online law cannot run (J_l, K_S, D_S not determined), the report was silently
    skipped ("no --plot/--report written") and the whole offline reason printed three times. Now
    --report holds the identification (with a note), the reason names each missing parameter's
    own reason and what to do, and the console prints it once."""
    from cli_runner import run_in_process

    mat = shared_data("kuka-kr300", "rec_B.mat")
    cfg = REPO / "examples" / "kuka" / "axis1.toml"
    rep, js = tmp_path / "r.html", tmp_path / "r.json"
    code, out, err = run_in_process(
        ["estimate", str(mat), "-c", str(cfg), "--identify", "--report", str(rep), "--json", str(js)], capsys
    )
    assert code == 0, err
    s = _json(js)
    assert s["online_run"] is False
    # J_m too since B8: the motor-only fit's J_m is the total J_m + J_l/N² (load moving with the motor)
    assert "does not determine J_m, J_l, K_S, D_S" in s["reason"]
    assert "give them in [drivetrain]" in s["reason"]
    assert any("--report holds the offline identification only" in w for w in s["warnings"])
    html = rep.read_text(encoding="utf-8")
    assert "drivelash identify (two-mass)" in html and "Identified parameters" in html
    text = " ".join((out + err).split())
    assert text.count("online estimate not run") == 1, text


# ---------------------------------------------------------------- 9b. the option the message names
def test_estimate_has_the_resample_option_its_message_names(rec, tmp_path, capsys):
    """Session 30 tester A (L1): the command refused a recording with a gap in its time stamps
    with "resample explicitly with --resample or [sampling] resample = true", while
    ``estimate --resample`` was "No such option" (only ``identify`` had it). The option now
    does what ``[sampling] resample = true`` does, streamed and with ``--identify``."""
    from tests.cli_runner import run_in_process

    df, _ = rec
    gap = pd.concat([df.iloc[:20000], df.iloc[20800:]])
    p = tmp_path / "gap.parquet"
    gap.to_parquet(p)
    cfg = _bench_cfg(tmp_path)
    code, _, err = run_in_process(["estimate", str(p), "-c", str(cfg)], capsys)
    assert code == 2 and "--resample" in err, err  # negative control: refused without it
    ref = dl.estimate_backlash(dl.Trace.from_frame(gap, dl.load_config(cfg), resample=True), cfg, DELTA1)
    for extra in ([], ["--identify"]):
        out = tmp_path / f"est{len(extra)}.json"
        code, _, err = run_in_process(
            ["estimate", str(p), "-c", str(cfg), "--resample", "--json", str(out), *extra], capsys
        )
        assert code == 0, err
        s = json.loads(out.read_text())
        assert s["samples"] == len(df)  # the 100 ms hole filled on the 125 µs grid
        if not extra:
            assert s["delta"] == ref.delta  # the same numbers as the notebook's resample=True
