"""A hand-edited ``model.json`` is refused on load naming the file and the key (finding A1).

Before (session 20, tester A): in-range edits of the numbers that place the arrays
(``models.<dir>.geo_x0``, ``geo_step``), the geometry (``d_p``), the valid range
(``torque_max``), swapped ``models.pos``/``neg`` or a deleted ``weights_sha256`` loaded
silently (tables off by up to 59 µm). ``save_model`` now stores each key's SHA-256
(``content_sha256``); a formatting-only change (indentation, key order) still loads, and a
file written before the digests existed (no ``content_sha256``) loads as before.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from cli_runner import run_in_process
from drivelash.te.runtime.persist import ModelFileError, load_model, save_model


@pytest.fixture(scope="module")
def model_dir(small_trained, tmp_path_factory) -> Path:
    return save_model(small_trained, tmp_path_factory.mktemp("integrity") / "m")


def _edited(model_dir: Path, tmp_path: Path, fn, name: str = "m") -> Path:
    d = tmp_path / name
    shutil.copytree(model_dir, d)
    meta = json.loads((d / "model.json").read_text())
    fn(meta)
    (d / "model.json").write_text(json.dumps(meta, indent=1))
    return d


def _swap(m):
    m["models"]["pos"], m["models"]["neg"] = m["models"]["neg"], m["models"]["pos"]


@pytest.mark.parametrize(
    ("edit", "key"),
    [
        (lambda m: m["models"]["pos"].update(geo_x0=m["models"]["pos"]["geo_x0"] + 0.1), "models.pos"),
        (lambda m: m["models"]["neg"].update(geo_step=2 * m["models"]["neg"]["geo_step"]), "models.neg"),
        (lambda m: m["pipeline"]["geometry"].update(d_p=1.05 * m["pipeline"]["geometry"]["d_p"]), "pipeline"),
        (lambda m: m["valid_range"].update(torque_max=1000.0), "valid_range"),
        (_swap, "models.neg"),
        (lambda m: m.pop("weights_sha256"), "weights_sha256"),
        (lambda m: m["info"].update(note="hidden"), "info"),
    ],
)
def test_an_edited_model_json_is_refused_naming_the_key(model_dir, tmp_path, edit, key):
    d = _edited(model_dir, tmp_path, edit)
    with pytest.raises(ModelFileError) as err:
        load_model(d)
    msg = str(err.value)
    assert "\n" not in msg and str(d / "model.json") in msg and f"key '{key}'" in msg, msg


def test_formatting_and_an_old_file_still_load(model_dir, tmp_path):
    """Negative controls: the unedited copy, a re-indented one with the keys in another order,
    and a file without ``content_sha256`` (written by the release before) load and predict
    the saved numbers bit for bit."""
    x = np.linspace(0.01, 0.29, 64)
    ref = load_model(model_dir).predict(x, 2.0, 1)
    reordered = _edited(model_dir, tmp_path, lambda m: None, "fmt")
    meta = json.loads((reordered / "model.json").read_text())
    (reordered / "model.json").write_text(json.dumps(dict(reversed(list(meta.items()))), indent=4))
    old = _edited(model_dir, tmp_path, lambda m: m.pop("content_sha256"), "old")
    for d in (model_dir, reordered, old):
        assert np.array_equal(load_model(d).predict(x, 2.0, 1), ref)


def test_te_export_of_an_edited_model_is_one_line_exit_2(model_dir, tmp_path, capsys):
    d = _edited(model_dir, tmp_path, lambda m: m["models"]["pos"].update(geo_x0=0.01))
    out = tmp_path / "x.ini"
    code, so, se = run_in_process(["te", "export", str(d), "-o", str(out)], capsys)
    assert code == 2 and not out.exists() and "Traceback" not in se
    line = se.strip()
    assert "\n" not in line and "key 'models.pos' changed after the model was saved" in line, line
