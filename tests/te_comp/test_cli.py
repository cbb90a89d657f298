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
    """The analytic TE with the context a loaded model carries (valid range 0 … 0.5 m, 0 … 9 N·m)."""

    info: dict = {}

    @property
    def context(self):
        from drivelash.io.campaign import AxisBlock
        from drivelash.physics.rack_pinion import RackPinionBench
        from drivelash.te.runtime.compensator import CompensatorParams
        from drivelash.te.runtime.persist import CampaignInfo, ModelContext, ValidRange

        return ModelContext(
            axis=AxisBlock.of(RackPinionBench()),
            valid_range=ValidRange(x_min=0.0, x_max=0.5, torque_max=9.0),
            compensator=CompensatorParams(J_flank=4e-3, T_C=0.5),
            campaign=CampaignInfo(source="imported"),
        )


def _mdir(tmp_path) -> str:
    """A model directory (the stubbed loader ignores its content); outputs go next to it."""
    d = tmp_path / "model"
    d.mkdir(exist_ok=True)
    return str(d)


@pytest.fixture
def stub_model(monkeypatch):
    import drivelash.te.runtime.persist as persist

    monkeypatch.setattr(persist, "load_model", lambda d: _Model())


@pytest.mark.parametrize("suffix", [".csv", ".json"])
def test_export_writes_documented_table(tmp_path, stub_model, suffix):
    out = tmp_path / f"table{suffix}"
    r = CliRunner().invoke(app, ["te", "export", _mdir(tmp_path), "-o", str(out), "--dx-mm", "1.0",
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
        app, ["te", "export", _mdir(tmp_path), "-o", str(tmp_path / "t.xlsx"), "--torque-max", "9"]
    )
    assert r.exit_code != 0
    assert "(use .csv, .json)" in str(r.exception)


def test_export_defaults_come_from_the_model(tmp_path, stub_model):
    """Valid range, torque range and the compensator's inertia/friction come from the model."""
    out = tmp_path / "t.json"
    r = CliRunner().invoke(app, ["te", "export", _mdir(tmp_path), "-o", str(out)])
    assert r.exit_code == 0, r.output
    doc = json.loads(out.read_text())
    assert doc["grid"]["x_T"]["start_mm"] == 0.0 and doc["grid"]["x_T"]["count"] == 2501
    assert doc["grid"]["torque"]["1"]["count"] == 19  # 0 … 9 N·m in 0.5 N·m steps
    assert doc["compensator"]["J_flank"] == 4e-3 and doc["compensator"]["T_C"] == 0.5


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--x-max", "0.7"], "valid range"),
        (["--x-min", "-0.1"], "valid range"),
        (["--dx-mm", "1e-6"], "--dx-mm"),
        (["--torque-max", "1e9"], "--torque-max"),
        (["--dx-mm", "nan"], "dx-mm"),
        (["--torque-step", "0"], "torque-step"),
    ],
)
def test_export_refuses_bad_grids_up_front(tmp_path, stub_model, args, needle):
    out = tmp_path / "t.csv"
    r = CliRunner().invoke(app, ["te", "export", _mdir(tmp_path), "-o", str(out), *args])
    assert r.exit_code != 0
    assert needle in str(r.exception)
    assert not out.exists()


def test_validate_refuses_a_model_of_an_imported_campaign(tmp_path, stub_model):
    r = CliRunner().invoke(app, ["te", "validate", _mdir(tmp_path), "-o", str(tmp_path / "v")])
    assert r.exit_code != 0
    assert "te score" in str(r.exception)
    assert not (tmp_path / "v").exists()
