"""Stacked model: scikit-learn contract, stages, blocked CV, update; baselines."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.model_selection import GridSearchCV, GroupKFold

from drivelash.errors import ParameterError
from drivelash.te.learn.baselines import GeometricOnly, StageOne, fit_hgb, fit_trees_only
from drivelash.te.learn.fit import split_of
from drivelash.te.learn.network import MLPRegressor
from drivelash.te.learn.stacked import StackedTERegressor, default_trees, position_blocks

from .conftest import design, te_def_um


def _fast(**kw) -> StackedTERegressor:
    base = dict(
        nn=MLPRegressor(hidden=16, max_epochs=10, patience=3, batch_size=256),
        trees=default_trees().set_params(n_estimators=4),
        tune_nn=False,
        tune_trees=False,
        nn_stride=2,
    )
    base.update(kw)
    return StackedTERegressor(**base)


def test_sklearn_contract():
    est = StackedTERegressor()
    params = est.get_params(deep=True)
    for k in ("nn__hidden", "nn__dropout", "nn__lr", "trees__n_estimators", "trees__estimator__max_depth"):
        assert k in params
    est.set_params(nn__hidden=8, trees__estimator__min_samples_leaf=3)
    assert est.nn.hidden == 8 and est.trees.estimator.min_samples_leaf == 3
    c = clone(est)
    assert c.get_params()["nn__hidden"] == 8 and c.nn is not est.nn
    assert not any(k.endswith("_") for k in vars(StackedTERegressor()))  # nothing fitted in __init__
    with pytest.raises(ValueError, match="1 feature"):  # x_T and torque at least
        StackedTERegressor().fit(np.zeros((5, 1)), np.zeros(5))
    with pytest.raises(ParameterError):
        MLPRegressor(dropout=1.5).fit(np.zeros((20, 3)), np.zeros(20))


def test_fit_returns_self_and_stage2_fits_the_residual(train_xy):
    """With torque among its inputs, stage 2 takes out most of the network's training residual."""
    X, y = train_xy
    est = _fast(stage2_inputs="position+torque")
    assert est.fit(X, y) is est
    fitted = [k for k in vars(est) if k.endswith("_") and not k.startswith("_")]
    assert {"nn_", "trees_", "stage1_share_", "train_mae_"} <= set(fitted)
    p1, p2 = est.predict_stages(X)
    np.testing.assert_allclose(est.predict(X), p1 + p2)
    mae1 = np.mean(np.abs(p1 - y))
    assert est.train_mae_ < 0.2 * mae1  # the trees take out most of the network's training residual
    assert 0.0 < est.stage1_share_ < 1.0


def test_gridsearch_reaches_nested_params(train_xy):
    X, y = train_xy
    Xs, ys = X[::8], y[::8]
    groups = position_blocks(Xs[:, 0], 0.05)
    gs = GridSearchCV(
        _fast(nn=MLPRegressor(hidden=8, max_epochs=3, patience=2)),
        {"trees__n_estimators": [1, 3]},
        cv=GroupKFold(n_splits=3),
        scoring="neg_mean_absolute_error",
    )
    gs.fit(Xs, ys, groups=groups)
    assert gs.best_params_["trees__n_estimators"] in (1, 3)


def test_position_blocks_never_split_a_block_across_folds():
    x = np.linspace(0.0, 0.3, 3001)
    g = position_blocks(x, 2e-3)
    assert np.unique(g).size == 151
    for tr, te in GroupKFold(n_splits=4).split(x, groups=g):
        assert not set(g[tr]) & set(g[te])


def test_hyperband_and_grid_search_choose_parameters(train_xy):
    X, y = train_xy
    est = StackedTERegressor(
        nn=MLPRegressor(max_epochs=9, patience=3, batch_size=512),
        n_trials=3,
        tree_grid={
            "n_estimators": [2, 4],
            "estimator__max_depth": [6, 24],
            "estimator__min_samples_leaf": [1],
        },
        cv_folds=3,
        nn_stride=4,
        search_stride=4,
        n_jobs=1,
    ).fit(X, y)
    assert est.nn_info_["n_trials"] == 3
    assert set(est.nn_info_["best_params"]) == {"hidden", "dropout", "lr"}
    assert est.nn_.hidden == est.nn_info_["best_params"]["hidden"]
    bp = est.tree_info_["best_params"]
    assert est.trees_.n_estimators == bp["n_estimators"]
    assert est.trees_.estimator.max_depth == bp["estimator__max_depth"]
    assert bp["estimator__max_depth"] == 24  # the shallow trees cannot follow the residual


