"""Baselines for the stacked TE model, and the comparison table / figure.

Every baseline predicts TE_def [µm] from the same design matrix
``[x_T [m], torque [N·m], M_1 … M_nt]`` and is trained on the same rows as the
stacked model:

* :class:`GeometricOnly` — the geometric lookup table alone: TE = TE_geo, so the
  deformation prediction is 0;
* stage 1 only — the stacked model's own network (``stacked.nn_``), i.e. the stack
  without its trees (:class:`StageOne`);
* :func:`fit_trees_only` — bagged trees on (x_T, torque) fitted to TE_def directly,
  with the same grid search and position-blocked folds as stage 2;
* :func:`fit_hgb` — one ``HistGradientBoostingRegressor`` on all inputs.

:func:`compare` scores any set of predictors per run; :func:`mae_table` groups the
scores by direction and load (the figure like the paper's Fig. 6 is
:func:`drivelash.report.te_figures.plot_fig6`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.ensemble import HistGradientBoostingRegressor

from drivelash.te.learn.network import check_xy
from drivelash.te.learn.preprocess import RunData, TEPipeline
from drivelash.te.learn.stacked import (
    DEFAULT_TREE_GRID,
    STAGE1_COLS,
    STAGE2_COLS,
    StackedTERegressor,
    default_trees,
    grid_search_trees,
    position_blocks,
)

__all__ = [
    "ColumnModel",
    "GeometricOnly",
    "StageOne",
    "compare",
    "fit_hgb",
    "fit_trees_only",
    "format_table",
    "mae_table",
    "split_summary",
]

Predictor = Callable[[np.ndarray], np.ndarray]


class GeometricOnly(RegressorMixin, BaseEstimator):
    """Geometric lookup table only: TE_def prediction ≡ 0 µm."""

    def fit(self, X: Any, y: Any) -> GeometricOnly:
        """Nothing to learn; returns ``self``.

        Parameters
        ----------
        X : array_like
            Design matrix ``[x_T [m], torque [N·m], M_1 … M_nt]``.
        y : array_like
            TE_def [µm] (not used).
        """
        X, _ = check_xy(X, y)
        self.n_features_in_ = X.shape[1]
        return self

    def predict(self, X: Any) -> np.ndarray:
        """Zeros [µm].

        Parameters
        ----------
        X : array_like
            Design matrix ``[x_T [m], torque [N·m], M_1 … M_nt]``.
        """
        X, _ = check_xy(X)
        return np.zeros(X.shape[0])


class StageOne:
    """The network of a fitted stacked model used alone (predicts TE_def [µm]).

    Parameters
    ----------
    stacked : StackedTERegressor
        A fitted stacked model (its ``nn_``).
    """

    def __init__(self, stacked: StackedTERegressor) -> None:
        self.stacked = stacked

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Stage-1 output [µm].

        Parameters
        ----------
        X : array_like
            Design matrix ``[x_T [m], torque [N·m], M_1 … M_nt]``.
        """
        return self.stacked.nn_.predict(np.asarray(X)[:, STAGE1_COLS])


