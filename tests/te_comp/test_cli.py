"""``drivelash te export`` / ``te validate`` command wiring (the model loader is stubbed)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from drivelash.cli import app
from drivelash.te.runtime.export import load_table

from .analytic import SineTE


class _Model(SineTE):
    info: dict = {}


@pytest.fixture
def stub_model(monkeypatch):
    import drivelash.te.runtime.persist as persist

    monkeypatch.setattr(persist, "load_model", lambda d: _Model())


@pytest.mark.parametrize("suffix", [".csv", ".json"])
def test_export_writes_documented_table(tmp_path, stub_model, suffix):
    out = tmp_path / f"table{suffix}"
    r = CliRunner().invoke(app, ["te", "export", str(tmp_path), "-o", str(out), "--dx-mm", "1.0",
                                 "--x-max", "0.5", "--torque-step", "3", "--torque-max", "9"])  # fmt: skip
    assert r.exit_code == 0, r.output
    tab = load_table(out)
    assert tab.te.shape == (2, 501, 4)
    np.testing.assert_allclose(tab.torque_grid(1), [0, 3, 6, 9])
    np.testing.assert_allclose(tab.torque_grid(-1), [-9, -6, -3, 0])
    x = np.linspace(0, 0.5, 37)
    # bilinear error ≤ h²/8·A(2π/λ)² = 0.14 µm at h = 1 mm
    np.testing.assert_allclose(tab.predict(x, -6.0, -1), _Model().predict(x, -6.0, -1), atol=0.15e-6)
    head = out.read_text()[:4000]
    assert '"x_T": "mm"' in head and '"TE": "um"' in head
    if suffix == ".json":
        doc = json.loads(out.read_text())
        assert doc["grid"]["x_T"] == {"start_mm": 0.0, "step_mm": 1.0, "count": 501}


def test_export_rejects_unknown_suffix(tmp_path, stub_model):
    r = CliRunner().invoke(
        app, ["te", "export", str(tmp_path), "-o", str(tmp_path / "t.xlsx"), "--torque-max", "9"]
    )
    assert r.exit_code != 0
    assert "use .csv or .json" in str(r.exception) or "use .csv or .json" in r.output


def test_export_needs_torque_range_without_campaign(tmp_path, stub_model):
    r = CliRunner().invoke(app, ["te", "export", str(tmp_path), "-o", str(tmp_path / "t.csv")])
    assert r.exit_code != 0
    assert "--torque-max" in str(r.exception) or "--torque-max" in r.output


def test_validate_needs_a_campaign(tmp_path, stub_model):
    r = CliRunner().invoke(app, ["te", "validate", str(tmp_path), "-o", str(tmp_path / "v")])
    assert r.exit_code != 0
    assert "--campaign" in str(r.exception) or "--campaign" in r.output
