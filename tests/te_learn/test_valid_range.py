"""The stored valid position range is where the model was measured (issue 12 item 3).

``model_context`` takes the span the no-load runs of both directions covered (50–450 mm on
the quick campaign), while the no-load curves hold data on a narrower span (55–445 mm; the
preprocessing trims their ends and holds them flat outside). The model used to store the
wider span, and ``te validate`` and its compensator table read it, while ``te export`` used
the intersection. Now :func:`save_model` stores the intersection
(:func:`~drivelash.te.runtime.table.measured_range`), ``te update`` writes it into the new
version, and a file written before is narrowed to it on load, so that it behaves as a new one.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from cli_runner import run_in_process
from drivelash.errors import ParameterError
from drivelash.te.runtime.persist import ModelFileError, load_model, save_model
from drivelash.te.runtime.table import build_table, measured_range

from .conftest import LOADS, synthetic_context
from .test_model_files import _copy_edit
from .test_update_cli import write_campaign

#: The runs' span, 5 mm wider on each side than the synthetic curves (0 … 0.3 m), as on the quick
#: campaign (runs 50–450 mm, curves 55–445 mm).
RUNS_SPAN = (-0.005, 0.305)


def _stored(d: Path) -> tuple[float, float]:
    vr = json.loads((d / "model.json").read_text())["valid_range"]
    return vr["x_min"], vr["x_max"]


@pytest.fixture(scope="module")
def wide_dir(small_trained, tmp_path_factory) -> Path:
    """A model fitted with the runs' span as its context's valid range (what ``te fit`` builds)."""
    trained = dataclasses.replace(small_trained, context=synthetic_context(*RUNS_SPAN))
    return save_model(trained, tmp_path_factory.mktemp("wide"))


def test_the_saved_range_is_the_measured_range(wide_dir, small_trained):
    lo, hi = small_trained.geometric_range()
    assert (lo, hi) == pytest.approx((0.0, 0.3), abs=1e-12)
    assert _stored(wide_dir) == (lo, hi)  # before: the runs' span, (-0.005, 0.305)
    m = load_model(wide_dir)
    vr = m.context.valid_range
    assert (vr.x_min, vr.x_max) == measured_range(m) == m.geometric_range() == (lo, hi)
    # the torque range and the training loads are not touched
    assert vr.torque_max == 9.0 and vr.loads == list(LOADS)


def test_a_stored_range_inside_the_curves_is_kept(small_trained, tmp_path):
    # negative control: the intersection never widens a narrower stored range to the curves
    trained = dataclasses.replace(small_trained, context=synthetic_context(0.05, 0.25))
    d = save_model(trained, tmp_path / "narrow")
    assert _stored(d) == (0.05, 0.25)
    m = load_model(d)
    assert (m.context.valid_range.x_min, m.context.valid_range.x_max) == measured_range(m) == (0.05, 0.25)


@pytest.fixture(scope="module")
def old_dir(wide_dir, tmp_path_factory) -> Path:
    """The same model as a file written before the fix: model.json holds the runs' span."""
    tmp = tmp_path_factory.mktemp("old")
    lo, hi = RUNS_SPAN
    # a file written before the fix also had no content digests (stored since session 20)
    return _copy_edit(
        wide_dir, tmp, lambda m: (m["valid_range"].update(x_min=lo, x_max=hi), m.pop("content_sha256"))
    )


def test_an_old_file_loads_and_behaves_as_a_new_one(wide_dir, old_dir):
    assert _stored(old_dir) == RUNS_SPAN
    new, old = load_model(wide_dir), load_model(old_dir)
    assert old.context == new.context
    assert old.meta["valid_range"] == new.meta["valid_range"]
    assert measured_range(old) == measured_range(new)
    # the table te validate and the compensator read: the same grid, the same values
    ta, tb = (build_table(m, *measured_range(m), 1e-3, 9.0, 4) for m in (new, old))
    assert (ta.x0, ta.dx, ta.te.shape) == (tb.x0, tb.dx, tb.te.shape)
    np.testing.assert_array_equal(ta.te, tb.te)
    # positions of the runs' span that the curves do not hold are refused, not held flat
    # (before, the old file's stored range let build_table sample them)
    with pytest.raises(ParameterError, match=r"valid range \[0, 0\.3\] m"):
        build_table(old, RUNS_SPAN[0], RUNS_SPAN[1], 1e-3, 9.0, 4)


def test_a_range_disjoint_from_the_curves_is_refused_in_one_line(wide_dir, tmp_path):
    d = _copy_edit(wide_dir, tmp_path, lambda m: m["valid_range"].update(x_min=0.4, x_max=0.5))
    with pytest.raises(ModelFileError, match="do not overlap") as exc:
        load_model(d)
    msg = str(exc.value)
    assert "model.json" in msg and "\n" not in msg


def test_update_writes_the_measured_range_into_the_new_version(old_dir, tmp_path, capsys):
    """``te update`` of a file written before: the new version stores the measured range."""
    camp = write_campaign(tmp_path / "worn", load_model(old_dir), (0.0, 1000.0, 2000.0, 3000.0), 3.0)
    new = tmp_path / "m2"
    code, out, err = run_in_process(["te", "update", str(old_dir), str(camp), "-o", str(new)], capsys)
    assert code == 0, out + err
    assert _stored(old_dir) == RUNS_SPAN  # the parent is an input, never rewritten
    assert _stored(new) == measured_range(load_model(new)) == measured_range(load_model(old_dir))
