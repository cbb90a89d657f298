"""Safe persistence of transmission-error models: the model directory, saved and loaded.

A model directory holds exactly two files that are read:

* ``model.json`` — metadata, a published, versioned schema (:class:`ModelMeta`,
  ``drivelash.te-model`` version 2): units, preprocessing, per-direction shapes and
  hyperparameters, the training record, and everything the runtime needs without the
  campaign (:class:`ModelContext`): the axis (geometry, drive, gains), the valid
  position and torque range, the compensator settings with the drive's inertia and
  friction, and — for a model of the virtual bench — the simulator that regenerates
  its drive;
* ``weights.safetensors`` (default) or ``weights.npz`` — plain numeric arrays:
  geometric curves, network weights and biases, standardisation, and the bagged
  trees as flat arrays (``children_left``, ``children_right``, ``feature``,
  ``threshold``, ``value`` of every ``tree_``, concatenated, with root offsets).

Loading never unpickles: JSON via :mod:`json`, arrays via ``safetensors.numpy``
or ``numpy.load(allow_pickle=False)``. A directory that contains a
pickle-capable file (``.pkl``, ``.pickle``, ``.joblib``, ``.npy``, ``.pt``, ``.pth``,
``.ckpt``, ``.dill``) or whose arrays are not plain numbers is refused with
:class:`ModelFileError` — nothing in it is executed. Tree arrays are checked so
that traversal always terminates (children after their parent). Every number in
``model.json`` is range-checked (an absurd contact ratio or substep count would hang the
kernels), and a loaded model must predict finite, physically possible values over its
valid range (a corrupted weight file is refused, not exported). Errors are one line
naming the file and the key.

:func:`load_model` returns a :class:`~drivelash.te.runtime.predictor.TEModel`, which
predicts with numba kernels only (torch is never imported).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field, field_validator, model_validator

from drivelash.errors import DataError, DrivelashError
from drivelash.io.campaign import AxisBlock
from drivelash.io.jsondoc import Document, read_document, read_raw_document
from drivelash.io.outputs import jsonable, write_json
from drivelash.te.learn.preprocess import TEPipeline
from drivelash.te.runtime.compensator import CompensatorParams
from drivelash.te.runtime.predictor import TEModel

FORMAT_NAME = "drivelash.te-model"
FORMAT_VERSION = 2
META_FILE = "model.json"
WEIGHT_FILES = ("weights.safetensors", "weights.npz")
#: Suffixes of files that can carry executable pickle payloads; their presence is refused.
PICKLE_SUFFIXES = (".pkl", ".pickle", ".joblib", ".npy", ".pt", ".pth", ".ckpt", ".dill", ".bin")


class ModelFileError(DrivelashError):
    """A model directory that is missing, malformed, or not safe to load."""


#: Largest |TE| a loaded model may predict over its valid range [m] (10 mm: far beyond
#: any rack-and-pinion transmission error; a corrupted weight file predicts far more).
TE_MAX = 10e-3
#: Bounds of the kernels' sizes (time and memory of one prediction stay bounded).
MAX_HIDDEN = 4096
MAX_TREES = 4096
MAX_NODES = 50_000_000
MAX_TEETH = 1000


def _finite(v: float) -> float:
    if not math.isfinite(v):
        raise ValueError("must be finite")
    return v


class GeometryDoc(Document):
    """``pipeline.geometry``: what the features need (d_p [m], n_t, i_pg, contact ratio eps)."""

    d_p: float = Field(gt=0, le=10.0)
    n_t: int = Field(ge=2, le=MAX_TEETH)
    i_pg: float = Field(gt=0, le=1e4)
    eps: float = Field(gt=0)

    @model_validator(mode="after")
    def _eps(self) -> GeometryDoc:
        # the bump kernel loops over ceil(eps) teeth: eps beyond n_t/2 is no gear (and would hang)
        if not (0.5 <= self.eps <= max(1.0, 0.5 * self.n_t)):
            raise ValueError(
                f"eps: contact ratio must lie in [0.5, n_t/2 = {0.5 * self.n_t:g}], got {self.eps!r}"
            )
        return self


class PipelineDoc(Document):
    """``pipeline``: the preprocessing (see :class:`~drivelash.te.learn.preprocess.TEPipeline`)."""

    geometry: GeometryDoc
    step: float = Field(ge=1e-7, le=1e-2)
    cutoff_factor: float = Field(gt=0, le=100)
    filter_order: int = Field(ge=1, le=10)
    offset: Literal["mean", "none"]
    trim: float = Field(ge=0, le=10)
    geo_trim: float = Field(default=5e-3, ge=0, le=10)


class DirectionDoc(Document):
    """``models.pos`` / ``models.neg``: shapes of one direction's arrays and its training record."""

    geo_x0: float
    geo_step: float = Field(gt=0, le=1.0)
    hidden: int = Field(ge=1, le=MAX_HIDDEN)
    n_inputs: int = Field(ge=2, le=MAX_TEETH + 1)
    n_trees: int = Field(ge=0, le=MAX_TREES)
    n_nodes: int = Field(ge=1, le=MAX_NODES)
    nn_params: dict[str, Any] = Field(default_factory=dict)
    tree_params: dict[str, Any] = Field(default_factory=dict)
    stage1_share: float | None = None
    train_mae_um: float | None = None
    nn_info: dict[str, Any] = Field(default_factory=dict)
    tree_info: dict[str, Any] = Field(default_factory=dict)
    fit_time_s: dict[str, Any] = Field(default_factory=dict)

    _f = field_validator("geo_x0")(_finite)


