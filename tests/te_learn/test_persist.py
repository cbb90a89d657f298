"""Persistence: safe loading, equality with the trained model, no torch, njit form."""

from __future__ import annotations

import hashlib
import json
import pickle
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from numba import njit

from drivelash.errors import DrivelashError
from drivelash.te.runtime.persist import ModelFileError, load_model, save_model
from drivelash.te.runtime.predictor import te_point


@pytest.fixture(scope="module")
def model_dir(small_trained, tmp_path_factory) -> Path:
    return save_model(small_trained, tmp_path_factory.mktemp("te_model"))


def _points(n: int = 5000):
    rng = np.random.default_rng(3)
    return rng.uniform(-0.01, 0.31, n), rng.uniform(0.0, 9.0, n)


@pytest.mark.parametrize("fmt", ["safetensors", "npz"])
def test_loaded_equals_trained(small_trained, tmp_path, fmt):
    d = save_model(small_trained, tmp_path / fmt, fmt=fmt)
    m = load_model(d)
    x, tq = _points()
    for direction in (1, -1):
        ref_def = small_trained.predict_def_um(x, tq, direction)
        np.testing.assert_allclose(m.predict_def_um(x, tq, direction), ref_def, rtol=0, atol=1e-9)
        ref = small_trained.predict(x, tq, direction)
        np.testing.assert_allclose(m.predict(x, tq, direction) * 1e6, ref * 1e6, rtol=0, atol=1e-9)
        one = m.predict_one(float(x[7]), float(tq[7]), direction)
        assert abs(one - ref[7]) * 1e6 <= 1e-9
    # the two directions really are different models (not one reused)
    assert np.max(np.abs(m.predict(x, tq, 1) - m.predict(x, tq, -1))) > 1e-6


def test_metadata_is_plain_json_with_units(model_dir):
    meta = json.loads((model_dir / "model.json").read_text())
    assert meta["units"]["TE (predict)"] == "m"
    assert set(meta["directions"]) == {"pos", "neg"}
    assert sorted(p.name for p in model_dir.iterdir()) == ["model.json", "weights.safetensors"]


def test_trees_match_sklearn_exactly(small_trained, model_dir):
    """Stage 2 of the loaded model equals BaggingRegressor.predict (float32 threshold semantics)."""
    m = load_model(model_dir)
    st = small_trained.models["pos"]
    x, tq = _points()
    X = small_trained.pipeline.design_matrix(x, tq)
    p1, p2 = st.predict_stages(X)
    got = m.predict_def_um(x, tq, 1)
    np.testing.assert_allclose(got - p1, p2, rtol=0, atol=1e-9)


