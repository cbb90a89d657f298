"""The model directory: versioned schema validated on load, bounded effort, plausible outputs (issue 15).

Each test damages one number of a saved model the way a corrupted or hand-edited file
would; loading must refuse it with one line naming the file and the key, quickly (an
absurd contact ratio or substep count used to hang the kernels), and a model whose weights
predict nonsense is never exported.
"""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

from drivelash.te.runtime.persist import ModelFileError, load_model, save_model


@pytest.fixture(scope="module")
def model_dir(small_trained, tmp_path_factory) -> Path:
    return save_model(small_trained, tmp_path_factory.mktemp("te_model"))


def _copy_edit(model_dir: Path, tmp_path: Path, fn) -> Path:
    d = tmp_path / "m"
    shutil.copytree(model_dir, d)
    meta = json.loads((d / "model.json").read_text())
    fn(meta)
    (d / "model.json").write_text(json.dumps(meta))
    return d


def test_saved_model_carries_its_context(model_dir):
    meta = json.loads((model_dir / "model.json").read_text())
    assert meta["format"] == "drivelash.te-model" and meta["version"] == 2
    assert {"axis", "valid_range", "compensator", "campaign"} <= set(meta)
    m = load_model(model_dir)
    assert m.context.valid_range.x_max == 0.3 and m.context.axis.geometry.n_t == 20


def _sim_block(n_sub):
    return {"seed": 0, "sim_config": {"n_sub": n_sub}}


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (lambda m: m["pipeline"]["geometry"].update(eps=1e9), "pipeline.geometry"),
        (lambda m: m["pipeline"]["geometry"].update(n_t=1e8), "pipeline.geometry.n_t"),
        (lambda m: m["models"]["pos"].update(hidden=10**9), "models.pos.hidden"),
        (lambda m: m.update(simulator=_sim_block(10**8)), "simulator"),
        (lambda m: m.pop("valid_range"), "key 'valid_range': missing"),
        (lambda m: m.update(valid_range=[0, 1]), "key 'valid_range'"),
        (lambda m: m["valid_range"].update(x_max=-5.0), "x_max"),
        (lambda m: m["compensator"].update(t_sc=-1.0), "key 'compensator'"),
        (lambda m: m.update(version=1), "version 1 models depend on their campaign"),
        (lambda m: m.update(weights="../../secret.npz"), "key 'weights'"),
        (lambda m: m.update(extra_key=1), "key 'extra_key': unknown key"),
    ],
)
def test_bad_model_json_is_refused_quickly_with_one_line(model_dir, tmp_path, edit, needle):
    d = _copy_edit(model_dir, tmp_path, edit)
    t0 = time.perf_counter()
    with pytest.raises(ModelFileError) as exc:
        load_model(d)
    assert time.perf_counter() - t0 < 30.0  # refused, not hanging
    msg = str(exc.value)
    assert needle in msg and "model.json" in msg and "\n" not in msg


def test_huge_weights_are_refused_not_exported(model_dir, tmp_path):
    """Weights ×1e300 used to export a ±4e300 µm table with exit 0."""
    from safetensors.numpy import load_file, save_file

    d = tmp_path / "m"
    shutil.copytree(model_dir, d)
    arrs = dict(load_file(str(d / "weights.safetensors")))
    for k in [k for k in arrs if k.endswith(".W3")]:
        arrs[k] = arrs[k] * 1e300
    save_file(arrs, str(d / "weights.safetensors"))
    with pytest.raises(
        ModelFileError, match=r"weights.safetensors: direction '(pos|neg)' predicts TE = .*implausible"
    ):
        load_model(d)


def test_export_table_refuses_implausible_values(tmp_path):
    from drivelash.errors import DataError
    from drivelash.te.runtime.export import export_table
    from drivelash.te.runtime.table import TETable

    te = np.zeros((2, 3, 2))
    te[0, 1, 1] = 4e294  # ±4e300 µm
    tab = TETable(0.0, 1e-3, np.array([0.0, -1.0]), np.array([1.0, 1.0]), te)
    with pytest.raises(DataError, match="refusing to export"):
        export_table(tab, tmp_path / "t.csv")
    assert not (tmp_path / "t.csv").exists()


class _FlatModel:
    """Predicts the same TE everywhere: the load-time output check at its documented limit."""

    directions = ("pos", "neg")

    def __init__(self, te: float, valid_range) -> None:
        self.te = te
        self.context = type("Context", (), {"valid_range": valid_range})()

    def predict(self, x, torque, direction):
        return np.full(np.shape(x), self.te)


@pytest.mark.parametrize("te", [9.9e-3, -9.9e-3])
def test_a_model_predicting_up_to_10_mm_loads(te):
    """docs/te-formats.md §3: on load "the model must predict finite TE of at most 10 mm over its
    valid range". 9.9 mm passes (a rack's TE is µm, but the limit is the documented one)."""
    from drivelash.te.runtime.persist import ValidRange, check_outputs

    check_outputs(_FlatModel(te, ValidRange(x_min=0.0, x_max=0.5, torque_max=9.0)), "w.safetensors")


@pytest.mark.parametrize("te", [10.1e-3, -10.1e-3, float("nan"), float("inf")])
def test_a_model_predicting_more_than_10_mm_or_not_finite_is_refused(te):
    from drivelash.te.runtime.persist import ValidRange, check_outputs

    with pytest.raises(ModelFileError, match=r"^w\.safetensors: direction 'pos' predicts TE = .* um") as e:
        check_outputs(_FlatModel(te, ValidRange(x_min=0.0, x_max=0.5, torque_max=9.0)), "w.safetensors")
    assert "\n" not in str(e.value)
