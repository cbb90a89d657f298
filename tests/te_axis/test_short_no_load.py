"""A no-load run covering less travel than the load passes (finding A9, session 20 tester A).

The synthetic axis of :mod:`.synth` with the −1 geometric run stopped early (210 … 450 mm,
the load passes 50 … 450 mm). Before: ``te import``/``te fit`` said nothing and the fit
trained on the load passes over 50 … 210 mm with TE_geo held flat there, so the target held
the *geometric* error (tens of µm) — learnt as load behaviour. Now the import warns naming
each load file and the uncovered span, and ``prepare_campaign`` keeps the load passes only
where their direction's no-load curve holds data.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from drivelash.te.learn.fit import prepare_campaign
from drivelash.te.protocol.campaign import load_campaign
from drivelash.te.protocol.importer import import_campaign

from .synth import BENCH, standard_runs, te_of, write_axis

LOADS = (0.0, 1500.0, 3000.0)


def _runs(geo_neg_lo: float):
    runs = [dataclasses.replace(r, lo=0.05, hi=0.45) for r in standard_runs(loads=LOADS)]
    assert runs[1].kind == "geometric" and runs[1].direction == -1
    runs[1] = dataclasses.replace(runs[1], lo=geo_neg_lo)
    return runs


@pytest.fixture(scope="module", params=[0.21, 0.05], ids=["short", "full"])
def imported(request, tmp_path_factory):
    root = tmp_path_factory.mktemp("geo_short")
    axis = write_axis(root / "rec", _runs(request.param))
    warnings: list[str] = []
    import_campaign(axis, root / "camp", warn=warnings.append)
    return request.param, load_campaign(root / "camp"), warnings


def test_import_warns_naming_each_load_file_and_the_uncovered_span(imported):
    lo, _, warnings = imported
    beyond = [w for w in warnings if "TE_geo is not known" in w]
    if lo == 0.05:  # negative control: the complete no-load run, no such warning
        assert beyond == []
        return
    assert len(beyond) == len(LOADS), warnings  # every −1 load pass, no +1 pass
    for w in beyond:
        assert "_neg.csv:" in w and "direction -1" in w
        # the uncovered span: the load pass starts at 50 mm, the no-load run at 210 mm
        assert "TE_geo is not known at 50.0 ... 210.0 mm" in w, w


def test_fit_uses_the_load_passes_only_where_the_no_load_curve_holds_data(imported):
    """Every training row of direction −1 lies on the no-load curve, and its target is the
    synthetic deformation TE(F) − TE(F_CT) (up to the pass's constant) to 0.05 µm.

    Reference: :func:`synth.te_of` — the geometric parts (5 µm/m drift, 25 µm once per pinion
    revolution, the direction's 20 µm) cancel in the difference; what is left is the load's
    change of the meshing term, < 1 µm. With TE_geo held flat below 210 mm (the old code) the
    target there held the drift and the revolution term: up to ~25 µm off.
    """
    lo, camp, _ = imported
    _, geo, runs = prepare_campaign(camp)
    g_lo, g_hi = geo["neg"].span()
    for d, key in ((1, "pos"), (-1, "neg")):
        for r in runs[key]:
            assert r.x.min() >= geo[key].span()[0] - 1e-9 and r.x.max() <= geo[key].span()[1] + 1e-9
            F = r.meta["load"] + BENCH.F_CT
            ref = (te_of(r.x, d, F) - te_of(r.x, d, BENCH.F_CT)) * 1e6
            err = r.te_def_um - (ref - np.mean(ref))
            assert np.max(np.abs(err)) < 0.05, (key, r.meta["load"], np.max(np.abs(err)))
    if lo == 0.21:
        assert g_lo == pytest.approx(0.215, abs=2e-3)  # the run from 210 mm, 5 mm trimmed
        # cut at the curve's start (then trimmed by 30 mm like any end): 50 ... ~215 mm dropped
        cut = g_lo - 0.05
        assert [r.meta["cropped_m"] for r in runs["neg"]] == pytest.approx([cut] * len(LOADS), abs=1e-3)
        assert all("cropped_m" not in r.meta for r in runs["pos"])