def test_load_and_predict_without_torch(model_dir):
    code = textwrap.dedent(
        f"""
        import sys
        import numpy as np
        from drivelash.te.runtime.persist import load_model
        m = load_model({str(model_dir)!r})
        v = m.predict(np.linspace(0, 0.3, 100), 2.0, 1)
        o = m.predict_one(0.1, 2.0, -1)
        assert np.all(np.isfinite(v)) and np.isfinite(o)
        assert 'torch' not in sys.modules, 'torch was imported'
        print('ok')
        """
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().endswith("ok")


def test_njit_callable_point_form(small_trained, model_dir):
    m = load_model(model_dir)
    f, ib = m.kernel_arrays(1)

    @njit
    def user_loop(xs, tq, f, ib):
        out = np.empty(xs.size)
        for i in range(xs.size):
            out[i] = te_point(xs[i], tq, f, ib)
        return out

    x = np.linspace(0.01, 0.29, 50)
    np.testing.assert_allclose(user_loop(x, 3.0, f, ib), small_trained.predict(x, 3.0, 1), rtol=0, atol=1e-15)


class _Boom:
    """Pickle payload: unpickling would create the marker file."""

    def __init__(self, marker: str) -> None:
        self.marker = marker

    def __reduce__(self):
        return (Path.touch, (Path(self.marker),))


def _payload(marker: Path) -> bytes:
    return pickle.dumps(_Boom(str(marker)))


def test_payload_really_executes_when_unpickled(tmp_path):
    """Guard: the payload used below is live (so the safety tests can fail)."""
    marker = tmp_path / "marker"
    pickle.loads(_payload(marker))
    assert marker.exists()


def _copy(model_dir: Path, dst: Path) -> Path:
    dst.mkdir()
    for p in model_dir.iterdir():
        (dst / p.name).write_bytes(p.read_bytes())
    return dst


@pytest.mark.parametrize("name", ["model.pkl", "weights.npy", "stage1.pt", "trees.joblib"])
def test_pickle_files_in_dir_are_refused(model_dir, tmp_path, name):
    marker = tmp_path / "marker"
    d = _copy(model_dir, tmp_path / "evil")
    (d / name).write_bytes(_payload(marker))
    with pytest.raises(ModelFileError):
        load_model(d)
    assert not marker.exists()


def test_weight_file_replaced_by_pickle_is_an_error(model_dir, tmp_path):
    marker = tmp_path / "marker"
    d = _copy(model_dir, tmp_path / "evil")
    (d / "weights.safetensors").write_bytes(_payload(marker))
    with pytest.raises(DrivelashError):
        load_model(d)
    assert not marker.exists()


def test_npz_with_object_array_is_an_error(small_trained, tmp_path):
    marker = tmp_path / "marker"
    d = save_model(small_trained, tmp_path / "npz", fmt="npz")
    with np.load(d / "weights.npz") as z:
        arrs = {k: z[k] for k in z.files}
    arrs["pos.W1"] = np.array([_Boom(str(marker))], dtype=object)
    np.savez(d / "weights.npz", **arrs)  # numpy pickles the object array
    with pytest.raises(ModelFileError):
        load_model(d)
    assert not marker.exists()


def test_corrupt_metadata_and_trees_are_errors(model_dir, tmp_path):
    d = _copy(model_dir, tmp_path / "bad_json")
    (d / "model.json").write_text("{not json")
    with pytest.raises(ModelFileError):
        load_model(d)
    d = _copy(model_dir, tmp_path / "bad_version")
    meta = json.loads((d / "model.json").read_text())
    meta["version"] = 99
    (d / "model.json").write_text(json.dumps(meta))
    with pytest.raises(ModelFileError, match="version"):
        load_model(d)
    # a tree whose child points back to its parent would loop forever: refused
    from safetensors.numpy import load_file, save_file

    d = _copy(model_dir, tmp_path / "cycle")
    arrs = dict(load_file(str(d / "weights.safetensors")))
    left = arrs["pos.children_left"].copy()
    i = int(np.flatnonzero(left != -1)[1])
    left[i] = 0
    arrs["pos.children_left"] = left
    save_file(arrs, str(d / "weights.safetensors"))
    with pytest.raises(ModelFileError, match="not valid trees"):
        load_model(d)
    with pytest.raises(ModelFileError, match="not found"):
        load_model(tmp_path / "nowhere")


@pytest.mark.parametrize("fmt", ["safetensors", "npz"])
def test_a_plausible_but_changed_weight_file_is_refused(small_trained, tmp_path, fmt):
    """Left alone until session 17: ``model.json`` held no integrity record, so a weight file
    that still passes every content check (one stage-1 weight changed by 1 %, or another
    model's weights swapped in) loaded silently and predicted other numbers. ``model.json``
    now stores the weight file's SHA-256; a mismatch is one line naming the file and the key.
    Negative control: the unchanged copy loads and predicts as saved."""
    from safetensors.numpy import load_file, save_file

    d = save_model(small_trained, tmp_path / "m", fmt=fmt)
    meta = json.loads((d / "model.json").read_text())
    w = d / meta["weights"]
    assert len(meta["weights_sha256"]) == 64
    assert meta["weights_sha256"] == hashlib.sha256(w.read_bytes()).hexdigest()
    x, tq = _points(200)
    ref = load_model(d).predict(x, tq, 1)  # negative control: as saved
    if fmt == "safetensors":
        arrs = dict(load_file(str(w)))
    else:
        with np.load(w) as z:
            arrs = {k: z[k] for k in z.files}
    arrs["pos.W3"] = arrs["pos.W3"] * 1.01
    if fmt == "safetensors":
        save_file(arrs, str(w))
    else:
        np.savez(w, **arrs)
    with pytest.raises(ModelFileError) as ei:
        load_model(d)
    msg = str(ei.value)
    assert "\n" not in msg and str(w) in msg and "weights_sha256" in msg
    # the changed file passes every content check: without the record it loads, with other numbers
    # (a file without records, as written before session 17: no content digests either)
    del meta["weights_sha256"], meta["content_sha256"]
    (d / "model.json").write_text(json.dumps(meta))
    assert np.max(np.abs(load_model(d).predict(x, tq, 1) - ref)) > 0


def test_saving_a_loaded_model_is_a_clear_error(model_dir, tmp_path):
    """Tester finding (session 14): ``save_model(load_model(M), d)`` raised a raw
    ``AttributeError: 'TEModel' object has no attribute 'models'``; now one line saying what
    save_model writes and how to keep a loaded model, and nothing written."""
    with pytest.raises(ModelFileError) as ei:
        save_model(load_model(model_dir), tmp_path / "copy")
    assert "\n" not in str(ei.value) and "copy that directory" in str(ei.value)
    assert not (tmp_path / "copy").exists()


def test_a_full_disk_while_saving_the_weights_is_one_line(small_trained, model_dir, tmp_path, monkeypatch):
    """``te fit -o MODEL`` on a full disk: safetensors raises ``SafetensorError`` ("I/O error: No
    space left on device (os error 28)"), no ``OSError`` — a traceback. Now the one-line error of
    the outputs; the previous model stays byte for byte."""
    import safetensors.numpy
    from safetensors import SafetensorError

    from drivelash.errors import OutputError
    from drivelash.io.outputs import Outputs

    target = _copy(model_dir, tmp_path / "model")
    before = {p.name: p.read_bytes() for p in sorted(tmp_path.rglob("*")) if p.is_file()}

    def full(*a, **k):
        raise SafetensorError("Error while serializing: I/O error: No space left on device (os error 28)")

    monkeypatch.setattr(safetensors.numpy, "save_file", full)
    with pytest.raises(OutputError) as ei, Outputs("te fit", force=True) as out:
        save_model(small_trained, out.staging(out.directory(target, option="-o")))
    assert str(ei.value) == (
        f"-o {target}: cannot write it: No space left on device; the existing files were left as they were"
    )
    assert {p.name: p.read_bytes() for p in sorted(tmp_path.rglob("*")) if p.is_file()} == before
