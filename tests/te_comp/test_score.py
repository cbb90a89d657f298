"""``te score`` on recorded passes (issue 12 item 5) against the virtual-bench protocol.

Passes are simulated on the bench without and with the compensator (an ideal model: the
bench's own TE), scored the way ``te validate`` scores them, then written as 1 kHz
recordings (time, linear scale, motor angle, torque, motor speed — with or without the
set position) and scored again by :func:`score_campaigns` from the files alone.
"""

from __future__ import annotations

import json
from dataclasses import asdict

import numpy as np
import pytest

from drivelash.cli import app
from drivelash.errors import DataError
from drivelash.te.protocol.bench import compensator_for
from drivelash.te.protocol.campaign import load_campaign
from drivelash.te.protocol.monitoring import section_edges
from drivelash.te.protocol.passes import pass_trajectory, run_pass, score_pass
from drivelash.te.protocol.score import ScoreConfig, pass_path_error, score_campaigns
from drivelash.te.runtime.compensator import Compensator
from drivelash.te.runtime.table import build_table

from .analytic import BenchTE
from .score_data import pass_improvements, write_passes

LO, HI = 0.1, 0.35
PASSES = [(1, 0.1, 2000.0), (-1, 0.1, 2000.0), (1, 0.05, 0.0)]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    from drivelash.io.campaign import FORMAT_V1 as FORMAT  # a first-release manifest, upgraded on read
    from drivelash.physics.rack_pinion import RackPinionBench, TransmissionErrorModel
    from drivelash.sim.rack_axis import RackAxisSimulator

    bench = RackPinionBench()
    te = TransmissionErrorModel.generate(bench, seed=3)
    sim = RackAxisSimulator(bench, te)
    table = build_table(BenchTE(bench, te), 0.0, 0.5, 0.1e-3, 10.0, 21)
    params = compensator_for(bench, table)
    edges = section_edges(LO, HI, 0.1)
    unc, comp, validate = [], [], {}
    for d, v, F in PASSES:
        _, x_d, v_d = pass_trajectory(sim, LO, HI, v, d)
        ru = run_pass(sim, x_d, v_d, F, None)
        rc = run_pass(sim, x_d, v_d, F, Compensator(table, params, d))
        mu, mc = score_pass(ru, rc, v, edges)
        ok = np.isfinite(mu) & np.isfinite(mc)
        validate[(d, v, F)] = float(np.mean(1 - mc[ok] / mu[ok]))
        entry = {"file": f"load_v{v * 1e3:g}_F{F:g}_{'pos' if d > 0 else 'neg'}.parquet", "kind": "load",
                 "load": F, "velocity": v, "direction": d, "seed": 0}  # fmt: skip
        unc.append((entry, ru))
        comp.append((entry, rc))
    manifest = {"format": FORMAT, "seed": 3, "bench": bench.to_dict(), "gains": asdict(sim.gains)}
    tmp = tmp_path_factory.mktemp("score")
    dirs = {}
    for with_x_d in (True, False):
        tag = "xd" if with_x_d else "noxd"
        dirs[tag] = (write_passes(tmp / f"unc_{tag}", manifest, unc, with_x_d),
                     write_passes(tmp / f"comp_{tag}", manifest, comp, with_x_d))  # fmt: skip
    return {"validate": validate, "dirs": dirs, "tmp": tmp}


@pytest.mark.parametrize(("tag", "tol_pp"), [("xd", 0.5), ("noxd", 1.0)])
def test_score_reproduces_the_protocol_per_pass(recorded, tag, tol_pp):
    u, c = recorded["dirs"][tag]
    s = score_campaigns(load_campaign(u), load_campaign(c), ScoreConfig())
    got = pass_improvements(s["rows"])
    assert s["set_position"] == (["recorded"] if tag == "xd" else ["reconstructed"])
    for k, ref in recorded["validate"].items():
        assert 100 * abs(got[k] - ref) <= tol_pp, (k, got[k], ref)
    assert s["gains"]["source"] == "axis file"
    # monitoring: (3) on the compensated passes' TE estimates the uncompensated path error
    assert s["monitoring"]["median_relative_error"] < 0.05
    assert abs(s["monitoring"]["average_improvement_estimated"] - s["passes"]["average_improvement"]) < 0.02


def test_identified_gains(recorded):
    u, c = recorded["dirs"]["xd"]
    s = score_campaigns(load_campaign(u), load_campaign(c), ScoreConfig(), gains="identify")
    g = s["gains"]
    assert g["source"] == "identified"
    # K_v is what the passes' spectrum determines (tooth meshing below the loop bandwidth)
    assert g["identified"]["K_v"] == pytest.approx(231.0, rel=0.01)
    assert g["identification"]["relative_std"]["K_v"] < 0.01
    assert s["monitoring"]["median_relative_error"] < 0.05


def test_reconstruction_removes_only_a_line():
    # a pass at 0.1 m/s whose true path error is a 13.3 mm meshing sine plus an offset and a slope
    t = np.arange(0, 3.0, 1e-3)
    v = 0.1
    x_d = np.where(t < 0.2, 0.5 * v * t**2 / 0.2, v * (t - 0.1))
    e_true = 2e-6 * np.sin(2 * np.pi * x_d / 13.333e-3) + 0.3e-6 + 1e-7 * t
    cols = {"t": t, "x_T": x_d - e_true}
    p = pass_path_error(cols, 1, v, ScoreConfig(), "synthetic")
    assert p.set_position == "reconstructed"
    m = np.isin(t, p.t)
    resid = p.e - e_true[m]
    A = np.vstack([np.ones(m.sum()), t[m]]).T
    line = A @ np.linalg.lstsq(A, resid, rcond=None)[0]
    assert np.max(np.abs(resid - line)) < 1e-9  # the difference is a line
    assert np.mean(np.abs(p.e)) == pytest.approx(np.mean(np.abs(e_true[m] - e_true[m].mean())), rel=0.05)