class ValidRange(Document):
    """Where the model was trained: positions [m] and the motor-torque magnitude [N·m].

    Attributes
    ----------
    x_min, x_max : float
        Table positions where the model was measured [m]: the span the geometric (no-load)
        runs of both directions covered ∩ the span the no-load curves hold data
        (:func:`~drivelash.te.runtime.table.measured_range`; written so by :func:`save_model`,
        and narrowed so on load for a file written before, whose range was the runs' span).
    torque_max : float
        Largest motor-torque magnitude of the training runs [N·m] (99.9th percentile of
        the constant-velocity parts); the runtime table spans [0, torque_max] per flank
        and holds its edge beyond (no extrapolation).
    loads : list of float
        The training loads [N].
    """

    x_min: float
    x_max: float
    torque_max: float = Field(gt=0, le=1e6)
    loads: list[float] = Field(default_factory=list)

    _f = field_validator("x_min", "x_max", "torque_max")(_finite)

    @model_validator(mode="after")
    def _order(self) -> ValidRange:
        if not self.x_max > self.x_min:
            raise ValueError(f"x_max ({self.x_max!r}) must exceed x_min ({self.x_min!r})")
        if self.x_max - self.x_min > 1000.0:
            raise ValueError(f"range of {self.x_max - self.x_min:g} m is not a rack")
        return self

    def contains(self, x_lo: float, x_hi: float, tol: float = 1e-9) -> bool:
        """True when [x_lo, x_hi] [m] lies inside the valid position range."""
        return x_lo >= self.x_min - tol and x_hi <= self.x_max + tol


class CampaignInfo(Document):
    """``campaign``: what the model was trained on (for reports; never read back as data)."""

    source: Literal["simulated", "imported"]
    directory: str | None = None
    velocities: list[float] = Field(default_factory=list)
    loads: list[float] = Field(default_factory=list)
    max_load: float | None = None
    holdout_loads: list[float] = Field(default_factory=list)


