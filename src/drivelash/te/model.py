"""Stacked transmission-error model (spec 02 §4): neural network + bagged regression trees.

One :class:`StackedTERegressor` per direction of travel, scikit-learn compatible:

* stage 1 — :class:`MLPRegressor`, a PyTorch network with two hidden ReLU layers and
  dropout, trained by Adam with early stopping on the validation MAE, on the
  standardised inputs torque and M_1 … M_nt (never position); dropout, width and
  learning rate by Optuna with the Hyperband pruner (:func:`tune_mlp`);
* stage 2 — ``BaggingRegressor(DecisionTreeRegressor)`` on the stage-1 residual
  with inputs table position and torque; number of trees, maximum depth and
  minimum leaf size by ``GridSearchCV`` on position-blocked groups
  (``GroupKFold``; never shuffled K-fold).

Inputs of every estimator here are the design matrix of
:meth:`drivelash.te.preprocess.TEPipeline.design_matrix`: columns
``[x_T [m], torque [N·m], M_1 … M_nt]``; targets are TE_def in **micrometres**.

:class:`TrainedTEModel` bundles the geometric curves and both directions and
predicts the full TE in **metres**; :func:`drivelash.te.persist.save_model` writes it
to a directory that :func:`drivelash.te.persist.load_model` reads without torch.

torch and optuna are imported only inside the training code paths.
"""

from __future__ import annotations

import copy
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.ensemble import BaggingRegressor
from sklearn.model_selection import GridSearchCV, GroupKFold
from sklearn.tree import DecisionTreeRegressor

from drivelash.errors import DataError, ParameterError
from drivelash.te.preprocess import UM, GearGeometry, GeometricCurve, RunData, TEPipeline, direction_key

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

#: Default Hyperband search space of stage 1.
DEFAULT_NN_SPACE: dict[str, tuple[Any, ...]] = {
    "hidden": (16, 32, 48, 64),
    "dropout": (0.0, 0.2),
    "lr": (1e-3, 2e-2),
}


def _check_xy(X: Any, y: Any | None = None, min_cols: int = 3) -> tuple[np.ndarray, np.ndarray | None]:
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2 or X.shape[1] < min_cols:
        raise DataError(f"design matrix must be 2-D with >= {min_cols} columns, got shape {X.shape}")
    if not np.all(np.isfinite(X)):
        raise DataError("design matrix contains NaN or inf")
    if y is None:
        return X, None
    y = np.asarray(y, dtype=np.float64).reshape(-1)
    if y.size != X.shape[0]:
        raise DataError(f"target has {y.size} values for {X.shape[0]} rows")
    if not np.all(np.isfinite(y)):
        raise DataError("target contains NaN or inf")
    return X, y


# ---------------------------------------------------------------------------
# stage 1: the network
# ---------------------------------------------------------------------------
def _make_net(n_in: int, hidden: int, dropout: float):  # noqa: ANN202 - torch type, lazy import
    import torch

    return torch.nn.Sequential(
        torch.nn.Linear(n_in, hidden),
        torch.nn.ReLU(),
        torch.nn.Dropout(dropout),
        torch.nn.Linear(hidden, hidden),
        torch.nn.ReLU(),
        torch.nn.Dropout(dropout),
        torch.nn.Linear(hidden, 1),
    )


