"""``te update`` (issue 12 item 4): the wear update of a saved model, written as a new version.

Synthetic data of :mod:`conftest` (no simulator): the model is fitted on the unworn
deformation, the rack then develops a 3 µm local defect at x = 0.2 m. Held-out passes
(a load the update never sees) measure whether the update learnt the wear.
"""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.te.learn.preprocess import RunData
from drivelash.te.learn.update import restore_trained, update_errors, update_trained
from drivelash.te.runtime.persist import load_model, save_model

from .conftest import LOADS, te_def_um, torque_of

DEFECT_UM = 3.0


def _runs(x: np.ndarray, loads, defect: float) -> dict[str, list[RunData]]:
    # as the conftest's model was trained: the torque of the load, the target with the flank's sign
    out = {}
    for key, d in (("pos", 1), ("neg", -1)):
        out[key] = [RunData(x, torque_of(F, x), d * te_def_um(x, F, defect), d, {"load": F}) for F in loads]
    return out


@pytest.fixture(scope="module")
def saved(small_trained, tmp_path_factory):
    d = tmp_path_factory.mktemp("model") / "m1"
    save_model(small_trained, d)
    return d


def test_restored_model_predicts_what_the_saved_one_predicts(saved, grid_x):
    model, trained = restore_trained(saved)
    x = grid_x[::7]
    for d in (1, -1):
        tq = torque_of(1700.0, x)
        # stage 1: the restored torch network against the numba kernel on the same weights
        key = "pos" if d > 0 else "neg"
        X = trained.pipeline.design_matrix(x, tq)
        p1 = trained.models[key].nn_.predict(X[:, 1:])
        np.testing.assert_allclose(p1, model.predict_stage1_um(x, tq, d), atol=1e-9)
        # geometric curve: the same grid values (interpolation rounding only, 1e-15 m)
        np.testing.assert_allclose(trained.geo[key](x), model.geometric(x, d), rtol=0, atol=1e-15)


def test_update_on_worn_passes_learns_the_defect_on_held_out_loads(saved, grid_x):
    """The update removes ≥ 75 % of the held-out error that the wear added.

    The defect is a 3 µm Gaussian (σ 8 mm) that the old model never saw; its mean
    |value| over the 0.3 m grid is ≈ 0.2 µm. The wear's share of the held-out MAE is the
    MAE on the worn rack minus the old model's MAE on the unworn rack (e0); after the
    update at most 25 % of it may remain. Negative control: the same update on passes
    over the *unworn* rack keeps ≥ 75 % of it: the gain comes from the worn data, not
    from refitting.
    """
    model, trained = restore_trained(saved)
    x = grid_x
    train_loads = (0.0, 1000.0, 2000.0, 3000.0)
    held = (1500.0, 2500.0)
    worn_new = _runs(x, train_loads, DEFECT_UM)
    worn_held = _runs(x, held, DEFECT_UM)
    rec = update_trained(trained, worn_new, stage="trees", update_stride=1)
    assert set(rec["directions"]) == {"pos", "neg"}
    err = update_errors(model, trained, worn_held)
    base = update_errors(model, model, _runs(x, held, 0.0))  # the old model on the unworn rack
    for key in ("pos", "neg"):
        e0, eb, ea = base[key]["before_um"], err[key]["before_um"], err[key]["after_um"]
        assert eb - e0 > 0.1, (e0, eb)  # the wear is visible to the old model
        assert ea - e0 <= 0.25 * (eb - e0), (key, e0, eb, ea)
    # the defect region itself: the old model misses ~3 µm, the updated one learnt it
    near = np.abs(x - 0.2) < 0.01
    r = worn_held["pos"][0]
    miss_before = np.max(np.abs(model.predict_def_um(r.x, r.torque, 1) - r.te_def_um)[near])
    miss_after = np.max(np.abs(trained.predict_def_um(r.x, r.torque, 1) - r.te_def_um)[near])
    assert miss_before > 2.0 and miss_after < 0.5 * miss_before, (miss_before, miss_after)

    _, control = restore_trained(saved)
    update_trained(control, _runs(x, train_loads, 0.0), stage="trees", update_stride=1)
    err_c = update_errors(model, control, worn_held)
    for key in ("pos", "neg"):
        e0, eb, ea = base[key]["before_um"], err_c[key]["before_um"], err_c[key]["after_um"]
        assert ea - e0 >= 0.75 * (eb - e0), (key, e0, eb, ea)


def test_update_both_stages_fine_tunes_the_network(saved, grid_x):
    model, trained = restore_trained(saved)
    W_before = trained.models["pos"].nn_.weights()[0].copy()
    update_trained(trained, _runs(grid_x[::2], (0.0, 3000.0), DEFECT_UM), stage="both", update_stride=2)
    assert not np.allclose(trained.models["pos"].nn_.weights()[0], W_before)
    err = update_errors(model, trained, _runs(grid_x, (1500.0,), DEFECT_UM))
    assert err["pos"]["after_um"] < err["pos"]["before_um"]


def test_saved_update_round_trips(saved, grid_x, tmp_path):
    _, trained = restore_trained(saved)
    update_trained(trained, _runs(grid_x, LOADS[::3], DEFECT_UM), stage="trees", update_stride=2)
    save_model(trained, tmp_path / "m2")
    m2 = load_model(tmp_path / "m2")
    x = grid_x[::5]
    tq = torque_of(900.0, x)
    np.testing.assert_allclose(m2.predict(x, tq, 1), trained.predict(x, tq, 1), atol=1e-12)


def test_bad_stage_and_empty_update_are_errors(saved):
    from drivelash.errors import DataError, ParameterError

    _, trained = restore_trained(saved)
    with pytest.raises(ParameterError, match="stage"):
        update_trained(trained, {}, stage="all")
    with pytest.raises(DataError, match="no update pass"):
        update_trained(trained, {"pos": [], "neg": []})
