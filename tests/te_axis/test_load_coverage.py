"""A model is valid only where its load behaviour was measured (finding A9's residue, session 29).

Stage 1 sees position only through the pinion-tooth features M_1 … M_nt (spec 02 §3–4); stage
2's trees see x_T. Load passes that leave less than one pinion revolution to train on never
mesh some teeth: stage 1's weights for them are untrained, and the model's prediction where
they mesh is not known — measured on the synthetic axis of :mod:`.synth` (slow test below):
140 mm of training rows on its 266.7 mm pinion: 0.047 µm MAE on them, 1.15 / 0.70 µm (+1 / −1)
over the rest of the travel — 1.17 / 0.72 times the 0.98 µm the load term itself amounts to; with
340 mm of rows, 0.05 µm on them and 0.08 µm over the rest. Before, the model claimed the no-load
runs' whole span (50 … 950 mm) as valid. Now the plausibility report (run by ``te import`` and
``te fit``) narrows the valid range to where two or more training loads were recorded and, with
less than a revolution to train on, to the rows ``te fit`` trains on; each narrowing is one
warning naming the range.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from drivelash.te.learn.preprocess import LOAD_TRIM
from drivelash.te.protocol.plausibility import check_runs

from .synth import BENCH, record, standard_runs, te_of, write_axis

LOADS = (0.0, 1000.0, 2000.0, 3000.0)
CIRC = BENCH.n_t * BENCH.tooth_pitch  # 266.7 mm


def _runs(load_hi: float, load_lo: float = 0.05, **per_load):
    """Geometric passes over 50 … 950 mm, load passes over [load_lo, load_hi] (or per load)."""
    out = []
    for r in standard_runs(loads=LOADS):
        if r.kind == "load":
            lo, hi = per_load.get(f"F{r.load:g}", (load_lo, load_hi))
            r = dataclasses.replace(r, lo=lo, hi=hi)
        out.append(r)
    return out


def _check(runs, for_score=False):
    recs = [record(r, f"run{i:02d}.csv") for i, r in enumerate(runs)]
    return check_runs(
        recs, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0, source="axis.toml", n_t=BENCH.n_t,
        for_score=for_score,
    )  # fmt: skip


def _coverage(rep):
    return [f for f in rep.warnings if f.check == "coverage" and f.file == "axis.toml"]


def test_less_than_a_revolution_narrows_to_the_trained_rows():
    rep = _check(_runs(0.25))  # 200 mm of load passes: 140 mm after the 30 mm trims
    assert rep.errors == []
    assert CIRC == pytest.approx(0.26667, abs=1e-4) and LOAD_TRIM == 0.03
    assert rep.valid_range == pytest.approx((0.08, 0.22), abs=1e-3)
    found = _coverage(rep)
    assert len(found) == 2, [f.line() for f in rep.findings]  # one per direction
    for f, d in zip(found, ("+1", "-1"), strict=True):
        assert f.message.startswith(f"direction {d}: the load passes leave 140.0 mm to train on"), f.message
        assert "less than one pinion revolution (266.7 mm)" in f.message
        assert "about 9 of the 20 pinion teeth never mesh" in f.message  # 20 − ⌈140 / 13.33⌉
        assert "narrowed to the trained 80.0 … 220.0 mm" in f.message
        assert "at least 327 mm" in f.message  # one revolution + 2 × 30 mm


def test_more_than_a_revolution_narrows_to_where_two_loads_were_recorded():
    rep = _check(_runs(0.45))  # 400 mm: 340 mm of rows, every tooth meshes
    assert rep.errors == []
    assert rep.valid_range == pytest.approx((0.05, 0.45), abs=1e-3)
    (f_pos, f_neg) = _coverage(rep)
    assert "pinion teeth" not in f_pos.message + f_neg.message
    assert (
        "recorded over 50.0 … 450.0 mm only, of the 50.0 … 950.0 mm the no-load runs cover" in f_pos.message
    )
    assert rep.directions["pos"]["load_range"] == pytest.approx([0.05, 0.45], abs=1e-3)


def test_full_load_passes_keep_the_no_load_span_exactly():
    """Negative control: the usual campaign is untouched, bit for bit (load passes ending
    within :data:`GEO_SPAN_TOL` of the no-load runs' ends count as reaching them)."""
    runs = _runs(0.95)
    rep = _check(runs)
    assert _coverage(rep) == [] and rep.warnings == []
    geo = [i["range_m"] for i in rep.runs if i["kind"] == "geometric"]
    assert rep.valid_range == (max(g[0] for g in geo), min(g[1] for g in geo))


def test_two_loads_over_the_travel_are_enough():
    """The load dependence needs two loads at a position: two short loads among four do not narrow."""
    rep = _check(_runs(0.95, F0=(0.05, 0.25), F1000=(0.05, 0.25)))
    assert _coverage(rep) == []
    assert rep.valid_range == pytest.approx((0.05, 0.95), abs=1e-3)
    # three short ones leave only one load over 250 … 950 mm: narrowed to 50 … 250 mm, and that
    # is less than a revolution to train on
    rep = _check(_runs(0.95, F0=(0.05, 0.25), F1000=(0.05, 0.25), F2000=(0.05, 0.25)))
    assert rep.valid_range == pytest.approx((0.08, 0.22), abs=1e-3)


def test_load_passes_of_the_two_directions_without_common_positions_are_an_error():
    runs = [
        dataclasses.replace(r, lo=0.05, hi=0.4)
        if r.direction > 0
        else dataclasses.replace(r, lo=0.55, hi=0.9)
        for r in _runs(0.95)
        if r.kind == "load"
    ] + [r for r in _runs(0.95) if r.kind == "geometric"]
    rep = _check(runs)
    assert [f.message for f in rep.errors] == [
        "the load passes of the two directions leave no common position to train on"
    ]
    assert rep.valid_range is None


def test_passes_to_score_are_not_narrowed():
    """``te score`` fits nothing: where its loads were recorded bounds no model."""
    rep = _check(_runs(0.25), for_score=True)
    assert _coverage(rep) == []
    assert rep.valid_range == pytest.approx((0.05, 0.95), abs=1e-3)


def test_import_and_model_context_carry_the_narrowed_range(tmp_path):
    """The range ``te import`` reports is the one a fitted model stores (``model_context``)."""
    from drivelash.te.protocol.bench import model_context
    from drivelash.te.protocol.campaign import load_campaign
    from drivelash.te.protocol.importer import import_campaign

    warnings: list[str] = []
    _, rep = import_campaign(
        write_axis(tmp_path / "rec", _runs(0.25)), tmp_path / "camp", warn=warnings.append
    )
    assert sum("pinion teeth never mesh" in w for w in warnings) == 2
    assert rep.valid_range == pytest.approx((0.08, 0.22), abs=1e-3)
    camp = load_campaign(tmp_path / "camp")
    vr = model_context(camp, 3000.0).valid_range
    assert (vr.x_min, vr.x_max) == pytest.approx((0.08, 0.22), abs=1e-3)


@pytest.mark.slow
@pytest.mark.parametrize("load_hi", [0.25, 0.45], ids=["140mm_rows", "340mm_rows"])
def test_unseen_teeth_are_not_known(tmp_path, load_hi):
    """The measurement behind the rule and the README's figures: fitted on 140 mm of rows, the
    model's load term at 1500 N (a load between the trained ones) is off by 0.7–1.2 times the term
    itself over the rest of the travel (measured 1.15 / 0.70 µm for 0.98) and by 0.05 times on the
    rows (0.047 µm); on 340 mm of rows (every tooth seen) 0.08 µm over the rest. Reference:
    :func:`synth.te_of`."""
    from drivelash.te.learn.fit import fit_te_model, prepare_campaign
    from drivelash.te.learn.network import MLPRegressor
    from drivelash.te.learn.stacked import StackedTERegressor
    from drivelash.te.protocol.campaign import load_campaign
    from drivelash.te.protocol.importer import import_campaign

    import_campaign(write_axis(tmp_path / "rec", _runs(load_hi)), tmp_path / "camp")
    pipeline, geo, runs = prepare_campaign(load_campaign(tmp_path / "camp"))
    est = StackedTERegressor(nn=MLPRegressor(max_epochs=60), n_trials=6, random_state=0)
    model = fit_te_model(pipeline, geo, runs, 3000.0, (), est)
    x = np.arange(0.06, 0.94, 5e-5)
    F = 1500.0
    for d, key in ((1, "pos"), (-1, "neg")):
        torque = d * (F + BENCH.F_CT) * BENCH.r_eff / 0.95 + d * BENCH.T_Cm  # synth.columns' torque
        ref = (te_of(x, d, F + BENCH.F_CT) - te_of(x, d, BENCH.F_CT)) * 1e6
        rows = np.concatenate([r.x for r in runs[key]])
        on = (x >= rows.min()) & (x <= rows.max())
        err = model.predict_def_um(x, np.full_like(x, torque), d) - ref
        err -= np.mean(err[on])  # TE_def is offset-free
        mae_on, mae_off = np.mean(np.abs(err[on])), np.mean(np.abs(err[~on]))
        term = np.mean(np.abs(ref - np.mean(ref)))  # what the load term itself amounts to: 0.98 µm
        assert mae_on < 0.1, (key, mae_on)
        if load_hi == 0.25:
            assert round(mae_on / term, 2) == 0.05, (key, mae_on, term)
            assert 0.65 <= mae_off / term <= 1.25, (key, mae_off, term)  # README: 0.7–1.2 times
        else:
            assert mae_off < 0.15, (key, mae_off)  # negative control: every tooth seen