class MLPRegressor(RegressorMixin, BaseEstimator):
    """Two-hidden-layer ReLU network with dropout, Adam and early stopping (PyTorch).

    Inputs and target are standardised inside ``fit``; prediction is in the target's
    units. Trained in float32; after training the network is kept in float64 so the
    NumPy/numba re-implementation in :mod:`drivelash.te.persist` reproduces it to
    rounding.

    Parameters
    ----------
    hidden : int
        Nodes per hidden layer.
    dropout : float
        Dropout rate after each hidden layer.
    lr : float
        Adam learning rate.
    max_epochs : int
        Upper limit of epochs.
    patience : int
        Epochs without improvement of the validation MAE before stopping.
    batch_size : int
        Mini-batch size.
    val_fraction : float
        Share of the rows drawn at random as validation set (paper §IV).
    weight_decay : float
        L2 penalty of Adam (on standardised inputs and target).
    random_state : int
        Seed of torch and of the split.
    """

    def __init__(
        self,
        hidden: int = 32,
        dropout: float = 0.05,
        lr: float = 5e-3,
        max_epochs: int = 60,
        patience: int = 8,
        batch_size: int = 1024,
        val_fraction: float = 0.15,
        weight_decay: float = 0.0,
        random_state: int = 0,
    ) -> None:
        self.hidden = hidden
        self.dropout = dropout
        self.lr = lr
        self.max_epochs = max_epochs
        self.patience = patience
        self.batch_size = batch_size
        self.val_fraction = val_fraction
        self.weight_decay = weight_decay
        self.random_state = random_state

    def _check_params(self) -> None:
        if not (isinstance(self.hidden, (int, np.integer)) and self.hidden >= 1):
            raise ParameterError("MLPRegressor", "hidden", f"must be a positive integer, got {self.hidden!r}")
        if not 0.0 <= self.dropout < 1.0:
            raise ParameterError("MLPRegressor", "dropout", f"must be in [0, 1), got {self.dropout!r}")
        if not self.lr > 0:
            raise ParameterError("MLPRegressor", "lr", f"must be > 0, got {self.lr!r}")
        if not 0.0 < self.val_fraction < 0.9:
            raise ParameterError(
                "MLPRegressor", "val_fraction", f"must be in (0, 0.9), got {self.val_fraction!r}"
            )

    def fit(
        self,
        X: Any,
        y: Any,
        epoch_callback: Callable[[int, float], None] | None = None,
    ) -> MLPRegressor:
        """Train from scratch.

        Parameters
        ----------
        X : array-like, shape (n, p)
            Inputs (any units; standardised here).
        y : array-like, shape (n,)
            Target.
        epoch_callback : callable, optional
            ``callback(epoch, val_mae)`` after each epoch (val MAE in target units);
            may raise to abort (Optuna pruning).

        Returns
        -------
        MLPRegressor
            ``self``.
        """
        self._check_params()
        X, y = _check_xy(X, y, min_cols=1)
        assert y is not None
        self.n_features_in_ = X.shape[1]
        self.x_mean_ = X.mean(axis=0)
        sd = X.std(axis=0)
        self.x_scale_ = np.where(sd > 1e-12, sd, 1.0)
        self.y_mean_ = float(y.mean())
        self.y_scale_ = float(y.std()) if y.std() > 1e-15 else 1.0
        import torch

        torch.manual_seed(int(self.random_state))
        net = _make_net(X.shape[1], int(self.hidden), float(self.dropout))
        self._train(net, X, y, float(self.lr), int(self.max_epochs), epoch_callback)
        return self

    def fine_tune(self, X: Any, y: Any, epochs: int = 15, lr_factor: float = 0.2) -> MLPRegressor:
        """Continue training the fitted network on new data (standardisation kept).

        Parameters
        ----------
        X, y : array-like
            New inputs and target.
        epochs : int
            Maximum epochs (early stopping still applies).
        lr_factor : float
            Learning rate = ``lr_factor · lr``.
        """
        X, y = _check_xy(X, y, min_cols=1)
        assert y is not None
        net = copy.deepcopy(self.net_).float()
        self._train(net, X, y, float(self.lr) * lr_factor, int(epochs), None)
        return self

    def _train(
        self,
        net: Any,
        X: np.ndarray,
        y: np.ndarray,
        lr: float,
        max_epochs: int,
        epoch_callback: Callable[[int, float], None] | None,
    ) -> None:
        import torch

        rng = np.random.default_rng(int(self.random_state))
        n = X.shape[0]
        perm = rng.permutation(n)
        n_val = max(1, int(round(self.val_fraction * n)))
        iv, it = perm[:n_val], perm[n_val:]
        Xs = ((X - self.x_mean_) / self.x_scale_).astype(np.float32)
        ys = ((y - self.y_mean_) / self.y_scale_).astype(np.float32)
        xt, yt = torch.from_numpy(Xs[it]), torch.from_numpy(ys[it])
        xv, yv = torch.from_numpy(Xs[iv]), torch.from_numpy(ys[iv])
        opt = torch.optim.Adam(net.parameters(), lr=lr, weight_decay=float(self.weight_decay))
        gen = torch.Generator().manual_seed(int(self.random_state))
        best = np.inf
        best_state = copy.deepcopy(net.state_dict())
        best_epoch = 0
        history: list[float] = []
        bs = int(self.batch_size)
        for epoch in range(max_epochs):
            net.train()
            order = torch.randperm(xt.shape[0], generator=gen)
            for k in range(0, xt.shape[0], bs):
                b = order[k : k + bs]
                opt.zero_grad()
                loss = torch.nn.functional.mse_loss(net(xt[b]).squeeze(-1), yt[b])
                loss.backward()
                opt.step()
            net.eval()
            with torch.no_grad():
                val = float(torch.mean(torch.abs(net(xv).squeeze(-1) - yv))) * self.y_scale_
            history.append(val)
            if val < best:
                best, best_epoch = val, epoch
                best_state = copy.deepcopy(net.state_dict())
            if epoch_callback is not None:
                epoch_callback(epoch, val)
            if epoch - best_epoch >= int(self.patience):
                break
        net.load_state_dict(best_state)
        self.net_ = net.double().eval()
        self.best_val_mae_ = best
        self.n_epochs_ = len(history)
        self.history_ = history

    def predict(self, X: Any) -> np.ndarray:
        """Prediction in target units (float64 forward pass of the trained network)."""
        import torch

        X, _ = _check_xy(X, min_cols=1)
        Xs = torch.from_numpy((X - self.x_mean_) / self.x_scale_)
        with torch.no_grad():
            out = self.net_(Xs).squeeze(-1).numpy()
        return out * self.y_scale_ + self.y_mean_

    def weights(self) -> list[np.ndarray]:
        """``[W1, b1, W2, b2, W3, b3]`` as float64 arrays, ``W`` shaped (inputs, outputs)."""
        layers = [m for m in self.net_ if hasattr(m, "weight")]
        out: list[np.ndarray] = []
        for lay in layers:
            out.append(np.ascontiguousarray(lay.weight.detach().numpy().T, dtype=np.float64))
            out.append(np.ascontiguousarray(lay.bias.detach().numpy(), dtype=np.float64))
        return out


