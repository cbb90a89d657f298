"""``drivelash identify --model two-mass``: outputs, the tables ``estimate`` reads, refusals."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from drivelash.io.config import loads_config
from drivelash.sim.scenarios import get_scenario
from identify.helpers import EMPS_CONFIG, emps_file

EXE = Path(sys.executable).parent / "drivelash"


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(EXE), *map(str, args)], capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("rec") / "run.parquet"
    get_scenario("bench-0C").simulate(duration=6.0, seed=11).to_parquet(p)
    return p


def test_two_mass_writes_tables_json_report_and_estimate_reads_them(tmp_path, recording):
    from drivelash.commands.data import run_identify
    from drivelash.commands.estimate import run_estimate

    cfg = tmp_path / "drive.toml"
    cfg.write_text('[drivetrain]\nN = 1.0\n[identification]\nmodel = "two-mass"\n')  # model from config
    out, js, rep = tmp_path / "id.toml", tmp_path / "id.json", tmp_path / "id.html"
    run_identify(recording, cfg, out=out, json_out=js, report=rep, quiet=True)
    text = out.read_text()
    assert text.startswith("# drivelash identify")  # recognisable as our output (io.outputs)
    got = loads_config(text)
    assert abs(got.backlash.delta - 0.105) < 1e-3 and abs(got.backlash.delta1 - 0.0525) < 1e-3
    assert got.to_drivetrain_params().K_S == pytest.approx(32.94, rel=0.1)
    doc = json.loads(js.read_text())  # strict JSON (NaN/inf would fail here)
    d = doc["parameters"]["delta"]
    assert d["identifiable"] and d["ci95"][0] < d["value"] < d["ci95"][1]
    assert doc["backlash_visible"] and len(doc["correlation"]["names"]) == len(doc["correlation"]["matrix"])
    html = rep.read_text()
    assert 'id="fig-characteristic"' in html and "95 % interval" in html
    e = run_estimate(recording, out, quiet=True)
    assert abs(e["delta"] - 0.105) < 2e-3


def test_negative_torque_gain_is_refused_with_the_cause(tmp_path, recording):
    """Issue 15: a torque with the wrong sign must not give a negative inertia in a config file."""
    cfg = tmp_path / "neg.toml"
    cfg.write_text(
        '[drivetrain]\nN = 1.0\n[columns.torque_m]\ncolumn = "torque_m"\nunit = "N·m"\nscale = -1.0\n'
    )
    out = tmp_path / "id.toml"
    r = _run("identify", recording, "--config", cfg, "--model", "two-mass", "--out", out)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert "J_m" in r.stderr and "torque sign or gain" in r.stderr
    assert not out.exists()


def test_implausible_drive_diagnosis_is_written_without_a_drive_table(tmp_path, recording):
    """--json alone on the same wrong-sign torque: the diagnosis is written, marked implausible,
    and carries no backlash figure; nothing goes to stdout as a drive table (the command then
    exits 2, with or without --out, since session 30: tests/identify/test_session30_identify.py)."""
    from drivelash.commands.data import run_identify

    cfg = tmp_path / "neg.toml"
    cfg.write_text(
        '[drivetrain]\nN = 1.0\n[columns.torque_m]\ncolumn = "torque_m"\nunit = "N·m"\nscale = -1.0\n'
    )
    js = tmp_path / "id.json"
    doc = run_identify(recording, cfg, model="two-mass", json_out=js, quiet=True)
    on_disk = json.loads(js.read_text())
    assert on_disk["plausible"] is False and doc["plausible"] is False
    assert on_disk["parameters"]["delta"]["identifiable"] is False
    assert "not determined" in on_disk["backlash_reason"]


def test_rigid_emps_with_negative_gain_is_refused(tmp_path):
    """The rigid IDIM-LS on EMPS with the voltage gain negated gave M = −95.1 kg: refused now
    (the same file with the right sign identifies: tests/identify/test_identify_emps.py)."""
    from drivelash.commands.data import run_identify
    from drivelash.errors import DataError

    mat = emps_file("DATA_EMPS.mat")
    cfg = tmp_path / "emps_neg.toml"
    cfg.write_text(EMPS_CONFIG.read_text().replace('gain = "gtau"', 'gain = "gtau"\nscale = -1.0'))
    out = tmp_path / "dt.toml"
    with pytest.raises(DataError, match="J_m = -95"):
        run_identify(mat, cfg, out=out, quiet=True)
    assert not out.exists()


def test_unknown_model_and_cross_with_two_mass_are_usage_errors(tmp_path, recording):
    from drivelash.commands.data import run_identify
    from drivelash.errors import DrivelashError

    cfg = tmp_path / "d.toml"
    cfg.write_text("[drivetrain]\nN = 1.0\n")
    with pytest.raises(DrivelashError, match="--model"):
        run_identify(recording, cfg, model="three-mass", quiet=True)
    with pytest.raises(DrivelashError, match="--cross"):
        run_identify(recording, cfg, model="two-mass", cross=recording, quiet=True)
