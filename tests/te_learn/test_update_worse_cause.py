"""A refused ``te update`` names the measured cause when the passes show one (session 36, tester H).

Before: "the update makes the model worse (held-out passes neg: TE_def MAE 0.685 um before,
0.870 um after; …): nothing written; give --accept-worse …" — the figures, not why. Now the
refusal names held-out loads outside the update passes' loads, or passes whose error against the
model grows with the load (another axis or drive stiffness, which a wear update does not learn).
"""

from __future__ import annotations

import re

import pytest

from cli_runner import run_in_process
from drivelash.te.runtime.persist import load_model, save_model

from .conftest import te_def_um
from .test_update_cli import write_campaign


def _campaign(directory, model, loads, scale: float = 1.0, defect: float = 0.0):
    """Passes over 10 … 290 mm; ``scale`` multiplies the load-dependent TE (another axis)."""
    return write_campaign(
        directory,
        model,
        loads,
        defect,
        te_def=lambda x, F: scale * te_def_um(x, F) + te_def_um(x, 0.0, defect),
    )


@pytest.fixture(scope="module")
def parent(small_trained, tmp_path_factory):
    root = tmp_path_factory.mktemp("cause")
    m1 = save_model(small_trained, root / "m1")
    return root, m1, load_model(m1)


def _refused(argv, capsys, out_dir) -> str:
    code, out, err = run_in_process(argv, capsys)
    text = out + err
    assert code == 2 and "Traceback" not in text, text
    last = text.strip().splitlines()[-1]
    assert text.count("error") == 1 and last.startswith("drivelash: error:"), text
    assert "nothing written; give --accept-worse" in last and not out_dir.exists()
    return last


def test_held_out_loads_beyond_the_update_loads_are_named(parent, tmp_path, capsys):
    root, m1, model = parent
    camp = _campaign(tmp_path / "c", model, (0.0, 500.0, 1000.0, 3000.0), defect=3.0)
    out = tmp_path / "m2"
    last = _refused(
        ["te", "update", str(m1), str(camp), "-o", str(out), "--holdout-loads", "3000"], capsys, out
    )
    assert "the update makes the model worse (held-out passes neg: TE_def MAE" in last, last
    assert (
        ") — the held-out loads 3000 N (neg) lie outside the update passes' loads 0 … 1000 N: the update"
        " extrapolates its change to them — update on passes that span the loads: nothing written;" in last
    ), last


def test_passes_with_another_load_dependence_are_named(parent, tmp_path, capsys):
    root, m1, model = parent
    camp = _campaign(tmp_path / "c", model, (0.0, 1000.0, 1500.0, 2000.0, 3000.0), scale=3.0)
    out = tmp_path / "m2"
    last = _refused(
        ["te", "update", str(m1), str(camp), "-o", str(out), "--holdout-loads", "1500"], capsys, out
    )
    m = re.search(
        r" — the passes differ from the model by (\d\.\d{3}) um at 0 N and (\d\.\d{3}) um at 3000 N"
        r" \((neg|pos)\):"
        r" a load dependence other than the model's \(another axis or drive stiffness\), which a wear"
        r" update does not learn: nothing written;",
        last,
    )
    assert m and float(m.group(2)) > 2 * float(m.group(1)), last


def test_a_worse_update_without_an_identifiable_cause_keeps_the_figures_alone(
    parent, tmp_path, capsys, monkeypatch
):
    """Negative control: worn passes (a local 3 µm defect, flat over the load) spanning the
    held-out load, made 'worse' by hand — no cause is invented."""
    import drivelash.te.learn.update as upd

    root, m1, model = parent
    camp = _campaign(tmp_path / "c", model, (0.0, 1000.0, 1500.0, 2000.0, 3000.0), defect=3.0)
    real = upd.update_errors
    monkeypatch.setattr(
        upd,
        "update_errors",
        lambda a, b, runs: {k: {**v, "after_um": 1.5 * v["before_um"]} for k, v in real(a, b, runs).items()},
    )
    out = tmp_path / "m2"
    last = _refused(
        ["te", "update", str(m1), str(camp), "-o", str(out), "--holdout-loads", "1500"], capsys, out
    )
    assert re.search(r"um after\): nothing written; give --accept-worse", last) and " — " not in last, last