def tune_mlp(
    base: MLPRegressor,
    X: np.ndarray,
    y: np.ndarray,
    n_trials: int = 10,
    space: Mapping[str, tuple[Any, ...]] | None = None,
    seed: int = 0,
    torch_threads: int = 1,
) -> tuple[MLPRegressor, dict[str, Any]]:
    """Choose hidden width, dropout and learning rate with Optuna's Hyperband pruner.

    Each trial trains ``clone(base)`` with the trial's parameters and reports the
    validation MAE per epoch (the resource of Hyperband is the epoch).

    Parameters
    ----------
    base : MLPRegressor
        Template (``max_epochs``, ``patience``, ``batch_size`` … are kept).
    X, y : numpy.ndarray
        Stage-1 inputs and target.
    n_trials : int
        Trials of the study.
    space : mapping, optional
        ``{"hidden": choices, "dropout": (lo, hi), "lr": (lo, hi)}`` (lr log-uniform).
    seed : int
        Seed of the TPE sampler.
    torch_threads : int
        ``torch.set_num_threads`` during the study (1: the network is small, per-op
        threading costs more than it gains; the second core fits the other direction).

    Returns
    -------
    best : MLPRegressor
        The fitted network of the best trial.
    info : dict
        ``best_params``, ``best_val_mae``, ``n_trials``, ``n_pruned``.
    """
    import optuna
    import torch

    torch.set_num_threads(int(torch_threads))
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    sp = dict(DEFAULT_NN_SPACE if space is None else space)
    pruner = optuna.pruners.HyperbandPruner(
        min_resource=3, max_resource=int(base.max_epochs), reduction_factor=3
    )
    study = optuna.create_study(
        direction="minimize", sampler=optuna.samplers.TPESampler(seed=seed), pruner=pruner
    )
    kept: dict[int, MLPRegressor] = {}

    def objective(trial: optuna.Trial) -> float:
        params = {
            "hidden": trial.suggest_categorical("hidden", list(sp["hidden"])),
            "dropout": trial.suggest_float("dropout", *sp["dropout"]),
            "lr": trial.suggest_float("lr", *sp["lr"], log=True),
        }
        model = clone(base).set_params(**params)

        def cb(epoch: int, val: float) -> None:
            trial.report(val, epoch)
            if trial.should_prune():
                raise optuna.TrialPruned()

        model.fit(X, y, epoch_callback=cb)
        kept[trial.number] = model
        best_now = min((t.value for t in study.trials if t.value is not None), default=np.inf)
        if model.best_val_mae_ > best_now:  # keep only the best fitted network in memory
            kept.pop(trial.number, None)
        return model.best_val_mae_

    study.optimize(objective, n_trials=int(n_trials))
    best_trial = study.best_trial
    n_pruned = sum(t.state == optuna.trial.TrialState.PRUNED for t in study.trials)
    return kept[best_trial.number], {
        "best_params": dict(best_trial.params),
        "best_val_mae": float(best_trial.value),
        "n_trials": len(study.trials),
        "n_pruned": int(n_pruned),
    }


