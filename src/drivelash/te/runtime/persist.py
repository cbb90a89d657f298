"""Safe persistence of transmission-error models: the model directory, saved and loaded.

A model directory holds exactly two files that are read:

* ``model.json`` — metadata (format version, units, geometry, preprocessing,
  hyperparameters, training record, array shapes);
* ``weights.safetensors`` (default) or ``weights.npz`` — plain numeric arrays:
  geometric curves, network weights and biases, standardisation, and the bagged
  trees as flat arrays (``children_left``, ``children_right``, ``feature``,
  ``threshold``, ``value`` of every ``tree_``, concatenated, with root offsets).

Loading never unpickles: JSON via :mod:`json`, arrays via ``safetensors.numpy``
or ``numpy.load(allow_pickle=False)``. A directory that contains a
pickle-capable file (``.pkl``, ``.pickle``, ``.joblib``, ``.npy``, ``.pt``, ``.pth``,
``.ckpt``, ``.dill``) or whose arrays are not plain numbers is refused with
:class:`ModelFileError` — nothing in it is executed. Tree arrays are checked so
that traversal always terminates (children after their parent).


:func:`load_model` returns a :class:`~drivelash.te.runtime.predictor.TEModel`, which
predicts with numba kernels only (torch is never imported).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import DrivelashError
from drivelash.te.learn.preprocess import TEPipeline
from drivelash.te.runtime.predictor import TEModel

FORMAT_NAME = "drivelash.te-model"
FORMAT_VERSION = 1
META_FILE = "model.json"
WEIGHT_FILES = ("weights.safetensors", "weights.npz")
#: Suffixes of files that can carry executable pickle payloads; their presence is refused.
PICKLE_SUFFIXES = (".pkl", ".pickle", ".joblib", ".npy", ".pt", ".pth", ".ckpt", ".dill", ".bin")


class ModelFileError(DrivelashError):
    """A model directory that is missing, malformed, or not safe to load."""


def flatten_trees(bagging: Any) -> dict[str, np.ndarray]:
    """Concatenate the trees of a fitted ``BaggingRegressor`` into flat arrays.

    Child indices become global (offset by the tree's first node), leaves keep −1;
    ``feature`` is mapped through ``estimators_features_`` to the input column
    (0 = x_T, 1 = torque); ``value`` is the leaf mean.
    """
    left, right, feat, thr, val, roots = [], [], [], [], [], []
    off = 0
    for est, feats in zip(bagging.estimators_, bagging.estimators_features_, strict=True):
        t = est.tree_
        n = t.node_count
        cl = t.children_left.astype(np.int64)
        cr = t.children_right.astype(np.int64)
        leaf = cl == -1
        left.append(np.where(leaf, -1, cl + off))
        right.append(np.where(leaf, -1, cr + off))
        fmap = np.asarray(feats, dtype=np.int64)
        feat.append(np.where(leaf, -1, fmap[np.clip(t.feature, 0, None)]))
        thr.append(np.asarray(t.threshold, dtype=np.float64))
        val.append(np.asarray(t.value, dtype=np.float64).reshape(n))
        roots.append(off)
        off += n
    return {
        "children_left": np.concatenate(left),
        "children_right": np.concatenate(right),
        "feature": np.concatenate(feat),
        "threshold": np.concatenate(thr),
        "value": np.concatenate(val),
        "roots": np.asarray(roots, dtype=np.int64),
    }


# ---------------------------------------------------------------------------
# save / load
# ---------------------------------------------------------------------------
def _jsonable(o: Any) -> Any:
    if isinstance(o, dict):
        return {str(k): _jsonable(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_jsonable(v) for v in o]
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, np.floating):
        return float(o)
    if isinstance(o, np.ndarray):
        return _jsonable(o.tolist())
    if o is None or isinstance(o, (bool, int, float, str)):
        return o
    return repr(o)


def model_arrays(trained: Any) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Metadata and flat named arrays of a :class:`~drivelash.te.learn.fit.TrainedTEModel`."""
    meta: dict[str, Any] = {
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        "units": {
            "x_T": "m",
            "torque": "N*m",
            "TE (predict)": "m",
            "TE_def (targets, stage outputs, tree values)": "um",
            "geo_te": "m",
            "offset (a, b)": "um, um/(N*m)",
        },
        "pipeline": trained.pipeline.to_dict(),
        "directions": sorted(trained.models),
        "models": {},
        "info": _jsonable(trained.info),
    }
    flat: dict[str, np.ndarray] = {}
    for key in sorted(trained.models):
        st = trained.models[key]
        geo = trained.geo[key]
        W = st.nn_.weights()
        names = ("W1", "b1", "W2", "b2", "W3", "b3")
        arrs: dict[str, np.ndarray] = dict(zip(names, W, strict=True))
        arrs["x_mean"] = np.asarray(st.nn_.x_mean_, dtype=np.float64)
        arrs["x_scale"] = np.asarray(st.nn_.x_scale_, dtype=np.float64)
        arrs["y_mean"] = np.array([st.nn_.y_mean_])
        arrs["y_scale"] = np.array([st.nn_.y_scale_])
        arrs["geo_te"] = np.asarray(geo.te, dtype=np.float64)
        arrs["offset"] = np.asarray(getattr(trained, "offset", {}).get(key, (0.0, 0.0)), dtype=np.float64)
        arrs.update(flatten_trees(st.trees_))
        for n, a in arrs.items():
            flat[f"{key}.{n}"] = np.ascontiguousarray(a)
        meta["models"][key] = {
            "geo_x0": geo.x0,
            "geo_step": geo.step,
            "hidden": int(W[0].shape[1]),
            "n_inputs": int(W[0].shape[0]),
            "n_trees": len(st.trees_.estimators_),
            "n_nodes": int(arrs["threshold"].size),
            "nn_params": _jsonable({k: v for k, v in st.nn_.get_params().items()}),
            "tree_params": _jsonable(st.tree_info_.get("best_params", {})),
            "stage1_share": st.stage1_share_,
            "train_mae_um": st.train_mae_,
            "nn_info": _jsonable(st.nn_info_),
            "tree_info": _jsonable(st.tree_info_),
            "fit_time_s": _jsonable(getattr(st, "fit_time_", {})),
        }
    return meta, flat


def save_model(trained: Any, directory: str | Path, fmt: str = "safetensors") -> Path:
    """Write a trained model to ``directory`` (created) as ``model.json`` + weights.

    Parameters
    ----------
    trained : TrainedTEModel
        The fitted model.
    directory : str or Path
        Target directory.
    fmt : {"safetensors", "npz"}
        Weight file format.

    Returns
    -------
    Path
        The directory.
    """
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    meta, flat = model_arrays(trained)
    if fmt == "safetensors":
        from safetensors.numpy import save_file

        save_file(flat, str(d / WEIGHT_FILES[0]))
        (d / WEIGHT_FILES[1]).unlink(missing_ok=True)
    elif fmt == "npz":
        np.savez(d / WEIGHT_FILES[1], **flat)
        (d / WEIGHT_FILES[0]).unlink(missing_ok=True)
    else:
        raise ModelFileError(f"unknown weight format {fmt!r} (use 'safetensors' or 'npz')")
    meta["weights"] = WEIGHT_FILES[0] if fmt == "safetensors" else WEIGHT_FILES[1]
    (d / META_FILE).write_text(json.dumps(meta, indent=1, allow_nan=True), encoding="utf-8")
    return d


def _read_arrays(path: Path) -> dict[str, np.ndarray]:
    try:
        if path.suffix == ".safetensors":
            from safetensors.numpy import load_file

            return dict(load_file(str(path)))
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except Exception as exc:  # noqa: BLE001 - any parse failure is a bad file, never executed
        raise ModelFileError(f"{path}: not a valid weight file ({type(exc).__name__})") from None


def _need(arrs: Mapping[str, np.ndarray], key: str, name: str, kind: str, ndim: int) -> np.ndarray:
    full = f"{key}.{name}"
    if full not in arrs:
        raise ModelFileError(f"weights: missing array {full!r}")
    a = np.asarray(arrs[full])
    if a.dtype.kind not in kind or a.ndim != ndim:
        raise ModelFileError(f"weights: array {full!r} has dtype {a.dtype} and {a.ndim} dims")
    a = np.ascontiguousarray(a, dtype=np.float64 if "f" in kind else np.int64)
    if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
        raise ModelFileError(f"weights: array {full!r} contains NaN or inf")
    return a


def _validate_direction(
    arrs: Mapping[str, np.ndarray],
    key: str,
    meta_dir: Mapping[str, Any],
    n_t: int,
) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    for n, nd in (
        ("W1", 2),
        ("b1", 1),
        ("W2", 2),
        ("b2", 1),
        ("W3", 2),
        ("b3", 1),
        ("x_mean", 1),
        ("x_scale", 1),
        ("y_mean", 1),
        ("y_scale", 1),
        ("geo_te", 1),
        ("threshold", 1),
        ("value", 1),
    ):
        out[n] = _need(arrs, key, n, "f", nd)
    # the offset line (a, b) is optional (directories written before it existed: zero)
    out["offset"] = _need(arrs, key, "offset", "f", 1) if f"{key}.offset" in arrs else np.zeros(2)
    for n in ("children_left", "children_right", "feature", "roots"):
        out[n] = _need(arrs, key, n, "iu", 1)
    n_in, hid = out["W1"].shape
    ok = (
        n_in == n_t + 1
        and out["b1"].shape == (hid,)
        and out["W2"].shape == (hid, hid)
        and out["b2"].shape == (hid,)
        and out["W3"].shape == (hid, 1)
        and out["b3"].shape == (1,)
        and out["x_mean"].shape == (n_in,)
        and out["x_scale"].shape == (n_in,)
        and out["y_mean"].shape == (1,)
        and out["y_scale"].shape == (1,)
        and out["offset"].shape == (2,)
        and out["geo_te"].size >= 2
        and np.all(out["x_scale"] != 0)
    )
    if not ok:
        raise ModelFileError(f"weights: network arrays of direction {key!r} have inconsistent shapes")
    n_nodes = out["threshold"].size
    L, R, F, roots = out["children_left"], out["children_right"], out["feature"], out["roots"]
    if not (out["value"].size == L.size == R.size == F.size == n_nodes and roots.size >= 1 and n_nodes >= 1):
        raise ModelFileError(f"weights: tree arrays of direction {key!r} have inconsistent sizes")
    idx = np.arange(n_nodes)
    leaf = L == -1
    internal = ~leaf
    if not (
        np.all(R[leaf] == -1)
        and np.all(L[internal] == idx[internal] + 1)  # depth-first order (scikit-learn's builder)
        and np.all(R[internal] > idx[internal])
        and np.all(L[internal] < n_nodes)
        and np.all(R[internal] < n_nodes)
        and np.all((F[internal] == 0) | (F[internal] == 1))
        and np.all((roots >= 0) & (roots < n_nodes))
    ):
        raise ModelFileError(f"weights: tree arrays of direction {key!r} are not valid trees")
    if int(meta_dir.get("n_trees", roots.size)) != roots.size:
        raise ModelFileError(f"model.json: n_trees of direction {key!r} does not match the weights")
    return out


def load_model(directory: str | Path) -> TEModel:
    """Load a model directory written by :func:`save_model`, without executing anything in it.

    Parameters
    ----------
    directory : str or Path
        The model directory.

    Returns
    -------
    TEModel
        NumPy/numba predictor (no torch import).

    Raises
    ------
    ModelFileError
        Missing or malformed files, unsupported version, pickle-capable files present,
        or arrays that are not plain numbers of the expected shapes.
    """
    d = Path(directory)
    if not d.is_dir():
        raise ModelFileError(f"{d}: model directory not found")
    for p in sorted(d.iterdir()):
        if p.suffix.lower() in PICKLE_SUFFIXES:
            raise ModelFileError(f"{p}: refusing to load a model directory with a pickle-capable file")
    mpath = d / META_FILE
    if not mpath.is_file():
        raise ModelFileError(f"{mpath}: missing")
    try:
        meta = json.loads(mpath.read_text(encoding="utf-8"))
    except (ValueError, UnicodeDecodeError) as exc:
        raise ModelFileError(f"{mpath}: not valid JSON ({exc.__class__.__name__})") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT_NAME:
        raise ModelFileError(f"{mpath}: not a drivelash transmission-error model")
    if meta.get("version") != FORMAT_VERSION:
        raise ModelFileError(f"{mpath}: unsupported format version {meta.get('version')!r}")
    wname = meta.get("weights")
    if wname not in WEIGHT_FILES:
        raise ModelFileError(f"{mpath}: 'weights' must be one of {', '.join(WEIGHT_FILES)}")
    wpath = d / wname
    if not wpath.is_file():
        raise ModelFileError(f"{wpath}: missing")
    try:
        pipe = TEPipeline.from_dict(meta["pipeline"])
        dirs = list(meta["directions"])
        models = meta["models"]
        if not dirs or any(k not in ("pos", "neg") or k not in models for k in dirs):
            raise ValueError("directions")
        for k in dirs:
            float(models[k]["geo_x0"])
            if not float(models[k]["geo_step"]) > 0:
                raise ValueError("geo_step")
    except (KeyError, TypeError, ValueError, DrivelashError) as exc:
        raise ModelFileError(f"{mpath}: malformed metadata ({exc})") from None
    arrs = _read_arrays(wpath)
    arrays = {k: _validate_direction(arrs, k, models[k], int(pipe.geometry.n_t)) for k in dirs}
    return TEModel(meta, arrays)


__all__ = ["ModelFileError", "flatten_trees", "load_model", "model_arrays", "save_model"]
