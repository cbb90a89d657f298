"""The measurement campaign: files, manifest, reproducibility, Fig. 2 structure (spec 02 §1, §6)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from drivelash.errors import DataError
from drivelash.physics.rack_pinion import TransmissionErrorModel
from drivelash.report.te_figures import plot_te_over_position
from drivelash.sim.rack_campaign import STORED_COLUMNS, CampaignConfig, plan_runs, run_campaign
from drivelash.te.protocol.campaign import load_campaign, measured_te

from .helpers import TINY, spectrum_over_position

# Fig. 2: geometric runs over the whole travel at 10 mm/s + load passes at one speed
FIG2 = CampaignConfig(velocities=(0.1,), loads=(0.0, 2500.0, 5000.0), sine_loads=())


# slow since session 33 (8–9 s of `make test`'s 10-minute budget): the paper's Fig. 2 campaign; the
# campaign's files, manifest and reproducibility stay fast (test_tiny_campaign_files_manifest_…)
@pytest.mark.slow
def test_fig2_structure(tmp_path):
    """Acceptance on one recorded Fig. 2 campaign (simulated once: the checks share it)."""
    run_campaign(tmp_path / "fig2", seed=5, config=FIG2, workers=2)
    camp = load_campaign(tmp_path / "fig2")
    _check_spectrum_peaks_at_configured_amplitudes(camp)
    _check_mesh_amplitude_falls_with_load(camp)
    _check_backlash_varies_within_range(camp)
    png = plot_te_over_position(camp, tmp_path / "fig2.png")
    assert png.stat().st_size > 20_000


def test_full_protocol_plan():
    runs = plan_runs(CampaignConfig())
    kinds = [r.kind for r in runs]
    assert kinds.count("geometric") == 2
    assert kinds.count("load") == 3 * 11 * 2
    assert kinds.count("sine") == 2
    loads = sorted({r.load for r in runs if r.kind == "load"})
    assert loads == [500.0 * i for i in range(11)]
    assert {r.direction for r in runs if r.kind != "sine"} == {1, -1}
    assert len({r.file for r in runs}) == len(runs)


def test_tiny_campaign_files_manifest_and_reproducibility(tmp_path):
    a = run_campaign(tmp_path / "a", seed=3, config=TINY)
    run_campaign(tmp_path / "b", seed=3, config=TINY, workers=1)
    run_campaign(tmp_path / "c", seed=4, config=TINY)
    assert a["timing"]["real_time_factor"] > 0
    ma = json.loads((tmp_path / "a" / "manifest.json").read_text())
    mb = json.loads((tmp_path / "b" / "manifest.json").read_text())
    assert ma == mb
    assert ma["simulator"]["seed"] == 3 and ma["store_rate"] == 1000.0
    assert ma["format"] == "drivelash.te-campaign" and ma["version"] == 2 and ma["source"] == "simulated"
    assert {"geometry", "drive", "gains"} <= set(ma["axis"])
    assert {"seed", "te_generator", "sim_config", "campaign", "defects"} <= set(ma["simulator"])
    camp_a, camp_b, camp_c = (load_campaign(tmp_path / n) for n in "abc")
    assert len(camp_a.runs) == len(plan_runs(TINY)) == 2 + 4 + 1
    for ra, rb, rc in zip(camp_a.runs, camp_b.runs, camp_c.runs, strict=True):
        ta, tb, tc = ra.trace(), rb.trace(), rc.trace()
        assert tuple(ta.names) == STORED_COLUMNS
        assert ta.T_s == pytest.approx(1e-3)
        assert set(np.unique(ta["direction"])) <= {-1.0, 1.0}
        assert np.all(ta["F_load"] == ra.load)
        for col in STORED_COLUMNS:  # same seed ⇒ identical
            assert np.array_equal(ta[col], tb[col]), (ra.file, col)
        # different seed ⇒ a different drive (the set-points are the same)
        assert np.array_equal(ta["x_d"], tc["x_d"])
        te_a, te_c = measured_te(ta, camp_a.bench), measured_te(tc, camp_c.bench)
        assert np.sqrt(np.mean((te_a - te_c) ** 2)) > 2e-6
    # the true TE along a run: quasi-static model at the transmitted force
    run = camp_a.select(kind="geometric", direction=-1)[0]
    tr = run.trace()
    m = (tr["x_d"] > tr["x_d"].min() + 0.03) & (tr["x_d"] < tr["x_d"].max() - 0.03)
    assert np.max(np.abs(camp_a.true_te(run)[m] - measured_te(tr, camp_a.bench)[m])) < 0.05e-6
    # the true model is regenerated exactly
    x = np.linspace(0.0, 2.2, 1001)
    ref = TransmissionErrorModel.generate(camp_a.bench, 3)
    assert np.array_equal(camp_a.true_te_model().te(x, 700.0, -1), ref.te(x, 700.0, -1))
    assert camp_a.gains.K_v == 231.0
    # and a simulator of the same drive reproduces a run
    run = camp_a.select(kind="load", direction=1, load=3000.0)[0]
    assert run.velocity == 0.1 and run.direction == 1


def _check_spectrum_peaks_at_configured_amplitudes(fig2_campaign):
    """Acceptance: the no-load TE over position shows the pinion-circumference and
    tooth-pitch periods with the configured amplitudes (±10 %)."""
    camp = fig2_campaign
    bench, model = camp.bench, camp.true_te_model()
    n_rev = 7  # 7 revolutions = 1.867 m of the 2.1 m pass
    for run in camp.select(kind="geometric"):
        tr = run.trace()
        k, a = spectrum_over_position(tr["x_T"], measured_te(tr, bench), 0.15, n_rev * bench.circumference)
        F_fr = bench.F_CT + bench.beta_T * run.velocity  # the flank carries the table friction
        conf = model.component_amplitudes(run.direction, F_fr)
        assert k[3 + np.argmax(a[3:60])] == n_rev
        assert k[100 + np.argmax(a[100:400])] == n_rev * bench.n_t
        assert a[n_rev] == pytest.approx(conf["runout"], rel=0.1)
        assert a[n_rev * bench.n_t] == pytest.approx(conf["mesh"], rel=0.1)
        a_run, a_mesh = a[n_rev] * 1e6, a[n_rev * bench.n_t] * 1e6
        print(
            f"dir {run.direction:+d}: runout {a_run:.2f} µm (configured {conf['runout'] * 1e6:.2f}), "
            f"mesh {a_mesh:.3f} µm (configured {conf['mesh'] * 1e6:.3f})"
        )


def _check_mesh_amplitude_falls_with_load(fig2_campaign):
    camp = fig2_campaign
    bench = camp.bench
    n_rev = 7
    for d in (1, -1):
        amps = []
        for run in sorted(camp.select(kind="load", direction=d), key=lambda r: r.load):
            tr = run.trace()
            te = measured_te(tr, bench)
            k, a = spectrum_over_position(tr["x_T"], te, 0.15, n_rev * bench.circumference)
            amps.append(a[n_rev * bench.n_t])
        assert len(amps) == 3
        assert amps[0] > amps[1] > amps[2]
        assert amps[2] < 0.6 * amps[0]


def _check_backlash_varies_within_range(fig2_campaign):
    camp = fig2_campaign
    bench, model = camp.bench, camp.true_te_model()
    p = model.params
    grid = np.arange(0.2, 2.0, 50e-6)
    curves = {}
    for run in camp.select(kind="geometric"):
        tr = run.trace()
        order = np.argsort(tr["x_T"])
        curves[run.direction] = np.interp(grid, tr["x_T"][order], measured_te(tr, bench)[order])
    gap = curves[-1] - curves[1]
    # measured gap = backlash + friction deflection of both flanks
    F_fr = bench.F_CT + bench.beta_T * 0.01
    expected = model.te(grid, F_fr, -1) - model.te(grid, F_fr, 1)
    assert np.max(np.abs(gap - expected)) < 0.1e-6
    b = model.backlash(grid)
    assert p.b_min <= b.min() and b.max() <= p.b_max
    assert np.ptp(gap) > 0.3 * (p.b_max - p.b_min)


def test_load_campaign_errors(tmp_path):
    with pytest.raises(DataError, match="manifest"):
        load_campaign(tmp_path)
    (tmp_path / "manifest.json").write_text("{not json")
    with pytest.raises(DataError, match="malformed"):
        load_campaign(tmp_path)
    run = {"file": "x.parquet", "kind": "load", "load": 0, "velocity": 0.1, "direction": 1}
    doc = {"format": "drivelash.te-campaign", "version": 2, "source": "imported", "axis": {"geometry": {}},
           "columns": ["t", "x_T", "theta_m", "torque_m"], "runs": [run]}  # fmt: skip
    (tmp_path / "manifest.json").write_text(json.dumps(doc))
    with pytest.raises(DataError, match="missing"):
        load_campaign(tmp_path)


def test_cli_quick_campaign(tmp_path):
    from typer.testing import CliRunner

    from drivelash.cli import app

    res = CliRunner().invoke(app, ["te", "campaign", "-o", str(tmp_path / "q"), "--quick", "--seed", "2"])
    assert res.exit_code == 0, res.output
    assert "real-time factor" in res.output
    camp = load_campaign(tmp_path / "q")
    assert camp.seed == 2
    assert (tmp_path / "q" / "fig2_te.png").is_file()
    assert {r.kind for r in camp.runs} == {"geometric", "load", "sine"}


@pytest.mark.slow
def test_full_campaign(tmp_path):
    m = run_campaign(tmp_path, seed=0)
    camp = load_campaign(tmp_path)
    assert len(camp.runs) == 70
    assert sorted({r.velocity for r in camp.select(kind="load")}) == [0.02, 0.05, 0.1]
    print(f"full campaign: {m['timing']}")