class ModelContext(Document):
    """Everything the runtime needs besides the arrays: stored in ``model.json`` (no campaign needed).

    Attributes
    ----------
    axis : AxisBlock
        Geometry, drive (inertias, friction) and loop gains of the axis.
    valid_range : ValidRange
        Positions and torques the model was trained on.
    compensator : CompensatorParams
        Compensator settings with the drive's inertia and friction filled in.
    campaign : CampaignInfo
        Source, velocities, loads of the training campaign.
    simulator : dict or None
        The ``simulator`` block of a virtual-bench campaign (seed, TE generator, engine,
        plan): ``te validate`` regenerates the drive from it.
    """

    axis: AxisBlock
    valid_range: ValidRange
    compensator: CompensatorParams
    campaign: CampaignInfo
    simulator: dict[str, Any] | None = None


class ModelMeta(ModelContext):
    """``model.json`` (format ``drivelash.te-model``, version 2)."""

    format: Literal["drivelash.te-model"]
    version: Literal[2]
    generator: str | None = None
    units: dict[str, str] = Field(default_factory=dict)
    pipeline: PipelineDoc
    directions: list[Literal["pos", "neg"]] = Field(min_length=1, max_length=2)
    models: dict[Literal["pos", "neg"], DirectionDoc]
    info: dict[str, Any] = Field(default_factory=dict)
    weights: Literal["weights.safetensors", "weights.npz"]
    #: SHA-256 of the weight file as written (absent in files written before it was stored)
    weights_sha256: str | None = Field(default=None, pattern="^[0-9a-f]{64}$")
    #: SHA-256 of every other key's canonical JSON as written (``models`` per direction), so a
    #: hand-edited or corrupted ``model.json`` is refused naming the key (absent in files
    #: written before it was stored: not checked)
    content_sha256: dict[str, Annotated[str, Field(pattern="^[0-9a-f]{64}$")]] | None = None

    @model_validator(mode="after")
    def _dirs(self) -> ModelMeta:
        if len(set(self.directions)) != len(self.directions):
            raise ValueError("directions: listed twice")
        for k in self.directions:
            if k not in self.models:
                raise ValueError(f"models: no entry for direction {k!r}")
            if self.models[k].n_inputs != self.pipeline.geometry.n_t + 1:
                raise ValueError(f"models.{k}.n_inputs: must be n_t + 1 = {self.pipeline.geometry.n_t + 1}")
        return self

    def context(self) -> ModelContext:
        """The runtime context alone."""
        return ModelContext(**{k: getattr(self, k) for k in ModelContext.model_fields})


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
def measured_context(model: Any, where: str | Path = "model") -> ModelContext:
    """``model.context`` with its valid position range narrowed to where the model was measured.

    The stored range (the span the no-load runs of both directions covered) ∩ the span the
    no-load curves hold data, :func:`~drivelash.te.runtime.table.measured_range` — the one
    definition that ``te export``, ``te validate``, ``te update`` and the compensator's table
    use. :func:`save_model` stores it; :func:`load_model` applies it to a file written before,
    whose stored range was the runs' span (e.g. 50–450 mm where the curves hold 55–445 mm).

    Parameters
    ----------
    model : TrainedTEModel or TEModel
        A model with ``context`` (:class:`ModelContext`) and ``geometric_range()`` [m].
    where : str or Path
        Named in the error.

    Returns
    -------
    ModelContext
        A copy; the torque range, loads and everything else unchanged.

    Raises
    ------
    ModelFileError
        The stored range and the no-load curves do not overlap.
    """
    from drivelash.te.runtime.table import measured_range

    ctx: ModelContext = model.context
    vr = ctx.valid_range
    lo, hi = measured_range(model)
    if (lo, hi) == (vr.x_min, vr.x_max):
        return ctx
    if not hi > lo:
        g_lo, g_hi = model.geometric_range()
        raise ModelFileError(
            f"{where}: the valid range [{vr.x_min:.6g}, {vr.x_max:.6g}] m and the span of the no-load"
            f" curves [{g_lo:.6g}, {g_hi:.6g}] m do not overlap: the model was measured nowhere"
        )
    narrowed = vr.model_copy(update={"x_min": lo, "x_max": hi})
    return ctx.model_copy(update={"valid_range": narrowed})


