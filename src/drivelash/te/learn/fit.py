"""From a campaign to a trained model: both directions plus the geometric curves (spec 02 §3–4).

:func:`prepare_campaign` turns a campaign's runs into geometric curves and processed
load runs; :func:`fit_te_model` fits one :class:`~drivelash.te.learn.stacked.StackedTERegressor`
per direction on the training loads and returns a :class:`TrainedTEModel`, which
predicts the full TE in **metres**; :func:`drivelash.te.runtime.persist.save_model`
writes it to a directory that :func:`drivelash.te.runtime.persist.load_model` reads
without torch.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from sklearn.base import clone

from drivelash.errors import DataError
from drivelash.te.learn.preprocess import (
    UM,
    GearGeometry,
    GeometricCurve,
    RunData,
    TEPipeline,
    direction_key,
    process_pass,
)
from drivelash.te.learn.stacked import StackedTERegressor

__all__ = [
    "TrainedTEModel",
    "default_holdout",
    "fit_offset_line",
    "fit_te_model",
    "prepare_campaign",
    "split_of",
    "stack_runs",
]


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
    context : ModelContext or None
        Axis, valid range, compensator settings and simulator
        (:class:`drivelash.te.runtime.persist.ModelContext`); required to save the model.
    noload_change : dict
        ``{"pos": array, …}`` on the grid of ``geo[key]``: what the ``te update`` runs since the fit
        changed the model's no-load TE [m] (its prediction at the no-load torque, new minus
        parent, accumulated); empty for a model that was never updated. The CNC tables add it
        to TE_geo (:func:`drivelash.te.runtime.cnc.geometric_table`); ``predict`` already
        holds it through stage 2.
    """

    pipeline: TEPipeline
    geo: dict[str, GeometricCurve]
    models: dict[str, StackedTERegressor]
    info: dict[str, Any] = field(default_factory=dict)
    offset: dict[str, tuple[float, float]] = field(default_factory=dict)
    context: Any = None
    noload_change: dict[str, np.ndarray] = field(default_factory=dict)

    def geometric_range(self) -> tuple[float, float]:
        """Positions [m] where every direction's no-load curve holds measured data (x_min, x_max).

        The same span as :meth:`drivelash.te.runtime.predictor.TEModel.geometric_range` of the
        saved model; :func:`drivelash.te.runtime.table.measured_range` intersects it with the
        stored valid range.
        """
        spans = [self.geo[k].span() for k in self.models]
        return max(s[0] for s in spans), min(s[1] for s in spans)

    def predict_def_um(self, x_T: Any, torque: Any, direction: int) -> np.ndarray:
        """Deformation TE_def [µm] (offset-free, the learning target) at ``x_T`` [m], motor torque [N·m].

        Parameters
        ----------
        x_T : array_like
            Table positions [m].
        torque : array_like
            Motor torque [N·m], broadcast to ``x_T``.
        direction : int
            Flank in contact: +1 or −1.
        """
        X = self.pipeline.design_matrix(x_T, torque)
        return self.models[direction_key(direction)].predict(X)

    def offset_um(self, torque: Any, direction: int) -> np.ndarray:
        """Mean deformation a + b·torque [µm] removed by the offset step (0 if none was fitted).

        Parameters
        ----------
        torque : array_like
            Motor torque [N·m].
        direction : int
            Flank in contact: +1 or −1.
        """
        a, b = self.offset.get(direction_key(direction), (0.0, 0.0))
        return a + b * np.asarray(torque, dtype=np.float64)

    def predict(self, x_T: Any, torque: Any, direction: int) -> np.ndarray:
        """TE [m] = TE_geo(x_T) + (offset(torque) + TE_def(x_T, torque))·1e-6, direction +1/−1.

        Parameters
        ----------
        x_T : array_like
            Table positions [m].
        torque : array_like
            Motor torque [N·m], broadcast to ``x_T``.
        direction : int
            Flank in contact: +1 or −1.
        """
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
    """Geometric curves and processed load runs of a campaign (:func:`~drivelash.te.protocol.load_campaign`).

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

    Raises
    ------
    DataError
        A direction without a geometric (no-load) run or without a load run.

    Notes
    -----
    A load run is used only where its direction's no-load curve holds data (``span`` of
    :meth:`TEPipeline.process`); ``te import``/``te fit`` warn for a run reaching beyond it.
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
        # only where TE_geo was measured (span): beyond the no-load curve it is held flat, and
        # the geometric error there would be learnt as load behaviour (finding A9)
        runs[key] = [
            process_pass(
                pipeline,
                r,
                d,
                geo[key],
                meta={"load": float(r.load), "velocity": float(r.velocity), "name": Path(r.path).stem},
                span=geo[key].span(),
            )
            for r in campaign.select(kind="load", direction=d)
        ]
        if not runs[key]:
            raise DataError(f"campaign has no load run in direction {d:+d}")
    return pipeline, geo, runs


def default_holdout(loads: Any, max_load: float) -> tuple[float, ...]:
    """Held-out loads [N] derived from a campaign's loads: in range, interior, leaving >= 3 to train.

    Of the distinct loads ≤ ``max_load`` (n of them): with n ≥ 5 the two interior loads
    nearest to 1/3 and 5/6 of the in-range span are held out (0 … 3000 N in 500 N steps:
    1000 and 2500 N, the paper-like default); with n = 4 the interior load nearest to the
    middle; with fewer, none — every load is needed for training.

    Parameters
    ----------
    loads : iterable of float
        The campaign's loads [N].
    max_load : float
        Largest training load [N].
    """
    inr = sorted({float(f) for f in loads if float(f) <= max_load + 1e-9})
    n = len(inr)
    if n < 4:
        return ()
    interior = inr[1:-1]
    lo, span = inr[0], inr[-1] - inr[0]
    targets = (0.5,) if n == 4 else (1.0 / 3.0, 5.0 / 6.0)
    out: list[float] = []
    for q in targets:
        cand = [f for f in interior if f not in out]
        out.append(min(cand, key=lambda f: abs(f - (lo + q * span))))
    return tuple(sorted(out))


def holdout_limitations(loads: Any, max_load: float, holdout_loads: tuple[float, ...]) -> list[str]:
    """What a fit cannot state about its accuracy, one line each (``model.json`` ``info.limitations``).

    With no load held out (fewer than 4 loads ≤ ``max_load``, :func:`default_holdout`) only the
    training MAE is known: it holds at the training loads, and the error between them is not
    measured (finding D7: train MAE 0.09 µm at 0 and 2500 N, 0.48–0.59 µm at 1000 N).

    Parameters
    ----------
    loads : iterable of float
        The campaign's loads [N].
    max_load : float
        Largest training load [N].
    holdout_loads : tuple of float
        Loads [N] left out of training.

    Returns
    -------
    list of str
        Empty when a load is held out.
    """
    if holdout_loads:
        return []
    train = sorted({float(f) for f in loads if float(f) <= max_load + 1e-9})
    return [
        f"no load held out ({len(train)} training loads: {', '.join(f'{f:g}' for f in train)} N): the"
        " accuracy between the training loads is not measured — the train MAE holds at them only;"
        " record 4 or more loads up to the max load (one is then held out)"
    ]


def split_of(load: float, max_load: float, holdout_loads: tuple[float, ...]) -> str:
    """``"train"``, ``"held-out"`` (in range, left out) or ``"extrapolation"`` (above ``max_load``).

    Parameters
    ----------
    load : float
        The run's process load [N].
    max_load : float
        Largest training load [N] (1e-9 N tolerance).
    holdout_loads : tuple of float
        Loads [N] left out of training (1e-6 N tolerance).
    """
    if load > max_load + 1e-9:
        return "extrapolation"
    if any(abs(load - h) < 1e-6 for h in holdout_loads):
        return "held-out"
    return "train"


def stack_runs(runs: list[RunData], pipeline: TEPipeline) -> tuple[np.ndarray, np.ndarray]:
    """Design matrix and TE_def [µm] of several runs, concatenated.

    Parameters
    ----------
    runs : list of RunData
        Processed runs (:meth:`TEPipeline.process`).
    pipeline : TEPipeline
        Builds the design matrix ``[x_T [m], torque [N·m], M_1 … M_nt]``.

    Returns
    -------
    X, y : numpy.ndarray
        Design matrix and TE_def [µm].

    Raises
    ------
    DataError
        ``runs`` is empty.
    """
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
    # before the worker processes start: they inherit the pinned CPU code path
    from drivelash.te.learn.numerics import pin_training_numerics

    info["numerics"] = pin_training_numerics()
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
    loads = [r.meta["load"] for k in keys for r in runs[k]]
    info["limitations"] = holdout_limitations(loads, max_load, holdout_loads)
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
