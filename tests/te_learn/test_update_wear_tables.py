"""``te update`` on passes over part of the travel.

Finding A7 (session 20, tester A). The conftest's model is updated on passes over
120 … 280 mm (trimmed by the preprocessing to 150 … 250 mm) of a rack with a 3 µm local
defect at 200 mm (σ 8 mm), the conftest's deformation otherwise unchanged:

* A7 — where the passes do not reach, the rack did not change, so the updated model must
  predict what its parent predicts there (before: the whole model shifted by minus the
  defect's mean over the pass, ≈ −0.6 µm, and the trees extrapolated the passes' edges);
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from drivelash.commands.te_update import run_update
from drivelash.io.trace import Trace
from drivelash.te.runtime.persist import load_model, save_model

from .conftest import GEOM, te_def_um, torque_of

V = 0.05  # m/s
T_S = 1e-3  # s
DEFECT_UM = 3.0  # the conftest's local defect: 3 µm at x = 0.2 m, σ 8 mm
LOADS = (0.0, 1000.0, 2000.0, 3000.0)


def _defect_um(x: np.ndarray) -> np.ndarray:
    return DEFECT_UM * np.exp(-0.5 * ((x - 0.2) / 0.008) ** 2)


def write_partial_campaign(directory: Path, model, lo: float, hi: float) -> Path:
    """One pass per load and direction over lo … hi [m] of the worn rack (manifest layout)."""
    directory.mkdir(parents=True)
    runs = []
    x_up = np.arange(lo, hi, V * T_S)
    for d, key in ((1, "pos"), (-1, "neg")):
        x = x_up if d > 0 else x_up[::-1]
        for F in LOADS:
            te = model.geometric(x, d) + d * te_def_um(x, F, DEFECT_UM) * 1e-6
            cols = {
                "t": np.arange(x.size) * T_S,
                "x_T": x,
                "theta_m": (x - te) * 2 * GEOM.i_pg / GEOM.d_p,
                "torque_m": torque_of(F, x),
                "direction": np.full(x.size, float(d)),
            }
            name = f"{key}_F{F:g}.parquet"
            Trace(cols, {}).to_parquet(directory / name)
            runs.append({"file": name, "kind": "load", "load": F, "velocity": V, "direction": d})
    manifest = {
        "format": "drivelash.te-campaign",
        "version": 2,
        "source": "imported",
        "axis": model.context.axis.model_dump(mode="json"),
        "columns": ["t", "x_T", "theta_m", "torque_m", "direction"],
        "runs": runs,
    }
    (directory / "manifest.json").write_text(json.dumps(manifest), encoding="utf-8")
    return directory


@pytest.fixture(scope="module")
def updated(small_trained, tmp_path_factory):
    root = tmp_path_factory.mktemp("upd_part")
    m1 = save_model(small_trained, root / "m1")
    camp = write_partial_campaign(root / "worn", load_model(m1), 0.12, 0.28)
    m2 = root / "m2"
    run_update(m1, [camp], m2, echo=lambda line: None)
    return root, m1, m2


def test_a_partial_update_keeps_the_model_where_the_passes_did_not_reach(updated):
    """Outside the passes' travel the updated model predicts the parent's TE (absolute).

    Reference: the parent's own prediction (the rack did not change there). Tolerance 0.1 µm
    mean |difference| — the refitted trees reproduce the parent's rows to a few 0.01 µm; the
    old code shifted the level by the defect's mean over the trimmed pass
    (3 µm · 8 mm · √(2π) / 100 mm ≈ 0.6 µm). Inside, the defect is learnt: at its centre the
    change is the defect's 3 µm with the flank's sign to 20 %.
    """
    _, m1, m2 = updated
    a, b = load_model(m1), load_model(m2)
    x = np.arange(0.0, 0.3, 0.5e-3)
    out = (x < 0.13) | (x > 0.27)
    for d in (1, -1):
        for F in LOADS:
            tq = torque_of(F, x)
            diff_um = (b.predict(x, tq, d) - a.predict(x, tq, d)) * 1e6
            assert np.mean(np.abs(diff_um[out])) < 0.1, (d, F, np.mean(diff_um[out]))
            centre = np.abs(x - 0.2) < 0.6e-3
            assert np.all(np.abs(diff_um[centre] - d * DEFECT_UM) < 0.2 * DEFECT_UM), (d, F, diff_um[centre])
