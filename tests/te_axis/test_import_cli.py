"""``drivelash te import AXIS.toml -o CAMPAIGN``: real recordings (CNC units) → campaign, checked first."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from drivelash.te.protocol.campaign import load_campaign

from .synth import BENCH, K_T, Run, standard_runs, te_of, write_axis

EXE = Path(sys.executable).parent / "drivelash"
# 350 mm: the load passes leave 290 mm to train on, more than one pinion revolution (266.7 mm)
SHORT = {"lo": 0.05, "hi": 0.4}


def _run(*args: str) -> subprocess.CompletedProcess:
    """The console script in a subprocess (exit code, stderr as a user sees them)."""
    return subprocess.run([str(EXE), *args], capture_output=True, text=True, timeout=600)


def _invoke(*args: str):
    """The command in-process (faster; exceptions as raised)."""
    from typer.testing import CliRunner

    from drivelash.cli import app

    return CliRunner().invoke(app, list(args))


def _small_runs():
    return [dataclasses.replace(r, **SHORT) for r in standard_runs(loads=(0.0, 1500.0, 3000.0))]


@pytest.fixture(scope="module")
def recordings(tmp_path_factory) -> Path:
    return write_axis(tmp_path_factory.mktemp("rec"), _small_runs())


def test_import_converts_units_and_keeps_the_te(recordings, tmp_path):
    out = tmp_path / "camp"
    r = _invoke("te", "import", str(recordings), "-o", str(out))
    assert r.exit_code == 0, r.output
    assert "8 runs (2 geometric, 6 load, 0 sine)" in r.output and "valid range" in r.output
    assert "drivelash: warning" not in r.output and "0 warning(s), no error" in r.output  # a clean axis
    camp = load_campaign(out)
    run = camp.select(kind="load", direction=-1, load=1500.0)[0]
    tr = run.trace()
    # SI on disk: the TE measured from the imported columns is the synthetic one (encoder counts: 0.5 nm)
    te = tr["x_T"] - tr["theta_m"] * camp.bench.r_eff
    ref = te_of(tr["x_T"], -1, 1500.0 + BENCH.F_CT)
    assert np.max(np.abs(te - ref)) < 2e-9
    # current in A times the torque constant
    moving = np.abs(np.gradient(tr["x_T"], tr["t"])) > 0.05
    assert np.median(tr["torque_m"][moving]) == pytest.approx(
        -(1650.0 * BENCH.r_eff / 0.95 + BENCH.T_Cm), rel=1e-3
    )
    assert K_T == 1.8 and run.velocity == 0.1
    man = json.loads((out / "manifest.json").read_text())
    assert man["import"]["plausibility"]["errors"] == []


def test_flipped_encoder_is_refused_with_one_line_and_nothing_written(tmp_path):
    runs = _small_runs()
    runs[2] = dataclasses.replace(runs[2], sign=-1, name="pass_flipped.csv")
    axis = write_axis(tmp_path / "rec", runs)
    out = tmp_path / "camp"
    r = _run("te", "import", str(axis), "-o", str(out))
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert "pass_flipped.csv: implausible campaign" in r.stderr and "encoder sign" in r.stderr
    # the line the README quotes, word for word after the file name
    assert r.stderr.rstrip("\n").endswith(
        "pass_flipped.csv: implausible campaign: TE slope +2.000 m/m: the motor encoder counts against"
        " the linear scale (encoder sign) — set scale = -1 on the theta_m column in [columns]"
    )
    assert not out.exists()


def test_warnings_are_printed_and_the_import_goes_on(tmp_path):
    runs = _small_runs()
    runs.append(Run("load", 1, 2500.0, 0.1, lo=0.05, hi=0.1, name="short_pass.csv"))
    axis = write_axis(tmp_path / "rec", runs)
    r = _invoke("te", "import", str(axis), "-o", str(tmp_path / "camp"))
    assert r.exit_code == 0, r.output
    assert "drivelash: warning:" in r.output and "short_pass.csv: covers 0.050 m" in r.output


@pytest.mark.parametrize(
    ("toml", "needle"),
    [
        ("[geometry]\ntravl = 1.0\n", "table [geometry], key 'travl': unknown key; did you mean 'travel'?"),
        ("[geometry]\nn_t = 20\n[[runs]]\nkind = 'load'\ndirection = 2\nfile = 'a.csv'\n", "direction"),
        ("[geometry]\nn_t = 20\n[[runs]]\nkind = 'load'\ndirection = 1\n", "key 'file': missing"),
        ("[geometry]\nn_t = 20\n", "[runs]"),
        ("[drive]\nm_T = 10\n[[runs]]\nkind = 'load'\ndirection = 1\nfile = 'a.csv'\n", "[geometry]"),
    ],
)
def test_bad_axis_files_are_one_line_errors(tmp_path, toml, needle):
    axis = tmp_path / "axis.toml"
    axis.write_text(toml)
    r = _invoke("te", "import", str(axis), "-o", str(tmp_path / "camp"))
    assert r.exit_code != 0
    msg = str(r.exception)
    assert needle in msg and "axis.toml" in msg and "\n" not in msg
