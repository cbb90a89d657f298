"""Stacked transmission-error model (spec 02 §4): neural network + bagged regression trees.

One :class:`StackedTERegressor` per direction of travel, scikit-learn compatible:

* stage 1 — :class:`~drivelash.te.learn.network.MLPRegressor` on the standardised
  inputs torque and M_1 … M_nt (never position), tuned by Hyperband;
* stage 2 — ``BaggingRegressor(DecisionTreeRegressor)`` on the stage-1 residual
  with inputs table position (and torque); number of trees, maximum depth and
  minimum leaf size by ``GridSearchCV`` on position-blocked groups
  (``GroupKFold``; never shuffled K-fold).

Inputs of every estimator here are the design matrix of
:meth:`drivelash.te.learn.preprocess.TEPipeline.design_matrix`: columns
``[x_T [m], torque [N·m], M_1 … M_nt]``; targets are TE_def in **micrometres**.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.ensemble import BaggingRegressor
from sklearn.model_selection import GridSearchCV, GroupKFold
from sklearn.tree import DecisionTreeRegressor
from sklearn.utils.validation import check_is_fitted, validate_data

from drivelash.errors import DataError, ParameterError
from drivelash.te.learn.network import MLPRegressor, tune_mlp

__all__ = [
    "DEFAULT_TREE_GRID",
    "STAGE1_COLS",
    "STAGE2_COLS",
    "STAGE2_INPUTS",
    "StackedTERegressor",
    "default_trees",
    "grid_search_trees",
    "position_blocks",
]

#: Column indices of the design matrix used by each stage.
STAGE1_COLS = slice(1, None)  # torque, M_1 … M_nt
STAGE2_COLS = [0, 1]  # x_T, torque
#: Stage-2 input columns by :attr:`StackedTERegressor.stage2_inputs`.
STAGE2_INPUTS = {"position": [0], "position+torque": [0, 1]}

#: Default stage-2 grid (number of trees, depth, leaf size); reasons in docs/assumptions.md.
DEFAULT_TREE_GRID: dict[str, list[Any]] = {
    "n_estimators": [8, 16],
    "estimator__max_depth": [20, None],
    "estimator__min_samples_leaf": [1, 5],
}


def position_blocks(x: np.ndarray, block_length: float) -> np.ndarray:
    """Group label of each row: index of its position block of ``block_length`` [m]."""
    if not block_length > 0:
        raise ParameterError("position_blocks", "block_length", f"must be > 0, got {block_length!r}")
    return np.floor(np.asarray(x, dtype=np.float64) / block_length).astype(np.int64)


def default_trees(random_state: int = 0) -> BaggingRegressor:
    """``BaggingRegressor(DecisionTreeRegressor)`` with bootstrap, all features, one job.

    Parameters
    ----------
    random_state : int
        Seed of the trees and of the bagging (16 estimators until the grid search sets them).
    """
    return BaggingRegressor(
        estimator=DecisionTreeRegressor(random_state=random_state),
        n_estimators=16,
        random_state=random_state,
        n_jobs=1,
    )


def grid_search_trees(
    base: BaggingRegressor,
    X2: np.ndarray,
    r: np.ndarray,
    groups: np.ndarray,
    grid: Mapping[str, list[Any]],
    folds: int = 4,
    n_jobs: int = 2,
) -> dict[str, Any]:
    """Grid search of the bagged trees with position-grouped folds; returns the best parameters."""
    search = GridSearchCV(
        clone(base),
        dict(grid),
        scoring="neg_mean_absolute_error",
        cv=GroupKFold(n_splits=folds),
        n_jobs=n_jobs,
        refit=False,
    )
    search.fit(X2, r, groups=groups)
    return {
        "best_params": dict(search.best_params_),
        "best_cv_mae": float(-search.best_score_),
    }


class StackedTERegressor(RegressorMixin, BaseEstimator):
    """Stage 1 network (torque, M_j) + stage 2 bagged trees (x_T [, torque]) on its residual.

    Parameters
    ----------
    nn : MLPRegressor, optional
        Stage-1 template (default :class:`MLPRegressor` ()); nested parameters ``nn__*``.
    trees : BaggingRegressor, optional
        Stage-2 template (default :func:`default_trees`); nested parameters ``trees__*``.
    tune_nn : bool
        Choose ``hidden``, ``dropout``, ``lr`` by Hyperband (else use ``nn`` as given).
    n_trials : int
        Optuna trials.
    tune_trees : bool
        Choose ``n_estimators``, ``max_depth``, ``min_samples_leaf`` by grid search.
    tree_grid : dict, optional
        Grid (default :data:`DEFAULT_TREE_GRID`).
    block_length : float
        Position block [m] defining the CV groups.
    cv_folds : int
        Folds of ``GroupKFold``.
    nn_stride : int
        Every ``nn_stride``-th row trains stage 1 (the low-passed target is
        oversampled on the 50 µm grid).
    search_stride : int
        Every ``search_stride``-th row enters the grid search.
    tree_stride : int
        Every ``tree_stride``-th row enters the final stage-2 fit.
    update_stride : int
        Every ``update_stride``-th row enters the stage-2 refit of :meth:`update`.
    stage2_inputs : {"position", "position+torque"}
        Inputs of the trees. ``"position"`` (default): stage 2 learns the residual that
        is common to all loads at a position (local rack deviations, wear) and leaves
        the load dependence to the network; with ``"position+torque"`` the trees can
        also split on torque, which replays the residual of the nearest *training*
        load at unseen loads (measured: worse on held-out and extrapolated loads,
        see docs/assumptions.md).
    torch_threads : int
        Threads of torch while training stage 1.
    n_jobs : int
        Parallel jobs of the grid search.
    random_state : int
        Seed.
    """

    def __init__(
        self,
        nn: MLPRegressor | None = None,
        trees: BaggingRegressor | None = None,
        tune_nn: bool = True,
        n_trials: int = 10,
        tune_trees: bool = True,
        tree_grid: dict[str, list[Any]] | None = None,
        block_length: float = 2e-3,
        cv_folds: int = 3,
        nn_stride: int = 2,
        search_stride: int = 16,
        tree_stride: int = 4,
        update_stride: int = 8,
        stage2_inputs: str = "position",
        n_jobs: int = 1,
        torch_threads: int = 1,
        random_state: int = 0,
    ) -> None:
        self.nn = nn
        self.trees = trees
        self.tune_nn = tune_nn
        self.n_trials = n_trials
        self.tune_trees = tune_trees
        self.tree_grid = tree_grid
        self.block_length = block_length
        self.cv_folds = cv_folds
        self.nn_stride = nn_stride
        self.search_stride = search_stride
        self.tree_stride = tree_stride
        self.update_stride = update_stride
        self.stage2_inputs = stage2_inputs
        self.n_jobs = n_jobs
        self.torch_threads = torch_threads
        self.random_state = random_state

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        """Parameters; with ``deep`` also ``nn__*`` and ``trees__*`` of the templates — of the
        defaults when ``nn``/``trees`` are None, so ``GridSearchCV`` reaches them.

        Parameters
        ----------
        deep : bool
            Also the nested ``nn__*`` and ``trees__*`` parameters.
        """
        params = super().get_params(deep=False)
        if deep:
            for name, est in (("nn", self._nn_template()), ("trees", self._trees_template())):
                if not hasattr(est, "get_params"):
                    continue  # not an estimator (an invalid value is reported by fit)
                for k, v in est.get_params(deep=True).items():
                    params[f"{name}__{k}"] = v
        return params

    def set_params(self, **params: Any) -> StackedTERegressor:
        """Set parameters, including nested ``nn__*``/``trees__*`` (templates are created if None).

        Parameters
        ----------
        **params
            Parameters by name, nested ones as ``nn__hidden``, ``trees__n_estimators``.

        Raises
        ------
        ParameterError
            Nested parameters for a template that is not an estimator.
        """
        nested: dict[str, dict[str, Any]] = {"nn": {}, "trees": {}}
        own = {}
        for k, v in params.items():
            head, sep, tail = k.partition("__")
            if sep and head in nested:
                nested[head][tail] = v
            else:
                own[k] = v
        super().set_params(**own)
        for name, template in (("nn", self._nn_template), ("trees", self._trees_template)):
            if nested[name]:
                est = template()
                if not hasattr(est, "set_params"):
                    raise ParameterError("StackedTERegressor", name, f"is not an estimator ({est!r})")
                setattr(self, name, clone(est).set_params(**nested[name]))
        return self

    def _stage2_cols(self) -> list[int]:
        try:
            return STAGE2_INPUTS[self.stage2_inputs]
        except KeyError:
            raise ParameterError(
                "StackedTERegressor",
                "stage2_inputs",
                f"must be one of {', '.join(STAGE2_INPUTS)}, got {self.stage2_inputs!r}",
            ) from None

    def _nn_template(self) -> MLPRegressor:
        return self.nn if self.nn is not None else MLPRegressor(random_state=self.random_state)

    def _trees_template(self) -> BaggingRegressor:
        return self.trees if self.trees is not None else default_trees(self.random_state)

    # -- fitting -------------------------------------------------------------
    def fit(self, X: Any, y: Any) -> StackedTERegressor:
        """Fit both stages.

        Parameters
        ----------
        X : array-like, shape (n, 2 + n_t)
            ``[x_T [m], torque [N·m], M_1 … M_nt]``.
        y : array-like, shape (n,)
            TE_def [µm].

        Returns
        -------
        StackedTERegressor
            ``self``; fitted attributes ``nn_``, ``trees_``, ``stage1_share_``,
            ``train_mae_``, ``nn_info_``, ``tree_info_``, ``fit_time_``.

        Raises
        ------
        ParameterError
            A stride that is not a positive integer, or ``nn``/``trees`` that is not an estimator.
        """
        X, y = validate_data(self, X, y, dtype=np.float64, y_numeric=True, ensure_min_features=2)
        for name in ("nn_stride", "search_stride", "tree_stride", "update_stride", "cv_folds"):
            v = getattr(self, name)
            if not (isinstance(v, (int, np.integer)) and v >= 1):
                raise ParameterError("StackedTERegressor", name, f"must be a positive integer, got {v!r}")
        for name, base in (("nn", self._nn_template()), ("trees", self._trees_template())):
            if not (hasattr(base, "fit") and hasattr(base, "get_params")):
                raise ParameterError("StackedTERegressor", name, f"must be an estimator, got {base!r}")
        t0 = time.perf_counter()
        s = int(self.nn_stride)
        X1 = X[:, STAGE1_COLS]
        if self.tune_nn:
            self.nn_, self.nn_info_ = tune_mlp(
                self._nn_template(),
                X1[::s],
                y[::s],
                n_trials=self.n_trials,
                seed=self.random_state,
                torch_threads=self.torch_threads,
            )
        else:
            from drivelash.te.learn.numerics import pin_training_numerics

            pin_training_numerics()
            import torch

            torch.set_num_threads(int(self.torch_threads))
            self.nn_ = clone(self._nn_template()).fit(X1[::s], y[::s])
            self.nn_info_ = {"best_params": {}, "best_val_mae": self.nn_.best_val_mae_}
        t1 = time.perf_counter()
        self._fit_trees(X, y, mode="search" if self.tune_trees else "template")
        self.fit_time_ = {"nn": t1 - t0, "trees": time.perf_counter() - t1, "total": time.perf_counter() - t0}
        self._score_train(X, y)
        return self

    def _fit_trees(self, X: np.ndarray, y: np.ndarray, mode: str) -> None:
        """Fit stage 2 on the stage-1 residual: ``mode`` "search" (grid search), "template", "keep"."""
        ts = int(self.update_stride if mode == "keep" else self.tree_stride)
        ss = int(self.search_stride)
        g = math.gcd(ts, ss) if mode == "search" else ts
        Xg = X[::g]  # the stage-1 residual is needed on these rows only
        r = y[::g] - self.nn_.predict(Xg[:, STAGE1_COLS])
        X2 = Xg[:, self._stage2_cols()]
        base = self._trees_template()
        ts, ss = ts // g, ss // g
        if mode == "search":
            groups = position_blocks(Xg[::ss, 0], float(self.block_length))
            n_groups = np.unique(groups).size
            folds = min(int(self.cv_folds), n_groups)
            if folds < 2:
                raise DataError("fewer than two position blocks: cannot cross-validate the trees")
            self.tree_info_ = grid_search_trees(
                base,
                X2[::ss],
                r[::ss],
                groups,
                self.tree_grid if self.tree_grid is not None else DEFAULT_TREE_GRID,
                folds=folds,
                n_jobs=int(self.n_jobs),
            )
            self.trees_ = clone(base).set_params(**self.tree_info_["best_params"])
        elif mode == "keep":
            self.trees_ = clone(self.trees_)
        else:
            self.trees_ = clone(base)
            self.tree_info_ = {"best_params": {}, "best_cv_mae": float("nan")}
        n_jobs = self.trees_.n_jobs
        self.trees_.set_params(n_jobs=int(self.n_jobs))  # the trees of the bag in parallel
        from joblib import parallel_backend

        with parallel_backend("threading"):  # tree building releases the GIL: no process start-up
            self.trees_.fit(X2[::ts], r[::ts])
        self.trees_.set_params(n_jobs=n_jobs)

    def _score_train(self, X: np.ndarray, y: np.ndarray) -> None:
        p1 = self.nn_.predict(X[:, STAGE1_COLS])
        p2 = self.trees_.predict(X[:, self._stage2_cols()])
        a1, a2 = np.abs(p1).sum(), np.abs(p2).sum()
        self.stage1_share_ = float(a1 / (a1 + a2)) if a1 + a2 > 0 else float("nan")
        self.train_mae_ = float(np.mean(np.abs(p1 + p2 - y)))

    def update(self, X: Any, y: Any, stage: str = "trees") -> StackedTERegressor:
        """Update with new data (wear, a new drive).

        Parameters
        ----------
        X, y : array-like
            New design matrix and TE_def [µm]; stage 2 is refitted on these rows only
            (with the hyperparameters found by the last grid search).
        stage : {"trees", "both"}
            ``"trees"``: refit stage 2 only; ``"both"``: fine-tune the network, then refit stage 2.

        Returns
        -------
        StackedTERegressor
            ``self``; ``update_time_`` [s]. ``train_mae_`` and ``stage1_share_`` keep the
            values of the last ``fit`` (not re-scored, to keep the update fast).

        Raises
        ------
        ParameterError
            ``stage`` other than ``"trees"`` or ``"both"``.
        """
        if stage not in ("trees", "both"):
            raise ParameterError(
                "StackedTERegressor.update", "stage", f"must be 'trees' or 'both', got {stage!r}"
            )
        check_is_fitted(self, ("nn_", "trees_"))
        X, y = validate_data(self, X, y, dtype=np.float64, y_numeric=True, reset=False)
        t0 = time.perf_counter()
        if stage == "both":
            s = int(self.nn_stride)
            self.nn_.fine_tune(X[::s, STAGE1_COLS], y[::s])
        self._fit_trees(X, y, mode="keep")
        self.update_time_ = time.perf_counter() - t0
        return self

    # -- prediction ----------------------------------------------------------
    def predict_stages(self, X: Any) -> tuple[np.ndarray, np.ndarray]:
        """Stage-1 and stage-2 outputs [µm] separately.

        Parameters
        ----------
        X : array_like, shape (n, 2 + n_t)
            ``[x_T [m], torque [N·m], M_1 … M_nt]``.
        """
        check_is_fitted(self, ("nn_", "trees_"))
        X = validate_data(self, X, dtype=np.float64, reset=False)
        return self.nn_.predict(X[:, STAGE1_COLS]), self.trees_.predict(X[:, self._stage2_cols()])

    def predict(self, X: Any) -> np.ndarray:
        """TE_def [µm] = stage 1 + stage 2.

        Parameters
        ----------
        X : array_like, shape (n, 2 + n_t)
            ``[x_T [m], torque [N·m], M_1 … M_nt]``.
        """
        p1, p2 = self.predict_stages(X)
        return p1 + p2
