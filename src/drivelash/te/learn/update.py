"""The wear update of a saved model (issue 12 item 4): stage 2, or both stages, on new passes.

A saved model directory holds plain arrays only (loading never unpickles), so the
trainable model is *restored* from them: :func:`restore_trained` rebuilds, per
direction, the fitted network (its float64 weights and standardisation loaded into a
PyTorch module of the same shape) and an unfitted bagged-tree template with the
hyperparameters the grid search chose (``tree_params``, the number of trees of the
saved bag, and the stage-2 inputs the saved trees split on). The restored model
predicts what the saved one predicts (stage 1 to rounding; stage 2 is refitted anyway).

:func:`update_trained` then processes the new passes with the model's **own**
geometric curves (so stage 2 sees everything that changed since the fit, the
geometric wear included, except the per-run constant that the offset step removes),
and calls :meth:`~drivelash.te.learn.stacked.StackedTERegressor.update` per direction:
``stage="trees"`` refits stage 2 alone on the new rows; ``stage="both"`` fine-tunes the
network first. The offset line and the geometric curves are kept.

:func:`update_errors` gives the before/after figures: the MAE of TE_def [µm] of both
models on the update passes and on held-out passes (not used by the update).

Training needs torch (imported here); prediction of the result does not.
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import DataError, ParameterError
from drivelash.te.learn.fit import TrainedTEModel, stack_runs
from drivelash.te.learn.preprocess import GeometricCurve, RunData, direction_key, process_pass

__all__ = [
    "UPDATE_STAGES",
    "align_to_parent",
    "half_sample_mode",
    "restore_trained",
    "runs_for_update",
    "update_errors",
    "update_trained",
]

#: Stages :func:`update_trained` accepts (those of ``StackedTERegressor.update``).
UPDATE_STAGES = ("trees", "both")


def _read_direction_arrays(directory: Path, meta: Mapping[str, Any]) -> dict[str, dict[str, np.ndarray]]:
    """The validated arrays of every direction (same checks as ``load_model``)."""
    from drivelash.te.runtime import persist

    arrs = persist._read_arrays(directory / str(meta["weights"]))
    n_t = int(meta["pipeline"]["geometry"]["n_t"])
    return {k: persist._validate_direction(arrs, k, meta["models"][k], n_t) for k in meta["directions"]}


def _restore_network(a: Mapping[str, np.ndarray], nn_params: Mapping[str, Any]) -> Any:
    """A fitted :class:`MLPRegressor` holding the saved weights (float64, eval mode)."""
    import torch

    from drivelash.te.learn.network import MLPRegressor, _make_net

    keep = MLPRegressor().get_params()
    nn = MLPRegressor(**{k: v for k, v in nn_params.items() if k in keep})
    n_in, hidden = a["W1"].shape
    net = _make_net(n_in, hidden, float(nn.dropout)).double()
    layers = [m for m in net if hasattr(m, "weight")]
    with torch.no_grad():
        for lay, (W, b) in zip(layers, (("W1", "b1"), ("W2", "b2"), ("W3", "b3")), strict=True):
            lay.weight.copy_(torch.from_numpy(np.ascontiguousarray(a[W].T)))
            lay.bias.copy_(torch.from_numpy(np.ascontiguousarray(a[b])))
    nn.net_ = net.eval()
    nn.x_mean_ = a["x_mean"].copy()
    nn.x_scale_ = a["x_scale"].copy()
    nn.y_mean_ = float(a["y_mean"][0])
    nn.y_scale_ = float(a["y_scale"][0])
    nn.n_features_in_ = int(n_in)
    nn.best_val_mae_ = float("nan")
    return nn


def restore_trained(directory: str | Path) -> tuple[Any, TrainedTEModel]:
    """Load a model directory and rebuild a trainable :class:`TrainedTEModel` from its arrays.

    Parameters
    ----------
    directory : str or Path
        Model directory (``drivelash te fit`` or an earlier ``te update``).

    Returns
    -------
    model : TEModel
        The loaded (numba) model, as :func:`~drivelash.te.runtime.persist.load_model` gives it.
    trained : TrainedTEModel
        Per direction a fitted network with the saved weights and an unfitted tree
        template (``tree_params`` of the grid search, the saved number of trees, the
        stage-2 inputs the saved trees use); geometric curves, offset lines, training
        record and (where the format has one) the model's context copied.
    """
    from drivelash.te.learn.numerics import pin_training_numerics

    # the restored network is trained on: fix torch's CPU code path before its first operation,
    # as te fit does (pin_training_numerics; update_trained records what is in force)
    pin_training_numerics()
    from drivelash.te.learn.stacked import StackedTERegressor, default_trees
    from drivelash.te.runtime.persist import load_model

    d = Path(directory)
    model = load_model(d)  # every safety check of the loader first
    meta = model.meta
    arrays = _read_direction_arrays(d, meta)
    models: dict[str, StackedTERegressor] = {}
    geo: dict[str, GeometricCurve] = {}
    offset: dict[str, tuple[float, float]] = {}
    for key in model.directions:
        dm = meta["models"][key]
        a = arrays[key]
        nn = _restore_network(a, dm.get("nn_params", {}))
        trees = default_trees().set_params(n_estimators=int(a["roots"].size))
        tp = {k: v for k, v in (dm.get("tree_params") or {}).items() if k in trees.get_params()}
        trees.set_params(**tp)
        internal = a["children_left"] != -1
        inputs = "position+torque" if np.any(a["feature"][internal] == 1) else "position"
        st = StackedTERegressor(nn=nn, trees=trees, tune_nn=False, tune_trees=False, stage2_inputs=inputs)
        st.nn_ = nn
        st.trees_ = trees  # unfitted template: update(mode "keep") clones and fits it
        st.n_features_in_ = int(a["W1"].shape[0]) + 1
        st.nn_info_ = dict(dm.get("nn_info") or {})
        st.tree_info_ = dict(dm.get("tree_info") or {"best_params": tp})
        st.tree_info_.setdefault("best_params", tp)
        st.stage1_share_ = dm.get("stage1_share")
        st.train_mae_ = dm.get("train_mae_um")
        st.fit_time_ = dict(dm.get("fit_time_s") or {})
        models[key] = st
        geo[key] = GeometricCurve(float(dm["geo_x0"]), float(dm["geo_step"]), a["geo_te"].copy())
        offset[key] = (float(a["offset"][0]), float(a["offset"][1]))
    trained = TrainedTEModel(model.pipeline, geo, models, dict(meta.get("info", {})), offset)
    for key in model.directions:  # an earlier update's no-load change, accumulated by this one
        if "noload_change" in arrays[key]:
            trained.noload_change[key] = arrays[key]["noload_change"].copy()
    ctx = getattr(model, "context", None)
    if ctx is not None:
        trained.context = ctx  # type: ignore[attr-defined]
    return model, trained


#: Further passes named in the refusal of passes beyond the model's torque range.
MORE_NAMED = 6
#: A pass whose |median motor torque| exceeds the model's torque_max by more than this share is
#: refused by te update (:func:`_refuse_beyond_torque`). torque_max is the 99.9th percentile of
#: |T_M| of the training runs, so a pass at a trained load lies below it (tester H's 2500 N passes:
#: 8.31 … 8.50 N·m of 8.84); 10 % covers the friction change of a worn or warm axis (equal-load
#: runs spread 0.23 N·m, 2.7 % of 8.5 N·m, across 20–100 mm/s) while the next load step of a
#: protocol lies beyond it (3000 → 3500 N: +16 %; tester H's 5000 N passes: 15.8 N·m, +79 %).
UPDATE_TORQUE_SLACK = 0.10


def runs_for_update(campaign: Any, trained: TrainedTEModel) -> dict[str, list[RunData]]:
    """Every constant-velocity run of ``campaign`` (geometric, load), processed with the model's curves.

    Parameters
    ----------
    campaign : Campaign
        New passes over the (worn) axis (:func:`~drivelash.te.protocol.campaign.load_campaign`).
    trained : TrainedTEModel
        The restored model (its pipeline and geometric curves are used).

    Returns
    -------
    dict
        ``{"pos": [RunData …], "neg": […]}`` with meta load [N], velocity [m/s], name, file.
    """
    out: dict[str, list[RunData]] = {}
    for d in (1, -1):
        key = direction_key(d)
        if key not in trained.models:
            continue
        out[key] = [
            process_pass(
                trained.pipeline,
                r,
                d,
                trained.geo[key],
                meta={
                    "load": float(r.load),
                    "velocity": float(r.velocity),
                    "name": Path(r.path).stem,
                    "file": str(r.path),
                },
            )  # fmt: skip
            for r in campaign.select(direction=d)
            if r.kind in ("geometric", "load")  # constant-velocity passes (not sine runs)
        ]
    _refuse_beyond_torque(out, trained, campaign)
    return out


def _refuse_beyond_torque(runs: Mapping[str, list[RunData]], trained: Any, campaign: Any) -> None:
    """Refuse passes whose median motor torque lies beyond the model's trained torque range.

    The limit is the flank's torque_max (:func:`~drivelash.te.runtime.table.valid_torque_range`;
    |median torque| above (1 + :data:`UPDATE_TORQUE_SLACK`) × torque_max: the magnitude, since the
    load, not the flank's sign convention, is what the model was not trained on), as ``te update`` refuses
    passes beyond the valid position range. The model's load behaviour beyond its training
    torques is an extrapolation (``te fit --max-load`` keeps heavier passes out of training);
    a stage-2 refit on them spread a ripple over the whole no-load table (session 33 tester H,
    TH3: six 5000 N passes, −15.8 N·m, beside a 3000 N model of torque_max 8.84 N·m: ±2.2 µm
    along the travel away from the wear, 0.28 µm without them). A model without a torque range
    (none stored) is not checked.
    """
    from drivelash.te.runtime.table import valid_torque_range

    names = {e.file: e.recording for e in getattr(getattr(campaign, "manifest", None), "runs", [])}
    bad, ranges = [], []
    for key, rs in runs.items():
        d = 1 if key == "pos" else -1
        rng = valid_torque_range(trained, d)
        if rng is None:
            continue
        t_max = max(abs(rng[0]), abs(rng[1]))
        ranges.append(f"flank {d:+d} |torque| ≤ {t_max:.3g} N·m")
        for r in rs:
            tq = float(np.median(r.torque))
            if abs(tq) > t_max * (1 + UPDATE_TORQUE_SLACK):
                f = Path(r.meta["file"])
                bad.append(
                    (str(Path(campaign.directory) / names[f.name]) if names.get(f.name) else str(f), r, tq)
                )
    if bad:
        listed = [f"{Path(p).name} ({r.meta['load']:g} N, {tq:+.3g} N·m)" for p, r, tq in bad[1:MORE_NAMED]]
        more = f"; also {', '.join(listed)}{', …' if len(bad) > MORE_NAMED else ''}" if listed else ""
        raise DataError(
            f"{len(bad)} pass(es) beyond the model's trained torque range ({', '.join(ranges)}): this one"
            f" at {bad[0][1].meta['load']:g} N has a median motor torque of {bad[0][2]:+.3g} N·m{more} —"
            " the model's load behaviour there is an extrapolation and a refit on it changes the whole"
            " no-load table: import the update passes without them, or refit with te fit (--max-load)",
            path=bad[0][0],
        )


def half_sample_mode(values: np.ndarray) -> float:
    """Half-sample mode of ``values`` (Bickel & Frühwirth 2006): repeatedly keep the half of the
    sorted values with the smallest range; robust to up to half of them lying anywhere else.

    Parameters
    ----------
    values : numpy.ndarray
        Finite samples (any unit; the result has it).

    Returns
    -------
    float
        The mode estimate.
    """
    y = np.sort(np.asarray(values, dtype=np.float64).reshape(-1))
    if y.size == 0:
        raise DataError("no values for the mode")
    while y.size > 3:
        h = (y.size + 1) // 2
        j = int(np.argmin(y[h - 1 :] - y[: y.size - h + 1]))
        y = y[j : j + h]
    if y.size == 3:
        y = y[:2] if y[1] - y[0] <= y[2] - y[1] else y[1:]
    return float(np.mean(y))


def align_to_parent(runs: Mapping[str, list[RunData]], parent: Any) -> None:
    """Give each pass the parent's absolute level where the axis did not change (in place).

    The offset step removes each pass's mean TE_def (its constant is arbitrary: the zero of
    x_T against θ_M). For a local defect that mean is the defect's mean over the pass, and an
    update learning ``defect − mean`` shifts the absolute TE everywhere (finding A7). Here the
    constant is the **mode** of (pass − parent's prediction) (:func:`half_sample_mode`): the
    densest level, which is the unchanged part of the pass wherever the axis did not change
    — also when a local defect covers half of a short pass, where a median would be pulled
    by it — so the unchanged part keeps the parent's level and the change is learnt in full.

    Parameters
    ----------
    runs : dict
        Processed passes per direction (:func:`runs_for_update`); ``te_def_um`` is shifted by
        the constant, ``meta["parent_level_um"]`` records it [µm].
    parent : TEModel or TrainedTEModel
        The model being updated (``predict_def_um``).
    """
    for rs in runs.values():
        for r in rs:
            k = half_sample_mode(r.te_def_um - parent.predict_def_um(r.x, r.torque, r.direction))
            r.te_def_um = r.te_def_um - k
            r.meta["parent_level_um"] = k


def _covered(rs: list[RunData]) -> tuple[float, float]:
    """Positions [m] the passes span (their hull)."""
    return float(min(np.min(r.x) for r in rs)), float(max(np.max(r.x) for r in rs))


def _parent_rows(
    parent: Any, geo: GeometricCurve, rs: list[RunData], pipeline: Any
) -> tuple[np.ndarray, np.ndarray]:
    """Rows of the parent's own prediction over the travel the passes do not cover.

    At every pass's median torque, on the grid of the no-load curve outside the passes' hull:
    the refit then reproduces the parent there instead of extrapolating the edge of the passes
    (the update does not change the model where it has no data).
    """
    lo, hi = _covered(rs)
    x = geo.x
    x = x[(x < lo - 0.5 * geo.step) | (x > hi + 0.5 * geo.step)]
    if x.size == 0:
        return np.empty((0, pipeline.design_matrix(geo.x[:1], np.zeros(1)).shape[1])), np.empty(0)
    d = rs[0].direction
    Xs, ys = [], []
    for r in rs:
        tq = np.full(x.shape, float(np.median(r.torque)))
        Xs.append(pipeline.design_matrix(x, tq))
        ys.append(parent.predict_def_um(x, tq, d))
    return np.vstack(Xs), np.concatenate(ys)


def _noload_torque(rs: list[RunData]) -> float:
    """Motor torque [N·m] of the no-load condition: the slowest zero-load pass's median torque.

    The geometric curves were learnt on the slow no-load runs; without a zero-load pass the
    pass of smallest mean |torque| stands in.
    """
    zero = [r for r in rs if abs(float(r.meta.get("load", np.nan))) < 1e-6]
    if zero:
        r = min(zero, key=lambda r: abs(float(r.meta.get("velocity", np.inf))))
    else:
        r = min(rs, key=lambda r: abs(float(np.mean(r.torque))))
    return float(np.median(r.torque))


def _parent_note(extra: Mapping[str, Any]) -> str:
    if not extra:
        return ""
    lo, hi = extra["covered_m"]
    return (
        f" over {lo * 1e3:.1f} ... {hi * 1e3:.1f} mm, + {extra['parent_rows']} rows of the parent beyond;"
        f" no-load change up to {extra['noload_change_max_um']:.3f} um"
    )


def _mae(predict: Callable[..., np.ndarray], runs: Iterable[RunData]) -> float:
    err = [np.abs(predict(r.x, r.torque, r.direction) - r.te_def_um) for r in runs]
    return float(np.mean(np.concatenate(err))) if err else float("nan")


def update_errors(before: Any, after: Any, runs: Mapping[str, list[RunData]]) -> dict[str, dict[str, float]]:
    """MAE of TE_def [µm] of two models on processed runs, per direction.

    ``before``/``after`` need ``predict_def_um(x_T, torque, direction)`` (a loaded
    ``TEModel`` or a ``TrainedTEModel``). Returns ``{key: {"before_um", "after_um",
    "n_runs"}}``; an empty list gives NaN.
    """
    res: dict[str, dict[str, float]] = {}
    for key, rs in runs.items():
        res[key] = {
            "before_um": _mae(before.predict_def_um, rs),
            "after_um": _mae(after.predict_def_um, rs),
            "n_runs": len(rs),
        }
    return res


def _digest(directory: Path, meta: Mapping[str, Any]) -> str:
    h = hashlib.sha256()
    for name in ("model.json", str(meta.get("weights", ""))):
        p = directory / name
        if p.is_file():
            h.update(p.read_bytes())
    return h.hexdigest()


def update_trained(
    trained: TrainedTEModel,
    runs: Mapping[str, list[RunData]],
    stage: str = "trees",
    update_stride: int = 1,
    log: Callable[[str], None] | None = None,
    parent: Any = None,
) -> dict[str, Any]:
    """Apply the wear update in place; returns the update record.

    Parameters
    ----------
    trained : TrainedTEModel
        Restored (:func:`restore_trained`) or freshly fitted model; changed in place.
    runs : dict
        Processed update passes per direction (:func:`runs_for_update`); a direction
        without runs keeps its model.
    stage : {"trees", "both"}
        Stage 2 alone, or fine-tune the network and then refit stage 2.
    update_stride : int
        Every ``update_stride``-th row of the position grid enters the stage-2 refit
        (1 = every row; see ``docs/assumptions.md``, "te update").
    log : callable, optional
        Progress messages.
    parent : TEModel, optional
        The model being updated (``te update`` gives it; ``runs`` aligned to it with
        :func:`align_to_parent` first). Then (1) over the travel the passes do not cover, rows
        of the parent's own prediction enter the refit, so the model keeps the parent there;
        (2) the change of the no-load prediction (at the no-load torque, :func:`_noload_torque`;
        zero outside the passes' travel) is added to ``trained.noload_change``, which the CNC
        tables hold.

    Returns
    -------
    dict
        ``stage``, ``update_stride``, per direction ``rows``, ``runs`` and ``time_s`` (with a
        parent also ``parent_rows``, ``covered_m``, ``noload_torque_Nm``, ``noload_change_max_um``).
    """
    if stage not in UPDATE_STAGES:
        raise ParameterError(
            "te update", "stage", f"must be one of {', '.join(UPDATE_STAGES)}, got {stage!r}"
        )
    if not (isinstance(update_stride, (int, np.integer)) and update_stride >= 1):
        raise ParameterError("te update", "stride", f"must be a positive integer, got {update_stride!r}")
    say = log or (lambda s: None)
    rec: dict[str, Any] = {"stage": stage, "update_stride": int(update_stride), "directions": {}}
    if not any(runs.get(k) for k in trained.models):
        raise DataError("no update pass in any direction of the model")
    from drivelash.te.learn.numerics import pin_training_numerics

    rec["numerics"] = pin_training_numerics()
    import torch

    torch.set_num_threads(2)
    for key, st in trained.models.items():
        rs = runs.get(key) or []
        if not rs:
            say(f"{key}: no update pass, model kept")
            continue
        X, y = stack_runs(rs, trained.pipeline)
        n_rows = int(X.shape[0])
        extra: dict[str, Any] = {}
        if parent is not None:
            Xp, yp = _parent_rows(parent, trained.geo[key], rs, trained.pipeline)
            X, y = np.vstack([X, Xp]), np.concatenate([y, yp])
            extra = {"parent_rows": int(Xp.shape[0]), "covered_m": list(_covered(rs))}
        st.set_params(update_stride=int(update_stride))
        t0 = time.perf_counter()
        st.update(X, y, stage=stage)
        dt_s = time.perf_counter() - t0
        if parent is not None:
            d = rs[0].direction
            geo = trained.geo[key]
            t0_nm = _noload_torque(rs)
            lo, hi = extra["covered_m"]
            inside = (geo.x >= lo) & (geo.x <= hi)
            change = np.where(
                inside,
                (trained.predict_def_um(geo.x, t0_nm, d) - parent.predict_def_um(geo.x, t0_nm, d)) / 1e6,
                0.0,
            )
            total = trained.noload_change.get(key, np.zeros_like(change)) + change
            trained.noload_change[key] = total
            extra.update(
                {"noload_torque_Nm": t0_nm, "noload_change_max_um": float(np.max(np.abs(change)) * 1e6)}
            )
        rec["directions"][key] = {"rows": n_rows, "runs": len(rs), "time_s": dt_s, **extra}
        say(f"{key}: updated stage {'2' if stage == 'trees' else '1 and 2'} on {len(rs)} passes "
            f"({n_rows} rows{_parent_note(extra)}) in {dt_s:.1f} s")  # fmt: skip
    return rec


def parent_record(directory: str | Path, meta: Mapping[str, Any]) -> dict[str, Any]:
    """Provenance of the model being updated: path, SHA-256 of its files, version number."""
    d = Path(directory)
    info = meta.get("info", {}) or {}
    return {
        "path": str(d.resolve()),
        "sha256": _digest(d, meta),
        "model_version": int(info.get("model_version", 1)),
    }