def test_unmatched_and_missing_runs(recorded, tmp_path):
    u, c = recorded["dirs"]["xd"]
    man = json.loads((c / "manifest.json").read_text())
    man["runs"] = man["runs"][:1]
    (c.parent / "partial").mkdir()
    for r in man["runs"]:
        (c.parent / "partial" / r["file"]).write_bytes((c / r["file"]).read_bytes())
    (c.parent / "partial" / "manifest.json").write_text(json.dumps(man))
    s = score_campaigns(load_campaign(u), load_campaign(c.parent / "partial"), ScoreConfig())
    assert len(s["unmatched"]) == 2 and len(s["passes"]["pass_averages"]) == 1
    man["runs"] = []
    (tmp_path / "manifest.json").write_text(json.dumps(man))
    # a campaign without runs is refused by the manifest schema (io.campaign) before pairing
    with pytest.raises(DataError, match="no pair|key 'runs': List should have at least 1 item"):
        score_campaigns(load_campaign(u), load_campaign(tmp_path), ScoreConfig())


@pytest.mark.filterwarnings("error::RuntimeWarning")  # no numpy warning reaches the user
def test_cli_writes_the_score_and_refuses_bad_input(recorded, tmp_path):
    from typer.testing import CliRunner

    u, c = recorded["dirs"]["noxd"]
    out = tmp_path / "S"
    r = CliRunner().invoke(
        app, ["te", "score", "--uncompensated", str(u), "--compensated", str(c), "-o", str(out)]
    )
    assert r.exit_code == 0, r.output
    assert "average improvement" in r.output and "set position: reconstructed" in r.output
    doc = json.loads((out / "score.json").read_text())
    assert doc["generator"].startswith("drivelash")
    assert (out / "improvement_sections.csv").read_text().startswith("# drivelash")
    assert (out / "fig9_improvement.png").stat().st_size > 10_000
    # the real entry point: one line on stderr, exit code 2
    import subprocess
    import sys

    def run(*args):
        cmd = [sys.executable, "-m", "drivelash.cli", "te", "score", *args]
        return subprocess.run(cmd, capture_output=True, text=True)

    r = run("--uncompensated", str(tmp_path / "nope"), "--compensated", str(c))
    assert r.returncode == 2 and "not a campaign directory" in r.stderr and r.stderr.count("\n") == 1
    r = run("--uncompensated", str(u), "--compensated", str(c), "--gains", "x")
    assert r.returncode == 2 and "--gains" in r.stderr and "Traceback" not in r.stderr


def _other_axis(src, dst):
    """A copy of the campaign ``src`` whose pinion has 24 instead of 20 teeth (another d_p)."""
    dst.mkdir()
    man = json.loads((src / "manifest.json").read_text())
    assert man["bench"]["n_t"] == 20
    man["bench"]["n_t"] = 24
    for r in man["runs"]:
        (dst / r["file"]).write_bytes((src / r["file"]).read_bytes())
    (dst / "manifest.json").write_text(json.dumps(man))
    return dst


def test_passes_of_another_axis_are_refused(recorded, tmp_path):
    u, c = recorded["dirs"]["xd"]
    other = _other_axis(u, tmp_path / "other")
    with pytest.raises(DataError, match=r"d_p of the uncompensated passes' axis is 0\.10\d+, the compensated"
                                        r" passes' is 0\.08\d+: passes of another axis"):  # fmt: skip
        score_campaigns(load_campaign(other), load_campaign(c), ScoreConfig())
    with pytest.raises(DataError, match="passes of another axis"):
        score_campaigns(load_campaign(u), load_campaign(_other_axis(c, tmp_path / "o2")), ScoreConfig())


@pytest.mark.filterwarnings("error::RuntimeWarning")  # no numpy overflow warning reaches the user
def test_implausible_identified_gains_are_not_used(recorded):
    u, c = recorded["dirs"]["xd"]
    # compensated and uncompensated swapped: eq. (3) cannot map the small TE onto the large error
    s = score_campaigns(load_campaign(c), load_campaign(u), ScoreConfig(), gains="identify")
    g = s["gains"]
    assert g["used"] is None and "monitoring" not in s
    assert g["identified"]["K_v"] > 1e4 or not np.isfinite(g["identified"]["K_v"])
    assert "K_v" in g["implausible"] and "outside 0.5 ... 10000 1/s" in g["implausible"]
    assert s["passes"]["average_improvement"] < 0
    assert any("swapped" in w for w in s["warnings"]) and len(s["warnings"]) == 2
    # negative control: the right order keeps the identified gains and the monitoring, no warning
    s = score_campaigns(load_campaign(u), load_campaign(c), ScoreConfig(), gains="identify")
    assert s["gains"]["used"]["K_v"] == pytest.approx(231.0, rel=0.01) and s["warnings"] == []
    assert "implausible" not in s["gains"] and s["monitoring"]["median_relative_error"] < 0.05