# ---------------------------------------------------------------------------
# the stacked regressor
# ---------------------------------------------------------------------------
def position_blocks(x: np.ndarray, block_length: float) -> np.ndarray:
    """Group label of each row: index of its position block of ``block_length`` [m]."""
    if not block_length > 0:
        raise ParameterError("position_blocks", "block_length", f"must be > 0, got {block_length!r}")
    return np.floor(np.asarray(x, dtype=np.float64) / block_length).astype(np.int64)


def default_trees(random_state: int = 0) -> BaggingRegressor:
    """``BaggingRegressor(DecisionTreeRegressor)`` with bootstrap, all features, one job."""
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
        """Parameters; with ``deep`` also ``nn__*`` and ``trees__*`` of the (default) templates."""
        params = super().get_params(deep=False)
        if deep:
            for name, est in (("nn", self._nn_template()), ("trees", self._trees_template())):
                for k, v in est.get_params(deep=True).items():
                    params[f"{name}__{k}"] = v
        return params

    def set_params(self, **params: Any) -> StackedTERegressor:
        """Set parameters, including nested ``nn__*``/``trees__*`` (templates are created if None)."""
        nested: dict[str, dict[str, Any]] = {"nn": {}, "trees": {}}
        own = {}
        for k, v in params.items():
            head, sep, tail = k.partition("__")
            if sep and head in nested:
                nested[head][tail] = v
            else:
                own[k] = v
        super().set_params(**own)
        if nested["nn"]:
            self.nn = clone(self._nn_template()).set_params(**nested["nn"])
        if nested["trees"]:
            self.trees = clone(self._trees_template()).set_params(**nested["trees"])
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
        """
        X, y = _check_xy(X, y)
        assert y is not None
        for name in ("nn_stride", "search_stride", "tree_stride", "update_stride", "cv_folds"):
            v = getattr(self, name)
            if not (isinstance(v, (int, np.integer)) and v >= 1):
                raise ParameterError("StackedTERegressor", name, f"must be a positive integer, got {v!r}")
        t0 = time.perf_counter()
        self.n_features_in_ = X.shape[1]
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
        """
        if stage not in ("trees", "both"):
            raise ParameterError(
                "StackedTERegressor.update", "stage", f"must be 'trees' or 'both', got {stage!r}"
            )
        if not hasattr(self, "nn_"):
            raise DataError("update needs a fitted model; call fit first")
        X, y = _check_xy(X, y)
        assert y is not None
        t0 = time.perf_counter()
        if stage == "both":
            s = int(self.nn_stride)
            self.nn_.fine_tune(X[::s, STAGE1_COLS], y[::s])
        self._fit_trees(X, y, mode="keep")
        self.update_time_ = time.perf_counter() - t0
        return self

    # -- prediction ----------------------------------------------------------
    def predict_stages(self, X: Any) -> tuple[np.ndarray, np.ndarray]:
        """Stage-1 and stage-2 outputs [µm] separately."""
        X, _ = _check_xy(X)
        return self.nn_.predict(X[:, STAGE1_COLS]), self.trees_.predict(X[:, self._stage2_cols()])

    def predict(self, X: Any) -> np.ndarray:
        """TE_def [µm] = stage 1 + stage 2."""
        p1, p2 = self.predict_stages(X)
        return p1 + p2


