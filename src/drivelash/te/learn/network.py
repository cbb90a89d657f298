"""Stage 1 of the stacked TE model: a PyTorch network tuned by Hyperband (spec 02 §4).

:class:`MLPRegressor` — two hidden ReLU layers with dropout, trained by Adam with early
stopping on the validation MAE, scikit-learn compatible; :func:`tune_mlp` chooses its
width, dropout and learning rate with Optuna's Hyperband pruner.

torch and optuna are imported only inside the training code paths.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.utils.validation import check_is_fitted, validate_data

from drivelash.errors import DataError, ParameterError

__all__ = ["DEFAULT_NN_SPACE", "MLPRegressor", "check_xy", "tune_mlp"]

#: Default Hyperband search space of stage 1.
DEFAULT_NN_SPACE: dict[str, tuple[Any, ...]] = {
    "hidden": (16, 32, 48, 64),
    "dropout": (0.0, 0.2),
    "lr": (1e-3, 2e-2),
}


def check_xy(X: Any, y: Any | None = None, min_cols: int = 3) -> tuple[np.ndarray, np.ndarray | None]:
    """Inputs as a finite 2-D float64 array with ``>= min_cols`` columns (and a matching finite target)."""
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
    units. scikit-learn contract (``check_estimator`` passes, tested with
    ``parametrize_with_checks``): hyperparameters are only stored by ``__init__`` and
    validated in ``fit``; inputs are checked by ``validate_data`` (finite, 2-D, dense,
    ``n_features_in_``); ``predict`` before ``fit`` raises ``NotFittedError``. Trained in
    float32; after training the network is kept in float64 so the NumPy/numba
    re-implementation in :mod:`drivelash.te.runtime.predictor` reproduces it to rounding.

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
        X, y = validate_data(self, X, y, dtype=np.float64, y_numeric=True)
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
        check_is_fitted(self, "net_")
        X, y = validate_data(self, X, y, dtype=np.float64, y_numeric=True, reset=False)
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
        from drivelash.te.learn.numerics import pin_training_numerics

        pin_training_numerics()  # every training path (fit, fine_tune, each Hyperband trial)
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
        """Prediction in target units (float64 forward pass of the trained network).

        Parameters
        ----------
        X : array_like, shape (n, p)
            Inputs, in the units of the training inputs.
        """
        check_is_fitted(self, "net_")
        X = validate_data(self, X, dtype=np.float64, reset=False)
        import torch

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
        ``best_params``, ``best_val_mae``, ``n_trials``, ``n_pruned``, ``numerics`` (the CPU
        code path of torch, :func:`~drivelash.te.learn.numerics.pin_training_numerics`).
    """
    import optuna

    from drivelash.te.learn.numerics import pin_training_numerics

    numerics = pin_training_numerics()
    import torch

    torch.set_num_threads(int(torch_threads))
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    sp = dict(DEFAULT_NN_SPACE if space is None else space)
    pruner = optuna.pruners.HyperbandPruner(
        min_resource=3, max_resource=int(base.max_epochs), reduction_factor=3
    )
    # A fixed study name: Hyperband assigns each trial to a bracket by crc32(study name, trial
    # number), and Optuna's default name carries a random UUID - the pruning, and with it the
    # chosen network, changed from run to run of the same command on the same data.
    study = optuna.create_study(
        study_name=f"drivelash-te-stage1-seed{int(seed)}",
        direction="minimize",
        sampler=optuna.samplers.TPESampler(seed=seed),
        pruner=pruner,
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
        "numerics": numerics,
    }