def model_arrays(trained: Any) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Metadata and flat named arrays of a :class:`~drivelash.te.learn.fit.TrainedTEModel`.

    ``trained.context`` (a :class:`ModelContext`) is required: a model without its axis,
    valid range and compensator settings could not be used without its campaign. The valid
    position range is stored as :func:`measured_context` gives it (where the no-load curves
    hold data, never the wider span of the runs).
    """
    ctx = getattr(trained, "context", None)
    if not isinstance(ctx, ModelContext):
        raise ModelFileError(
            "a model needs its context (axis, valid range, compensator): set trained.context"
            " (drivelash.te.protocol.bench.model_context)"
        )
    ctx = measured_context(trained)
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
        "info": jsonable(trained.info),
        **ctx.model_dump(mode="json"),
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
        change = getattr(trained, "noload_change", {}).get(key)
        if change is not None:  # only an updated model has one (never-updated files unchanged)
            arrs["noload_change"] = np.asarray(change, dtype=np.float64)
        for n, a in arrs.items():
            flat[f"{key}.{n}"] = np.ascontiguousarray(a)
        meta["models"][key] = {
            "geo_x0": geo.x0,
            "geo_step": geo.step,
            "hidden": int(W[0].shape[1]),
            "n_inputs": int(W[0].shape[0]),
            "n_trees": len(st.trees_.estimators_),
            "n_nodes": int(arrs["threshold"].size),
            "nn_params": jsonable({k: v for k, v in st.nn_.get_params().items()}),
            "tree_params": jsonable(st.tree_info_.get("best_params", {})),
            "stage1_share": st.stage1_share_,
            "train_mae_um": st.train_mae_,
            "nn_info": jsonable(st.nn_info_),
            "tree_info": jsonable(st.tree_info_),
            "fit_time_s": jsonable(getattr(st, "fit_time_", {})),
        }
    return meta, flat


def _save_safetensors(arrays: dict[str, np.ndarray], path: Path) -> None:
    """``safetensors.numpy.save_file``, its I/O failure as the ``OSError`` it wraps.

    safetensors reports a full disk as ``SafetensorError("… I/O error: No space left on device
    (os error 28)")``, no ``OSError``; as one, the command's :class:`~drivelash.io.outputs.Outputs`
    turns it into its one-line "cannot write it" error (it was a traceback).
    """
    import os
    import re

    from safetensors import SafetensorError
    from safetensors.numpy import save_file

    try:
        save_file(arrays, str(path))
        # safetensors creates the file 0600; the project's outputs honour the umask (finding A8:
        # a model directory shared with the CNC's service user had an unreadable weight file)
        from drivelash.io.outputs import _umask

        os.chmod(path, 0o666 & ~_umask())
    except SafetensorError as exc:
        m = re.search(r"\(os error (\d+)\)", str(exc))
        if m is None:
            raise
        code = int(m[1])
        raise OSError(code, os.strerror(code), str(path)) from exc


def save_model(trained: Any, directory: str | Path, fmt: str = "safetensors") -> Path:
    """Write a trained model as ``model.json`` + weights into ``directory`` (created).

    The metadata are validated against :class:`ModelMeta` before anything is written.
    Atomicity and overwrite rules are the caller's: commands write into a staging
    directory of :class:`drivelash.io.outputs.Outputs`.

    Parameters
    ----------
    trained : TrainedTEModel
        The fitted model, with its ``context``.
    directory : str or Path
        Target directory.
    fmt : {"safetensors", "npz"}
        Weight file format.

    Returns
    -------
    Path
        The directory.

    Raises
    ------
    ModelFileError
        An unknown ``fmt``, a loaded :class:`TEModel` instead of a trained model, or metadata
        that do not validate.
    """
    if fmt not in ("safetensors", "npz"):
        raise ModelFileError(f"unknown weight format {fmt!r} (use 'safetensors' or 'npz')")
    if isinstance(trained, TEModel):
        raise ModelFileError(
            "save_model writes a trained model (te fit's TrainedTEModel); a loaded TEModel is"
            " already on disk in its directory: copy that directory to keep another version"
        )
    meta, flat = model_arrays(trained)
    meta["weights"] = WEIGHT_FILES[0] if fmt == "safetensors" else WEIGHT_FILES[1]
    d = Path(directory)
    try:
        ModelMeta.model_validate(meta)
    except Exception as exc:  # noqa: BLE001 - a writer bug must not produce an unreadable model
        raise ModelFileError(
            f"{d / META_FILE}: the model to save is invalid ({exc})".splitlines()[0]
        ) from None
    d.mkdir(parents=True, exist_ok=True)
    if fmt == "safetensors":
        _save_safetensors(flat, d / WEIGHT_FILES[0])
        (d / WEIGHT_FILES[1]).unlink(missing_ok=True)
    else:
        np.savez(d / WEIGHT_FILES[1], **flat)
        (d / WEIGHT_FILES[0]).unlink(missing_ok=True)
    meta["weights_sha256"] = _sha256(d / meta["weights"])
    write_json(d / META_FILE, meta, indent=1)
    # each key's digest of the document as written (and as the loader will read it)
    meta["content_sha256"] = content_digests(read_raw_document(d / META_FILE))
    write_json(d / META_FILE, meta, indent=1)
    return d


#: The key of ``model.json`` holding the digests of the others (:func:`content_digests`).
CONTENT_KEY = "content_sha256"


def content_digests(doc: Mapping[str, Any]) -> dict[str, str]:
    """SHA-256 of each key of a parsed ``model.json`` but :data:`CONTENT_KEY`, ``models`` per direction.

    Canonical form: ``json.dumps(value, sort_keys=True, separators=(",", ":"))`` — independent of
    indentation and key order, so only a change of a value (or a key added or removed) changes it.

    Parameters
    ----------
    doc : mapping
        The raw JSON object of ``model.json``.

    Returns
    -------
    dict
        ``{key: hex digest}``; ``models`` as ``models.pos``, ``models.neg``.
    """
    import hashlib
    import json

    def dig(v: Any) -> str:
        text = json.dumps(v, sort_keys=True, separators=(",", ":"), ensure_ascii=True)
        return hashlib.sha256(text.encode("ascii")).hexdigest()

    out: dict[str, str] = {}
    for k, v in doc.items():
        if k == CONTENT_KEY:
            continue
        if k == "models" and isinstance(v, Mapping):
            out.update({f"models.{d}": dig(m) for d, m in v.items()})
            out["models"] = dig(sorted(v))
        else:
            out[k] = dig(v)
    return out


def _check_content(head: Mapping[str, Any], mpath: Path) -> None:
    """Refuse a ``model.json`` whose keys differ from the digests it was saved with (finding A1)."""
    stored = head.get(CONTENT_KEY)
    if stored is None:
        return  # written before the digests were stored
    now = content_digests(head)
    for k in sorted(set(stored) | set(now)):
        if stored.get(k) == now.get(k):
            continue
        what = "added" if k not in stored else "removed" if k not in now else "changed"
        raise ModelFileError(
            f"{mpath}: key '{k}' {what} after the model was saved (key '{CONTENT_KEY}'): a hand-edited"
            " or corrupted model is refused — copy the model directory whole, or refit"
        )


def _sha256(path: Path) -> str:
    import hashlib

    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


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
    # the no-load change of te update (optional: a model never updated has none)
    if f"{key}.noload_change" in arrs:
        out["noload_change"] = _need(arrs, key, "noload_change", "f", 1)
        if out["noload_change"].shape != out["geo_te"].shape:
            raise ModelFileError(
                f"weights: array '{key}.noload_change' has {out['noload_change'].size} values,"
                f" the no-load curve {out['geo_te'].size}"
            )
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
        NumPy/numba predictor (no torch import). Its ``context.valid_range`` is where the
        model was measured (:func:`measured_context`), also for a file written before the
        range was stored so.

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
        head = read_raw_document(mpath)
        if head.get("format") != FORMAT_NAME:
            raise ModelFileError(f"{mpath}: key 'format': not a drivelash transmission-error model")
        if head.get("version") != FORMAT_VERSION:
            raise ModelFileError(
                f"{mpath}: key 'version': unsupported format version {head.get('version')!r}"
                f" (this release reads {FORMAT_VERSION}; version 1 models depend on their campaign:"
                " refit with drivelash te fit)"
            )
        doc = read_document(mpath, ModelMeta)
        if doc.simulator is not None:  # the virtual drive: bounded effort (substeps, table step)
            from drivelash.io.jsondoc import validate_document
            from drivelash.sim.rack_campaign import SimulatorBlock

            class _Sim(Document):
                simulator: SimulatorBlock

            validate_document({"simulator": doc.simulator}, _Sim, mpath)
    except DataError as exc:
        raise ModelFileError(str(exc)) from None
    meta = doc.model_dump(mode="json")
    wpath = d / doc.weights
    if not wpath.is_file():
        raise ModelFileError(f"{wpath}: missing")
    pipe = TEPipeline.from_dict(meta["pipeline"])
    dirs = list(doc.directions)
    models = meta["models"]
    arrs = _read_arrays(wpath)
    arrays = {k: _validate_direction(arrs, k, models[k], int(pipe.geometry.n_t)) for k in dirs}
    model = TEModel(meta, arrays, context=doc.context())
    # a file written before the valid range was stored as measured: the same range as a new one
    model.context = measured_context(model, mpath)
    model.meta["valid_range"] = model.context.valid_range.model_dump(mode="json")
    check_outputs(model, wpath)
    # last: the checks above name what is wrong in a broken file; these see a plausible one
    # that is not the file the model was saved with (edited, swapped, or bit-flipped)
    _check_content(head, mpath)
    if doc.weights_sha256 is not None and _sha256(wpath) != doc.weights_sha256:
        raise ModelFileError(
            f"{wpath}: does not match {META_FILE} (key 'weights_sha256': the file changed after"
            " the model was saved — copy the model directory whole, or refit)"
        )
    return model


def check_outputs(model: TEModel, path: str | Path, n: int = 257) -> None:
    """Refuse a model whose predictions over its valid range are not finite or not physical.

    Evaluates TE on ``n`` positions × {0, ½, 1}·torque_max per direction (a few ms) and
    requires every value finite with |TE| <= :data:`TE_MAX`.

    Raises
    ------
    ModelFileError
        One line naming the file, the direction and the worst value.
    """
    vr = model.context.valid_range
    x = np.linspace(vr.x_min, vr.x_max, n)
    for key in model.directions:
        d = 1 if key == "pos" else -1
        for frac in (0.0, 0.5, 1.0):
            with np.errstate(all="ignore"):
                te = model.predict(x, d * frac * vr.torque_max, d)
            bad = ~np.isfinite(te) | (np.abs(te) > TE_MAX)
            if bad.any():
                k = int(np.flatnonzero(bad)[0])
                raise ModelFileError(
                    f"{path}: direction {key!r} predicts TE = {te[k] * 1e6:.4g} um at x = {x[k]:.4f} m"
                    f" (limit ±{TE_MAX * 1e6:g} um): corrupted or implausible weights"
                )


__all__ = [
    "FORMAT_VERSION",
    "ModelContext",
    "ModelFileError",
    "ModelMeta",
    "ValidRange",
    "CampaignInfo",
    "check_outputs",
    "flatten_trees",
    "measured_context",
    "load_model",
    "model_arrays",
    "save_model",
]