# ---------------------------------------------------------------------------
# both directions + geometric curves
# ---------------------------------------------------------------------------
@dataclass
class TrainedTEModel:
    """Geometric curves and a stacked deformation model per direction (training side).

    Attributes
    ----------
    pipeline : TEPipeline
        Preprocessing (geometry, grid, filter).
    geo : dict
        ``{"pos": GeometricCurve, "neg": GeometricCurve}``, TE_geo in metres.
    models : dict
        ``{"pos": StackedTERegressor, "neg": …}``, TE_def in micrometres.
    info : dict
        JSON-serialisable training record (loads used, held-out runs, timings, scores).
    offset : dict
        ``{"pos": (a [µm], b [µm/(N·m)]), …}``: line through the per-run constants that the
        offset step removed (mean elastic deflection against mean torque), so that
        :meth:`predict` returns the absolute TE under load.
    """

    pipeline: TEPipeline
    geo: dict[str, GeometricCurve]
    models: dict[str, StackedTERegressor]
    info: dict[str, Any] = field(default_factory=dict)
    offset: dict[str, tuple[float, float]] = field(default_factory=dict)

    def predict_def_um(self, x_T: Any, torque: Any, direction: int) -> np.ndarray:
        """Deformation TE_def [µm] (offset-free, the learning target) at ``x_T`` [m], motor torque [N·m]."""
        X = self.pipeline.design_matrix(x_T, torque)
        return self.models[direction_key(direction)].predict(X)

    def offset_um(self, torque: Any, direction: int) -> np.ndarray:
        """Mean deformation a + b·torque [µm] removed by the offset step (0 if none was fitted)."""
        a, b = self.offset.get(direction_key(direction), (0.0, 0.0))
        return a + b * np.asarray(torque, dtype=np.float64)

    def predict(self, x_T: Any, torque: Any, direction: int) -> np.ndarray:
        """TE [m] = TE_geo(x_T) + (offset(torque) + TE_def(x_T, torque))·1e-6, direction +1/−1."""
        key = direction_key(direction)
        x = np.asarray(x_T, dtype=np.float64).reshape(-1)
        tq = np.broadcast_to(np.asarray(torque, dtype=np.float64), x.shape)
        return self.geo[key](x) + (self.offset_um(tq, direction) + self.predict_def_um(x, tq, direction)) / UM


# ---------------------------------------------------------------------------
# from a campaign to a trained model
# ---------------------------------------------------------------------------
def prepare_campaign(
    campaign: Any, pipeline: TEPipeline | None = None
) -> tuple[TEPipeline, dict[str, GeometricCurve], dict[str, list[RunData]]]:
    """Geometric curves and processed load runs of a campaign (:func:`drivelash.te.campaign.load_campaign`).

    Parameters
    ----------
    campaign : Campaign
        Needs ``bench`` (with ``d_p``, ``n_t``, ``i_PG``, ``epsilon``) and
        ``select(kind=…, direction=…)`` returning runs with ``trace()``, ``load``,
        ``velocity``, ``path``.
    pipeline : TEPipeline, optional
        Default: :class:`TEPipeline` with the bench geometry.

    Returns
    -------
    pipeline, geo, runs
        ``geo[key]`` from the ``geometric`` runs, ``runs[key]`` the ``load`` runs of
        each direction as :class:`RunData` (meta: load [N], velocity [m/s], name).
    """
    if pipeline is None:
        pipeline = TEPipeline(GearGeometry.from_bench(campaign.bench))
    geo: dict[str, GeometricCurve] = {}
    runs: dict[str, list[RunData]] = {}
    for d in (1, -1):
        key = direction_key(d)
        gruns = campaign.select(kind="geometric", direction=d)
        if not gruns:
            raise DataError(f"campaign has no geometric (no-load) run in direction {d:+d}")
        geo[key] = pipeline.geometric([r.trace().columns for r in gruns], d)
        runs[key] = [
            pipeline.process(
                r.trace().columns,
                d,
                geo[key],
                meta={"load": float(r.load), "velocity": float(r.velocity), "name": Path(r.path).stem},
            )
            for r in campaign.select(kind="load", direction=d)
        ]
        if not runs[key]:
            raise DataError(f"campaign has no load run in direction {d:+d}")
    return pipeline, geo, runs


def split_of(load: float, max_load: float, holdout_loads: tuple[float, ...]) -> str:
    """``"train"``, ``"held-out"`` (in range, left out) or ``"extrapolation"`` (above ``max_load``)."""
    if load > max_load + 1e-9:
        return "extrapolation"
    if any(abs(load - h) < 1e-6 for h in holdout_loads):
        return "held-out"
    return "train"


