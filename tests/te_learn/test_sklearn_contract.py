"""scikit-learn contract of the estimators the README calls compatible (issue 13 item 4).

``parametrize_with_checks`` runs every check of ``check_estimator`` on
:class:`MLPRegressor` (stage 1) and :class:`StackedTERegressor` (the stack), with small
settings so the fast suite stays fast (a 16-node network, ≤ 15 epochs, 4 trees, no
hyperparameter search): set_params/get_params/clone, validation in ``fit`` (finite,
dense, 2-D, ``n_features_in_``), ``NotFittedError`` before ``fit``, fitted attributes
ending in ``_``, and a regression score > 0.5 on scikit-learn's test data.
"""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.model_selection import GridSearchCV
from sklearn.utils.estimator_checks import parametrize_with_checks

from drivelash.te.learn.network import MLPRegressor
from drivelash.te.learn.stacked import StackedTERegressor, default_trees


@pytest.fixture(autouse=True)
def _one_torch_thread():
    """One torch thread, as the learner uses (per-op threading of a 16-node net only costs).

    The code path is pinned first, as every training entry point does: touching torch before
    the pin fixes its kernels for the process, and the first fit here then warned (under
    pytest-xdist, whenever this file's tests were the first of a worker to use torch)."""
    from drivelash.te.learn.numerics import pin_training_numerics

    pin_training_numerics()
    import torch

    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


def _mlp() -> MLPRegressor:
    return MLPRegressor(hidden=16, lr=2e-2, max_epochs=15, patience=3, batch_size=64)


def _stacked() -> StackedTERegressor:
    return StackedTERegressor(nn=_mlp(), trees=default_trees().set_params(n_estimators=4), tune_nn=False,
                              tune_trees=False, nn_stride=1, tree_stride=1, update_stride=1)  # fmt: skip


# slow since session 33 (≈ 100 of scikit-learn's conformance checks, 9 s of `make test`); the grid
# search over nested parameters below stays fast
@pytest.mark.slow
@parametrize_with_checks([_mlp(), _stacked()])
def test_sklearn_compatible_estimator(estimator, check):
    check(estimator)


def test_grid_search_reaches_nested_parameters_of_the_default_templates():
    # nn / trees left at None: their defaults' parameters are still reachable as nn__*, trees__*
    est = StackedTERegressor(tune_nn=False, tune_trees=False, nn_stride=1, tree_stride=1)
    params = est.get_params(deep=True)
    assert params["nn__hidden"] == MLPRegressor().hidden
    assert params["trees__n_estimators"] == default_trees().n_estimators
    rng = np.random.default_rng(0)
    X = rng.uniform(0, 1, (240, 3))
    y = np.sin(6 * X[:, 1]) + 0.1 * X[:, 0]
    grid = {"nn__hidden": [4, 8], "trees__n_estimators": [2, 3]}
    est.set_params(nn__max_epochs=5, nn__batch_size=64)
    search = GridSearchCV(est, grid, cv=2).fit(X, y)
    assert set(search.best_params_) == set(grid)
    best = search.best_estimator_
    assert best.nn_.hidden == search.best_params_["nn__hidden"]
    assert len(best.trees_.estimators_) == search.best_params_["trees__n_estimators"]
    assert clone(est).get_params()["nn__max_epochs"] == 5
