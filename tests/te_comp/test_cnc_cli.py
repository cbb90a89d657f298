"""``drivelash te export`` writes the CNC layouts (issue 12) and stays inside the measured range.

The model loader is stubbed with the closed-form no-load curves of ``test_cnc_export`` (the
golden files' model), carrying the context a loaded model has.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from drivelash.cli import app

from .analytic import SineTE
from .test_cnc_export import GOLDEN, LinearGeoModel


def _context(x_min: float, x_max: float, torque_max: float = 9.0):
    from drivelash.io.campaign import AxisBlock
    from drivelash.physics.rack_pinion import RackPinionBench
    from drivelash.te.runtime.compensator import CompensatorParams
    from drivelash.te.runtime.persist import CampaignInfo, ModelContext, ValidRange

    return ModelContext(
        axis=AxisBlock.of(RackPinionBench()),
        valid_range=ValidRange(x_min=x_min, x_max=x_max, torque_max=torque_max),
        compensator=CompensatorParams(J_flank=4e-3, T_C=0.5),
        campaign=CampaignInfo(source="imported"),
    )


class _GeoModel(LinearGeoModel):
    """The golden model; its stored valid range is 0.5 mm wider on each side than its no-load curves."""

    info: dict = {}

    @property
    def context(self):
        return _context(0.0995, 0.1045)

    def predict(self, x_T, torque, direction):
        return self.geometric(x_T, direction) + 1e-7 * np.abs(np.asarray(torque, dtype=float))


class _WideModel(SineTE):
    """Analytic TE; stored valid range 0 ... 0.5 m, no-load curves measured on 0.005 ... 0.495 m."""

    info: dict = {}

    @property
    def context(self):
        return _context(0.0, 0.5)

    def geometric_range(self):
        return 0.005, 0.495


@pytest.fixture
def geo_model(monkeypatch):
    import drivelash.te.runtime.persist as persist

    monkeypatch.setattr(persist, "load_model", lambda d: _GeoModel())


@pytest.fixture
def wide_model(monkeypatch):
    import drivelash.te.runtime.persist as persist

    monkeypatch.setattr(persist, "load_model", lambda d: _WideModel())


def _mdir(tmp_path) -> str:
    d = tmp_path / "model"
    d.mkdir(exist_ok=True)
    return str(d)


def _export(tmp_path, *args):
    return CliRunner().invoke(app, ["te", "export", _mdir(tmp_path), *args])


def _without_source(raw: bytes) -> bytes:
    """The file with LF line ends and without the provenance line (the model directory)."""
    lines = raw.replace(b"\r\n", b"\n").split(b"\n")
    return b"\n".join(ln for ln in lines if not ln.startswith((b"; model: ", b"model: ")))


@pytest.mark.parametrize(
    ("name", "args", "golden"),
    [
        ("axis.ini", [], "X1_sinumerik.ini"),
        ("axis.txt", ["--format", "sinumerik"], None),  # unknown extension + explicit format: refused
        ("X.COM", ["--axis", "X"], "X.COM"),
        ("x.com", ["--format", "heidenhain", "--axis", "X"], "X.COM"),
    ],
)
def test_export_writes_the_cnc_layouts_like_the_golden_files(tmp_path, geo_model, name, args, golden):
    out = tmp_path / name
    r = _export(tmp_path, "-o", str(out), "--step-mm", "1", *args)
    if golden is None:
        assert r.exit_code != 0 and "unsupported extension '.txt'" in str(r.exception)
        assert not out.exists()
        return
    assert r.exit_code == 0, r.output
    raw = out.read_bytes()
    assert raw.count(b"\r\n") == raw.count(b"\n")  # CR LF throughout
    text = raw.decode("ascii")
    assert f"model: {_mdir(tmp_path)}" in text  # provenance
    assert _without_source(raw) == (GOLDEN / golden).read_bytes()  # BEGIN names the file: X.COM
    # the default range is where the no-load curves were measured (100 ... 104 mm), not the
    # stored valid range 99.5 ... 104.5 mm
    assert "5 points 100.000 ... 104.000 mm" in r.output


@pytest.mark.parametrize(("name", "golden"), [("axis.ini", "X1_sinumerik.ini"), ("X.COM", "X.COM")])
def test_export_cnc_defaults_are_the_documented_ones(tmp_path, geo_model, name, golden):
    """README / docs/te-formats.md §4: ``--step-mm`` 1, ``--axis`` X1 (SINUMERIK) or X
    (HEIDENHAIN), ``--cec-tables`` 0,1 when left out — the golden files, written with them."""
    out = tmp_path / name
    r = _export(tmp_path, "-o", str(out))
    assert r.exit_code == 0, r.output
    assert _without_source(out.read_bytes()) == (GOLDEN / golden).read_bytes()
    # negative control: another step is another file
    (tmp_path / "half").mkdir()
    other = tmp_path / "half" / name
    assert _export(tmp_path, "-o", str(other), "--step-mm", "0.5").exit_code == 0
    assert _without_source(other.read_bytes()) != (GOLDEN / golden).read_bytes()


def test_export_cnc_options(tmp_path, geo_model):
    out = tmp_path / "s.ini"
    r = _export(tmp_path, "-o", str(out), "--step-mm", "0.5", "--axis", "Y2", "--cec-tables", "4,7")
    assert r.exit_code == 0, r.output
    lines = out.read_text().splitlines()
    assert "$AA_ENC_COMP_STEP[0,Y2]=0.500000" in lines
    assert sum(ln.startswith("$AA_ENC_COMP[0,") for ln in lines) == 9
    assert "$AN_CEC_DIRECTION[4]=1" in lines and "$AN_CEC_DIRECTION[7]=-1" in lines
    # LEC − CEC of a direction = its no-load TE (2.5 µm + ... at 101.5 mm: TE+ = 2.5 µm, TE− = 25.5 µm)
    enc = float(next(ln for ln in lines if ln.startswith("$AA_ENC_COMP[0,3,")).split("=")[1])
    c4 = float(next(ln for ln in lines if ln.startswith("$AN_CEC[4,3]")).split("=")[1])
    c7 = float(next(ln for ln in lines if ln.startswith("$AN_CEC[7,3]")).split("=")[1])
    assert enc - c4 == pytest.approx(0.0025, abs=1e-6) and enc - c7 == pytest.approx(0.0255, abs=1e-6)


@pytest.mark.parametrize(
    ("name", "args", "needle"),
    [
        ("a.ini", ["--dx-mm", "1"], "--dx-mm: does not apply to --format sinumerik"),
        ("a.com", ["--torque-max", "5"], "--torque-max: does not apply"),
        ("a.csv", ["--step-mm", "1"], "--step-mm: does not apply to --format table"),
        ("a.com", ["--cec-tables", "0,1"], "--cec-tables: applies to --format sinumerik only"),
        ("a.ini", ["--cec-tables", "3,3"], "--cec-tables: must be two different"),
        ("a.ini", ["--cec-tables", "3"], "--cec-tables: must be two table indices"),
        ("a.ini", ["--axis", "X1;M30"], "--axis"),
        ("a.ini", ["--step-mm", "0"], "--step-mm"),
        ("a.ini", ["--x-max", "0.105"], "--x-max"),
        ("a.ini", ["--x-min", "0.0996"], "--x-min"),  # inside the stored range, outside the measured one
        ("a.com", ["--format", "sinumerik"], "extension '.com' is the heidenhain format"),
        # --format does not stand in for the extension (README, docs/te-formats.md §4)
        ("axis", ["--format", "sinumerik"], "unsupported extension (none) (use .ini)"),
        ("X", ["--format", "heidenhain"], "unsupported extension (none) (use .com)"),
        ("t.txt", ["--format", "table"], "unsupported extension '.txt' (use .csv, .json)"),
        ("a.ini", ["--format", "fanuc"], "--format: must be table, sinumerik or heidenhain"),
    ],
)
def test_export_cnc_refusals(tmp_path, geo_model, name, args, needle):
    out = tmp_path / name
    r = _export(tmp_path, "-o", str(out), *args)
    assert r.exit_code != 0
    assert needle in str(r.exception)
    assert not out.exists()


def test_export_cnc_position_typed_in_mm_is_refused_in_mm_and_m(tmp_path, geo_model):
    """The CNC layouts state ranges in mm first; the note says --x-min/--x-max take m."""
    out = tmp_path / "a.ini"
    r = _export(tmp_path, "-o", str(out), "--x-min", "100", "--x-max", "104")
    assert r.exit_code != 0
    msg = str(r.exception)
    assert "\n" not in msg
    assert "leaves the model's valid range [100.000, 104.000] mm = [0.1, 0.104] m" in msg
    assert msg.endswith("; --x-min and --x-max are in m (metres; --dx-mm and --step-mm are in mm)")
    assert not out.exists()


def test_export_refuses_torques_above_the_training_range(tmp_path, wide_model):
    out = tmp_path / "t.json"
    r = _export(tmp_path, "-o", str(out), "--torque-max", "9.5", "--dx-mm", "1")
    assert r.exit_code != 0
    assert "--torque-max: 9.5 N·m is above the model's valid torque range 0 ... 9 N·m" in str(r.exception)
    assert not out.exists()
    # negative control: the training range itself and a smaller one are accepted
    for tmax, count in (("9", 19), ("4", 9)):
        r = _export(tmp_path, "-o", str(out), "--torque-max", tmax, "--dx-mm", "1", "--force")
        assert r.exit_code == 0, r.output
        assert json.loads(out.read_text())["grid"]["torque"]["1"]["count"] == count


def test_export_table_defaults_to_the_measured_range(tmp_path, wide_model):
    out = tmp_path / "t.json"
    r = _export(tmp_path, "-o", str(out), "--dx-mm", "1")
    assert r.exit_code == 0, r.output
    grid = json.loads(out.read_text())["grid"]["x_T"]
    assert grid == {"start_mm": 5.0, "step_mm": 1.0, "count": 491}  # 5 ... 495 mm, not 0 ... 500 mm
    r = _export(tmp_path, "-o", str(tmp_path / "u.json"), "--x-min", "0.002")
    assert r.exit_code != 0 and "valid range [0.005, 0.495] m" in str(r.exception)