class ColumnModel:
    """A regressor applied to selected design-matrix columns."""

    def __init__(self, est: Any, cols: Any) -> None:
        self.est = est
        self.cols = cols

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Prediction [µm]."""
        return self.est.predict(np.asarray(X)[:, self.cols])


def fit_trees_only(
    X: np.ndarray,
    y: np.ndarray,
    grid: Mapping[str, list[Any]] | None = None,
    block_length: float = 2e-3,
    folds: int = 3,
    search_stride: int = 16,
    tree_stride: int = 4,
    n_jobs: int = 1,
    random_state: int = 0,
) -> tuple[ColumnModel, dict[str, Any]]:
    """Bagged trees on (x_T, torque) fitted to TE_def [µm] directly (stage 2 alone).

    Same grid, blocked folds and subsampling as stage 2 of the stacked model.

    Parameters
    ----------
    X : numpy.ndarray
        Design matrix ``[x_T [m], torque [N·m], M_1 … M_nt]`` (only x_T and torque are used).
    y : numpy.ndarray
        TE_def [µm].
    grid : mapping, optional
        Hyperparameter grid (default :data:`~drivelash.te.learn.stacked.DEFAULT_TREE_GRID`).
    block_length : float
        Position block [m] defining the CV groups.
    folds : int
        Folds of the blocked cross-validation.
    search_stride, tree_stride : int
        Every n-th row enters the grid search / the final fit.
    n_jobs : int
        Parallel jobs of the grid search.
    random_state : int
        Seed.

    Returns
    -------
    model : ColumnModel
        ``predict(X) -> µm``.
    info : dict
        The grid search's result (``best_params`` …).
    """
    X2 = X[:, STAGE2_COLS]
    base = default_trees(random_state)
    g = position_blocks(X[::search_stride, 0], block_length)
    info = grid_search_trees(
        base, X2[::search_stride], y[::search_stride], g, grid or DEFAULT_TREE_GRID, folds, n_jobs
    )
    est = clone(base).set_params(**info["best_params"]).fit(X2[::tree_stride], y[::tree_stride])
    return ColumnModel(est, STAGE2_COLS), info


def fit_hgb(X: np.ndarray, y: np.ndarray, max_iter: int = 300, random_state: int = 0) -> ColumnModel:
    """One ``HistGradientBoostingRegressor`` on all inputs (x_T, torque, M_j).

    ``max_iter`` boosting rounds (300), ``max_leaf_nodes=63``, learning rate 0.1,
    early stopping on an internal 10 % validation split (scikit-learn default for
    > 10 000 rows); OpenMP limited to 2 threads.

    Parameters
    ----------
    X : numpy.ndarray
        Design matrix ``[x_T [m], torque [N·m], M_1 … M_nt]``.
    y : numpy.ndarray
        TE_def [µm].
    max_iter : int
        Boosting rounds.
    random_state : int
        Seed.

    Returns
    -------
    ColumnModel
        ``predict(X) -> µm``.
    """
    from threadpoolctl import threadpool_limits

    with threadpool_limits(2):
        est = HistGradientBoostingRegressor(
            max_iter=max_iter, max_leaf_nodes=63, learning_rate=0.1, random_state=random_state
        ).fit(X, y)
    return ColumnModel(est, slice(None))


# ---------------------------------------------------------------------------
# scoring
# ---------------------------------------------------------------------------
def compare(
    predictors: Mapping[str, Mapping[str, Any]],
    runs: Mapping[str, Sequence[RunData]],
    pipeline: TEPipeline,
    split_of: Callable[[RunData], str],
) -> list[dict[str, Any]]:
    """MAE [µm] of every predictor on every run.

    Parameters
    ----------
    predictors : mapping
        ``{name: {"pos": predictor, "neg": predictor}}``; a predictor has ``predict(X) -> µm``.
    runs : mapping
        ``{"pos": [RunData…], "neg": […]}``.
    pipeline : TEPipeline
        Builds the design matrix.
    split_of : callable
        ``split_of(run) -> "train" | "held-out" | "extrapolation"``.

    Returns
    -------
    list of dict
        One row per run: direction, load [N], velocity [m/s], split, n, rms [µm] of
        the target, and ``mae[name]`` [µm].
    """
    rows: list[dict[str, Any]] = []
    for key, rr in runs.items():
        for run in rr:
            X = pipeline.design_matrix(run.x, run.torque)
            y = run.te_def_um
            row = {
                "direction": key,
                "load": float(run.meta.get("load", np.nan)),
                "velocity": float(run.meta.get("velocity", np.nan)),
                "run": run.meta.get("name", ""),
                "split": split_of(run),
                "n": int(y.size),
                "rms": float(np.sqrt(np.mean(y**2))),
                "mae": {
                    name: float(np.mean(np.abs(p[key].predict(X) - y))) for name, p in predictors.items()
                },
            }
            rows.append(row)
    return rows


def mae_table(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Rows grouped by (direction, load): point-weighted MAE and RMS over the velocities.

    Parameters
    ----------
    rows : sequence of mapping
        The rows of :func:`compare` (``direction``, ``load`` [N], ``split``, ``n``, ``rms``
        [µm], ``mae`` [µm] per predictor).

    Returns
    -------
    list of dict
        One row per (direction, load), the same keys, MAE and RMS [µm] weighted by ``n``.
    """
    groups: dict[tuple[str, float], list[Mapping[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["direction"], r["load"]), []).append(r)
    out = []
    for (d, load), rr in sorted(groups.items(), key=lambda kv: (kv[0][0] != "pos", kv[0][1])):
        n = np.array([r["n"] for r in rr], dtype=float)
        names = list(rr[0]["mae"])
        out.append(
            {
                "direction": d,
                "load": load,
                "split": rr[0]["split"],
                "n": int(n.sum()),
                "rms": float(np.sqrt(np.sum(n * np.array([r["rms"] for r in rr]) ** 2) / n.sum())),
                "mae": {m: float(np.sum(n * np.array([r["mae"][m] for r in rr])) / n.sum()) for m in names},
            }
        )
    return out


def split_summary(rows: Sequence[Mapping[str, Any]]) -> dict[str, dict[str, Any]]:
    """Per split: point-weighted MAE [µm] of every model, target RMS [µm], MAE/RMS ratios.

    Parameters
    ----------
    rows : sequence of mapping
        The rows of :func:`compare`.

    Returns
    -------
    dict
        ``{split: {"rms", "mae", "ratio", "n"}}`` for the splits present (``"train"``,
        ``"held-out"``, ``"extrapolation"``).
    """
    out: dict[str, dict[str, Any]] = {}
    for split in ("train", "held-out", "extrapolation"):
        rr = [r for r in rows if r["split"] == split]
        if not rr:
            continue
        n = np.array([r["n"] for r in rr], dtype=float)
        rms = float(np.sqrt(np.sum(n * np.array([r["rms"] for r in rr]) ** 2) / n.sum()))
        mae = {m: float(np.sum(n * np.array([r["mae"][m] for r in rr])) / n.sum()) for m in rr[0]["mae"]}
        out[split] = {
            "rms": rms,
            "mae": mae,
            "ratio": {m: v / rms for m, v in mae.items()},
            "n": int(n.sum()),
        }
    return out


def format_table(table: Sequence[Mapping[str, Any]], summary: Mapping[str, Mapping[str, Any]]) -> str:
    """Plain-text table: MAE [µm] per direction and load, stacked vs baselines, then per split."""
    names = list(table[0]["mae"]) if table else []
    head = f"{'dir':>4} {'load N':>7} {'split':>13} {'RMS um':>8} " + " ".join(f"{n:>10}" for n in names)
    lines = ["MAE of TE_def [um] per direction and load (mean over velocities)", head]
    for r in table:
        lines.append(
            f"{r['direction']:>4} {r['load']:>7.0f} {r['split']:>13} {r['rms']:>8.3f} "
            + " ".join(f"{r['mae'][n]:>10.4f}" for n in names)
        )
    lines.append("")
    lines.append(
        f"{'split':>13} {'RMS um':>8} " + " ".join(f"{n:>10}" for n in names) + "   (MAE um; % of RMS)"
    )
    for split, s in summary.items():
        lines.append(f"{split:>13} {s['rms']:>8.3f} " + " ".join(f"{s['mae'][n]:>10.4f}" for n in names))
        lines.append(f"{'':>13} {'':>8} " + " ".join(f"{100 * s['ratio'][n]:>9.1f}%" for n in names))
    return "\n".join(lines)