def stack_runs(runs: list[RunData], pipeline: TEPipeline) -> tuple[np.ndarray, np.ndarray]:
    """Design matrix and TE_def [µm] of several runs, concatenated."""
    if not runs:
        raise DataError("no runs to stack")
    X = np.vstack([pipeline.design_matrix(r.x, r.torque) for r in runs])
    y = np.concatenate([r.te_def_um for r in runs])
    return X, y


def _fit_one(est: StackedTERegressor, X: np.ndarray, y: np.ndarray) -> StackedTERegressor:
    return est.fit(X, y)


def fit_te_model(
    pipeline: TEPipeline,
    geo: dict[str, GeometricCurve],
    runs: dict[str, list[RunData]],
    max_load: float = 3000.0,
    holdout_loads: tuple[float, ...] = (1000.0, 2500.0),
    estimator: StackedTERegressor | None = None,
    log: Callable[[str], None] | None = None,
    n_jobs: int = 2,
) -> TrainedTEModel:
    """Fit one stacked model per direction on the training runs (load ≤ ``max_load``, not held out).

    Parameters
    ----------
    pipeline, geo, runs
        From :func:`prepare_campaign`.
    max_load : float
        Largest training load [N] (paper: 3000 N).
    holdout_loads : tuple of float
        Loads [N] ≤ ``max_load`` whose runs are left out to score in-range generalisation.
    estimator : StackedTERegressor, optional
        Template (cloned per direction); default ``StackedTERegressor()``.
    log : callable, optional
        Progress messages.
    n_jobs : int
        Processes: with 2 the two directions are fitted at the same time (one core each).

    Returns
    -------
    TrainedTEModel
        With ``info``: loads, splits, per-direction fit times [s], stage-1 shares, training MAE [µm].
    """
    template = estimator if estimator is not None else StackedTERegressor()
    models: dict[str, StackedTERegressor] = {}
    info: dict[str, Any] = {"max_load": max_load, "holdout_loads": list(holdout_loads), "directions": {}}
    t0 = time.perf_counter()
    keys = list(runs)
    trains = {
        k: [r for r in runs[k] if split_of(r.meta["load"], max_load, holdout_loads) == "train"] for k in keys
    }
    data = {k: stack_runs(trains[k], pipeline) for k in keys}
    if n_jobs > 1 and len(keys) > 1:
        from joblib import Parallel, delayed

        fitted = Parallel(n_jobs=min(n_jobs, len(keys)), backend="loky")(
            delayed(_fit_one)(clone(template), *data[k]) for k in keys
        )
    else:
        fitted = [_fit_one(clone(template), *data[k]) for k in keys]
    for key, st in zip(keys, fitted, strict=True):
        train, y = trains[key], data[key][1]
        models[key] = st
        info["directions"][key] = {
            "train_runs": [r.meta.get("name", "") for r in train],
            "n_rows": int(y.size),
            "fit_time_s": st.fit_time_,
            "stage1_share": st.stage1_share_,
            "train_mae_um": st.train_mae_,
            "nn": st.nn_info_,
            "trees": st.tree_info_,
        }
        if log:
            log(
                f"{key}: {len(train)} runs, {y.size} rows, fit {st.fit_time_['total']:.1f} s, "
                f"train MAE {st.train_mae_:.4f} um, stage-1 share {100 * st.stage1_share_:.0f} %"
            )
    info["fit_time_total_s"] = time.perf_counter() - t0
    offset = {k: fit_offset_line(trains[k]) for k in keys}
    info["offset_line_um"] = {k: list(v) for k, v in offset.items()}
    return TrainedTEModel(pipeline, geo, models, info, offset)


def fit_offset_line(runs: list[RunData]) -> tuple[float, float]:
    """Least-squares line offset_um = a + b · torque_mean over runs ([µm], [µm/(N·m)])."""
    tq = np.array([r.meta.get("torque_mean", np.nan) for r in runs])
    off = np.array([r.meta.get("offset_um", 0.0) for r in runs])
    ok = np.isfinite(tq)
    if ok.sum() < 2 or np.ptp(tq[ok]) == 0:
        return (float(np.mean(off)) if off.size else 0.0, 0.0)
    b, a = np.polyfit(tq[ok], off[ok], 1)
    return float(a), float(b)
