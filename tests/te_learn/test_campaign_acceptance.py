"""Issue 6 acceptance on the full virtual-bench campaign (slow: simulate, fit, evaluate)."""

from __future__ import annotations

import pytest

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def evaluated(tmp_path_factory):
    from drivelash.commands.te_model import run_evaluate, run_fit
    from drivelash.sim.rack_campaign import run_campaign

    tmp = tmp_path_factory.mktemp("te_acceptance")
    run_campaign(tmp / "camp", seed=0)
    info = run_fit(tmp / "camp", tmp / "model", 3000.0, (1000.0, 2500.0), echo=lambda s: None)
    ev = run_evaluate(tmp / "model", tmp / "camp", echo=lambda s: None)
    return info, ev


def test_training_mae_below_50_nm(evaluated):
    """The deformation model (both directions pooled) fits its training runs to <= 0.05 um;
    measured 0.0499 um on seed 0 (0.0497 / 0.0501 um per direction): at the limit."""
    _, ev = evaluated
    assert ev["summary"]["train"]["mae"]["stacked"] <= 0.05


def test_held_out_and_extrapolation_relative_errors(evaluated):
    _, ev = evaluated
    s = ev["summary"]
    assert s["held-out"]["ratio"]["stacked"] <= 0.10
    assert s["extrapolation"]["ratio"]["stacked"] <= 0.25


def test_stacked_beats_every_baseline(evaluated):
    """Pooled over loads, directions and velocities, as the issue's acceptance asks (per
    load the margin to stage-1-only is small and can invert; see the closing note)."""
    _, ev = evaluated
    for split in ("held-out", "extrapolation"):
        mae = ev["summary"][split]["mae"]
        for base in ("geo-only", "stage1-only", "trees-only", "hgb"):
            assert mae["stacked"] < mae[base], (split, base, mae)
