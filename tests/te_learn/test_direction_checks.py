"""TEModel takes a direction as exactly +1 or −1 in every public method (the shared
``table.check_direction``): 0, 2, 0.5, NaN, "pos" or True are refused with one line instead of a
silent flank (predict_one took any direction ≤ 0 as −1), and a model without the asked direction
names it instead of a bare KeyError. ±1 in any integer form gives the same numbers, bit for bit."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from drivelash.errors import ParameterError
from drivelash.te.runtime.persist import content_digests, load_model, save_model

BAD = [0, 2, -2, 0.5, -0.5, float("nan"), "pos", True]
X = np.linspace(0.01, 0.29, 40)
TQ = np.linspace(0.5, 8.5, 40)


def _calls(m, d):
    return {
        "predict": lambda: m.predict(X, TQ, d),
        "predict_def_um": lambda: m.predict_def_um(X, TQ, d),
        "predict_stage1_um": lambda: m.predict_stage1_um(X, TQ, d),
        "predict_one": lambda: m.predict_one(0.1, 2.0, d),
        "geometric": lambda: m.geometric(X, d),
        "kernel_arrays": lambda: m.kernel_arrays(d),
    }


@pytest.fixture(scope="module")
def model_dir(small_trained, tmp_path_factory):
    return save_model(small_trained, tmp_path_factory.mktemp("te_model_dir"))


@pytest.fixture(scope="module")
def model(model_dir):
    return load_model(model_dir)


@pytest.mark.parametrize("bad", BAD, ids=repr)
def test_every_method_refuses_other_directions(model, bad):
    for name, call in _calls(model, bad).items():
        with pytest.raises(ParameterError) as err:
            call()
        msg = str(err.value)
        assert "\n" not in msg, name
        assert msg == f"TEModel.direction: must be +1 or -1, got {bad!r}", name


@pytest.mark.parametrize("code", [1, -1])
def test_integer_forms_give_the_same_numbers(model, code):
    ref = {k: c() for k, c in _calls(model, code).items()}
    for form in (np.int64(code), np.int32(code), float(code)):
        got = {k: c() for k, c in _calls(model, form).items()}
        for k in ref:
            a = ref[k] if k != "kernel_arrays" else ref[k][0].tobytes() + ref[k][1].tobytes()
            b = got[k] if k != "kernel_arrays" else got[k][0].tobytes() + got[k][1].tobytes()
            assert np.asarray(a).tobytes() == np.asarray(b).tobytes(), (k, form)


def test_one_direction_model_names_the_missing_direction(model_dir, tmp_path):
    d = shutil.copytree(model_dir, tmp_path / "pos_only")
    meta = json.loads((d / "model.json").read_text())
    meta["directions"] = ["pos"]
    meta["content_sha256"] = content_digests(meta)  # saved so (a hand edit alone is refused)
    (d / "model.json").write_text(json.dumps(meta))
    m = load_model(d)
    assert np.isfinite(m.predict_one(0.1, 2.0, 1))
    for name, call in _calls(m, -1).items():
        with pytest.raises(ParameterError) as err:
            call()
        assert str(err.value) == "TEModel.direction: model has no direction -1 (it has +1)", name


@pytest.mark.parametrize("torque", [2.0, -2.0])
def test_backlash_takes_each_flank_at_its_own_torque_sign(model, torque):
    """``TEModel.backlash(x, T)`` is TE(−1, −|T|) − TE(+1, +|T|), the gap ``TETable.backlash``
    gives: flank −1 carries a negative motor torque (``build_table``'s grid for it is
    [−torque_max, −torque_min]). It gave both flanks the same signed T, so for T ≠ 0 flank −1
    was asked at a torque it never carries and the two backlash functions of one model
    disagreed (here by about 3 µm at |T| = 2 N·m)."""
    from drivelash.te.runtime.table import build_table

    expected = model.predict(X, -abs(torque), -1) - model.predict(X, abs(torque), 1)
    assert np.array_equal(model.backlash(X, torque), expected)
    # a coarse grid on purpose (the check is at the nodes): the table says it misses the meshing
    with pytest.warns(UserWarning, match="coarser than the model resolves"):
        table = build_table(model, 0.05, 0.25, 0.01, torque_max=4.0, n_torque=3)  # torques 0, 2, 4
    xg = table.x_grid  # grid nodes: the table holds the model's values there
    np.testing.assert_allclose(model.backlash(xg, torque), table.backlash(xg, torque), rtol=0, atol=1e-12)
    assert model.backlash(X, 0.0) == pytest.approx(model.predict(X, 0.0, -1) - model.predict(X, 0.0, 1))