def test_update_trees_learns_a_local_defect(pipe, grid_x, train_xy):
    X, y = train_xy
    est = _fast().fit(X, y)
    loads = (0.0, 1000.0, 2000.0, 3000.0)
    Xn = np.vstack([design(grid_x, F, pipe) for F in loads])
    yn = np.concatenate([te_def_um(grid_x, F, defect=1.0) for F in loads])
    Xh, yh = design(grid_x, 1500.0, pipe), te_def_um(grid_x, 1500.0, defect=1.0)
    near = np.abs(grid_x - 0.2) < 0.025  # around the defect
    before = np.mean(np.abs(est.predict(Xh) - yh)[near])
    nn_before = est.nn_.predict(Xh[:, 1:])
    est.update(Xn, yn, stage="trees")
    after = np.mean(np.abs(est.predict(Xh) - yh)[near])
    np.testing.assert_array_equal(est.nn_.predict(Xh[:, 1:]), nn_before)  # stage 1 untouched
    assert after < 0.5 * before
    assert est.update_time_ > 0
    est.update(Xn, yn, stage="both")
    assert np.any(est.nn_.predict(Xh[:, 1:]) != nn_before)  # stage 1 fine-tuned
    with pytest.raises(ParameterError):
        est.update(Xn, yn, stage="all")
    with pytest.raises(NotFittedError):
        _fast().update(Xn, yn)


def test_baselines_and_split(train_xy):
    X, y = train_xy
    assert np.all(GeometricOnly().fit(X, y).predict(X) == 0.0)
    est = _fast().fit(X, y)
    np.testing.assert_array_equal(StageOne(est).predict(X), est.predict_stages(X)[0])
    trees, info = fit_trees_only(
        X,
        y,
        grid={"n_estimators": [2], "estimator__max_depth": [20], "estimator__min_samples_leaf": [1]},
        n_jobs=1,
    )
    assert np.mean(np.abs(trees.predict(X) - y)) < 0.1 * np.mean(np.abs(y))
    hgb = fit_hgb(X[::4], y[::4], max_iter=40)
    assert np.mean(np.abs(hgb.predict(X) - y)) < 0.2 * np.mean(np.abs(y))
    assert split_of(1000.0, 3000.0, (1000.0,)) == "held-out"
    assert split_of(3500.0, 3000.0, (1000.0,)) == "extrapolation"
    assert split_of(3000.0, 3000.0, (1000.0,)) == "train"


def test_offset_line_recovers_mean_compliance():
    from drivelash.te.learn.fit import fit_offset_line
    from drivelash.te.learn.preprocess import RunData

    runs = [
        RunData(np.zeros(3), np.zeros(3), np.zeros(3), 1, {"torque_mean": t, "offset_um": 0.3 - 1.5 * t})
        for t in (0.9, 3.6, 6.2, 8.9)
    ]
    a, b = fit_offset_line(runs)
    assert a == pytest.approx(0.3, abs=1e-12) and b == pytest.approx(-1.5, abs=1e-12)


def test_position_only_stage2_ignores_torque(train_xy):
    """The default stage 2 sees position only: its output does not change with torque, and
    it still reduces the network's training residual (the part common to all loads)."""
    X, y = train_xy
    est = _fast().fit(X, y)
    assert est.stage2_inputs == "position"
    X2 = X.copy()
    X2[:, 1] = X2[:, 1] * 3.0 + 1.0
    np.testing.assert_array_equal(est.predict_stages(X)[1], est.predict_stages(X2)[1])
    p1, _ = est.predict_stages(X)
    assert est.train_mae_ < np.mean(np.abs(p1 - y))


def test_unknown_stage2_inputs_is_a_parameter_error(train_xy):
    X, y = train_xy
    with pytest.raises(ParameterError, match="stage2_inputs"):
        _fast(stage2_inputs="torque").fit(X[:500], y[:500])
