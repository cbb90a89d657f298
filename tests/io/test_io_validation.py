"""Validation on load: every bad-input case is one line naming file, column and first bad row;
through the CLI it is exit code 2 and no output files are left behind."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from drivelash.errors import DataError
from drivelash.io import Trace, load_trace, write_trace

N = 400
DT = 1e-3


def _good(n: int = N) -> dict[str, np.ndarray]:
    t = np.arange(n) * DT
    th = 0.3 * np.sin(2 * np.pi * 2 * t) + 0.2 * t
    om = 0.3 * 2 * np.pi * 2 * np.cos(2 * np.pi * 2 * t) + 0.2
    tq = 1.5 * np.sin(2 * np.pi * 2 * t + 0.3) + 0.1 * np.cos(2 * np.pi * 7 * t)
    return {"t": t, "theta_m": th, "omega_m": om, "torque_m": tq}


def _csv(path: Path, cols: dict[str, np.ndarray]) -> Path:
    write_trace(Trace(cols), path)
    return path


#: lines above the data of a CSV drivelash writes: its ``# drivelash.meta`` line and the header
#: (data row r is line r + 3 of the file, as an editor numbers it)
ABOVE_DATA = 2


CONFIG = """
[drivetrain]
J_m = 0.01
beta_m = 0.001

[identification]
decimate = 2
n_border = 10
"""


def _bad_cases(tmp: Path) -> dict[str, tuple[Path, str, str | None, int | None]]:
    """name → (file, message fragment, column named, row named)."""
    cases: dict[str, tuple[Path, str, str | None, int | None]] = {}
    c = _good()
    del c["torque_m"]
    cases["missing_column"] = (_csv(tmp / "missing.csv", c), "missing required column", "torque_m", None)
    c = _good()
    c["torque_m"][123] = np.nan
    cases["nan"] = (_csv(tmp / "nan.csv", c), "NaN", "torque_m", 123)
    c = _good()
    c["theta_m"][77] = np.inf
    cases["inf"] = (_csv(tmp / "inf.csv", c), "infinite", "theta_m", 77)
    c = _good()
    c["t"][200] = c["t"][199]
    cases["duplicated_time"] = (_csv(tmp / "dup.csv", c), "duplicated time", "t", 200)
    c = _good()
    c["t"][200] = c["t"][198]
    cases["backwards_time"] = (_csv(tmp / "back.csv", c), "non-increasing", "t", 200)
    c = _good()
    c["t"][250:] += 0.5 * DT  # one interval 1.5 ms: 50 % jitter
    cases["non_uniform"] = (_csv(tmp / "jitter.csv", c), "non-uniform sampling", "t", 250)
    c = _good()
    c["torque_m"] = np.full(N, 0.7)
    cases["constant"] = (_csv(tmp / "const.csv", c), "constant signal", "torque_m", 0)
    c = _good()
    c["torque_m"] = np.clip(c["torque_m"], -1.0, 1.0)  # clipped at ±1 N·m
    cases["saturated"] = (_csv(tmp / "sat.csv", c), "saturated", "torque_m", None)
    c = _good()
    c["omega_m"] = np.degrees(c["omega_m"])  # deg/s in a rad/s column
    cases["units_deg"] = (_csv(tmp / "deg.csv", c), "deg", "omega_m", None)
    c = _good()
    c["omega_m"] = c["omega_m"] * 60 / (2 * np.pi)  # rpm in a rad/s column
    cases["units_rpm"] = (_csv(tmp / "rpm.csv", c), "rpm", "omega_m", None)
    c = _good()
    c["t"] = c["t"] / 10  # a 10 kHz drive (same motion in a tenth of the time) …
    c["omega_m"] = c["omega_m"] * 10
    c["t"] = c["t"] * 1e3  # … with ms in its time column read as s: 0.1 s steps, a plausible
    # period, so only velocity against the derivative of position (1000×) shows it
    cases["units_time_ms"] = (_csv(tmp / "ms.csv", c), "time in ms read as s", "omega_m", None)
    c = _good()
    c["t"] = c["t"] * 1e3  # ms stamps of a 1 kHz drive read as s: 1 s steps, refused by the period
    cases["units_time_ms_1khz"] = (_csv(tmp / "ms1k.csv", c), "time stamps in ms?", "t", None)
    c = _good()
    c["theta_m"] = c["theta_m"] * 1e3  # a position 1000× its velocity's integral (mm against m/s)
    cases["units_x1000"] = (_csv(tmp / "mm.csv", c), "position in mm against a velocity", "omega_m", None)
    c = _good()
    c["t"] = c["t"] * 1e6  # µs
    cases["units_time_us"] = (_csv(tmp / "us.csv", c), "time stamps in us?", "t", None)  # T_s check
    good = _csv(tmp / "good.csv", _good())
    text = good.read_text()
    (tmp / "trunc.csv").write_text(text[: len(text) - 30])  # cut mid-line, fields lost
    cases["truncated_csv"] = (tmp / "trunc.csv", "truncated", None, None)
    pq = write_trace(Trace(_good()), tmp / "good.parquet")
    (tmp / "trunc.parquet").write_bytes(pq.read_bytes()[:-200])
    cases["truncated_parquet"] = (tmp / "trunc.parquet", "truncated", None, None)
    mat = write_trace(Trace(_good()), tmp / "good.mat")
    (tmp / "trunc.mat").write_bytes(mat.read_bytes()[: mat.stat().st_size // 2])
    cases["truncated_mat"] = (tmp / "trunc.mat", "truncated", None, None)
    h5 = write_trace(Trace(_good()), tmp / "good.h5")
    (tmp / "trunc.h5").write_bytes(h5.read_bytes()[: h5.stat().st_size // 2])
    cases["truncated_hdf5"] = (tmp / "trunc.h5", "truncated", None, None)
    (tmp / "text.parquet").write_text(text)
    cases["wrong_type_parquet"] = (tmp / "text.parquet", "wrong file type", None, None)
    (tmp / "binary.csv").write_bytes(pq.read_bytes())
    cases["wrong_type_csv"] = (tmp / "binary.csv", "wrong file type", None, None)
    (tmp / "x.xlsx").write_bytes(b"PK\x03\x04")
    cases["wrong_extension"] = (tmp / "x.xlsx", "unsupported file type", None, None)
    (tmp / "empty.csv").write_bytes(b"")
    cases["empty"] = (tmp / "empty.csv", "empty", None, None)
    (tmp / "header_only.csv").write_text("t,theta_m,torque_m\n")
    cases["header_only"] = (tmp / "header_only.csv", "no data rows", None, None)
    (tmp / "text_in_numbers.csv").write_text("t,theta_m,torque_m\n0,0,1\n0.001,abc,2\n0.002,0.1,3\n")
    cases["not_a_number"] = (tmp / "text_in_numbers.csv", "not a number", "theta_m", 1)
    return cases


CASE_NAMES = [
    "missing_column", "nan", "inf", "duplicated_time", "backwards_time", "non_uniform", "constant",
    "saturated", "units_deg", "units_rpm", "units_time_ms", "units_time_ms_1khz", "units_x1000",
    "units_time_us", "truncated_csv",
    "truncated_parquet", "truncated_mat",
    "truncated_hdf5", "wrong_type_parquet", "wrong_type_csv", "wrong_extension", "empty", "header_only",
    "not_a_number",
]  # fmt: skip


@pytest.fixture(scope="module")
def cases(tmp_path_factory):
    return _bad_cases(tmp_path_factory.mktemp("bad"))


@pytest.mark.parametrize("name", CASE_NAMES)
def test_bad_input_is_one_line_data_error(cases, name):
    path, fragment, column, row = cases[name]
    with pytest.raises(DataError) as ei:
        load_trace(path, required=["theta_m", "torque_m"])
    msg = str(ei.value)
    assert "\n" not in msg
    assert str(path) in msg
    assert fragment.lower() in msg.lower(), msg
    if column is not None:
        assert f"column '{column}'" in msg, msg
    if row is not None:
        if name != "not_a_number":  # written by drivelash: the meta line and the header above the data
            assert Path(path).read_text().splitlines()[0].startswith("# drivelash.meta")
        above = 1 if name == "not_a_number" else ABOVE_DATA
        assert f"line {row + above + 1}" in msg, msg  # the file's line, not the data row index
    elif name in ("saturated", "units_deg", "units_rpm", "units_time_ms", "units_x1000"):
        assert "line " in msg


def _cli(args: list[str], monkeypatch, capsys) -> tuple[int, str]:
    from drivelash import cli

    monkeypatch.setattr(sys, "argv", ["drivelash", *args])
    with pytest.raises(SystemExit) as ei:
        cli.main()
    return int(ei.value.code or 0), capsys.readouterr().err


@pytest.mark.parametrize("command", ["identify", "observe"])
@pytest.mark.parametrize("name", CASE_NAMES)
def test_cli_exit_2_and_no_outputs(cases, name, command, tmp_path, monkeypatch, capsys):
    path, fragment, _, _ = cases[name]
    cfg = tmp_path / "c.toml"
    cfg.write_text(CONFIG)
    outs = [
        tmp_path / "o.json",
        tmp_path / "o.html",
        tmp_path / ("out.toml" if command == "identify" else "out.csv"),
    ]
    code, err = _cli(
        [command, str(path), "--config", str(cfg), "--json", str(outs[0]), "--report", str(outs[1]),
         "--out", str(outs[2])],
        monkeypatch,
        capsys,
    )  # fmt: skip
    assert code == 2
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("drivelash: error:"), err
    assert fragment.lower() in lines[0].lower()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.toml"]


def test_cli_subprocess_exit_code_2(cases, tmp_path):
    """End to end through the console script: exit code 2, one line on stderr, no traceback."""
    path = cases["nan"][0]
    cfg = tmp_path / "c.toml"
    cfg.write_text(CONFIG)
    exe = Path(sys.executable).parent / "drivelash"
    r = subprocess.run(
        [str(exe), "identify", str(path), "--config", str(cfg), "--json", str(tmp_path / "o.json")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert f"column 'torque_m', line {123 + ABOVE_DATA + 1}" in r.stderr
    assert not (tmp_path / "o.json").exists()


def test_resampling_only_when_asked(cases):
    path = cases["non_uniform"][0]
    tr = load_trace(path, resample=True)
    steps = np.diff(tr["t"])
    np.testing.assert_allclose(steps, DT, rtol=1e-9)
    assert any("resampled" in w and f"line {250 + ABOVE_DATA + 1}" in w for w in tr.meta["warnings"])
    # linear interpolation of a linear-in-t column is exact: theta_m has a 0.2·t ramp + sine;
    # compare with the analytic signal at the new grid, within the interpolation error of the sine
    ref = 0.3 * np.sin(2 * np.pi * 2 * tr["t"]) + 0.2 * tr["t"]
    # the source was shifted by 0.5 ms after row 250 → its values there belong to t − 0.5 ms
    assert np.max(np.abs(tr["theta_m"][:240] - ref[:240])) < 1e-12


def test_encoder_wraparound_is_unwrapped_and_reported(tmp_path, capsys):
    """A 12-bit single-turn encoder (4096 counts/rev) moving over 3 revolutions."""
    t = np.arange(3000) * DT
    turns = 1.5 * (1 - np.cos(np.pi * t / t[-1]))  # 0 → 3 revolutions, smooth
    counts_true = turns * 4096
    counts_wrapped = np.mod(np.round(counts_true), 4096)
    tq = np.sin(2 * np.pi * 3 * t)
    path = write_trace(Trace({"t": t, "enc": counts_wrapped, "iq": tq}), tmp_path / "enc.parquet")
    mapping = {
        "enc": {"column": "theta_m", "unit": "counts", "counts_per_rev": 4096},
        "iq": {"column": "torque_m", "unit": "A", "torque_constant": 0.8},
    }
    tr = load_trace(path, mapping)
    np.testing.assert_allclose(tr["theta_m"], 2 * np.pi * np.round(counts_true) / 4096, atol=1e-12)
    np.testing.assert_allclose(tr["torque_m"], 0.8 * tq, rtol=1e-15)
    first = int(np.flatnonzero(np.diff(counts_wrapped) < -2048)[0] + 1)
    assert any(
        f"column 'enc', data row {first + 1} (1-based): encoder wrap-around" in w for w in tr.meta["warnings"]
    )


def test_unit_mapping_against_hand_conversion(tmp_path):
    """Every unit of the [columns] table, compared with the SI values computed by hand."""
    n = 500
    t_ms = np.arange(n) * 0.5  # 0.5 ms steps
    th_rad = 0.4 * np.sin(np.linspace(0, 6, n))
    om_rad = np.gradient(th_rad, t_ms * 1e-3)
    x_m = 0.01 * np.cos(np.linspace(0, 5, n))
    cols = {
        "time_ms": t_ms,
        "pos_deg": np.degrees(th_rad),
        "vel_rpm": om_rad * 60 / (2 * np.pi),
        "load_rev": th_rad / (2 * np.pi),
        "load_degs": np.degrees(om_rad),
        "carriage_mm": x_m * 1e3,
        "probe_um": x_m * 1e6,
        "cmd_V": np.sin(np.linspace(0, 9, n)),
    }
    path = write_trace(Trace({"t": t_ms, **cols}), tmp_path / "u.h5")
    mapping = {
        "time_ms": {"column": "t", "unit": "ms"},
        "pos_deg": {"column": "theta_m", "unit": "deg"},
        "vel_rpm": {"column": "omega_m", "unit": "rpm"},
        "load_rev": {"column": "theta_l", "unit": "rev"},
        "load_degs": {"column": "omega_l", "unit": "deg/s"},
        "carriage_mm": {"column": "x_T", "unit": "mm"},
        "probe_um": {"column": "x_probe", "unit": "µm"},
        "cmd_V": {"column": "torque_m", "unit": "V", "gain": 2.5},
    }
    tr = load_trace(path, mapping)
    np.testing.assert_allclose(tr["t"], t_ms * 1e-3, rtol=1e-15)
    np.testing.assert_allclose(tr["theta_m"], th_rad, rtol=1e-14, atol=1e-16)
    np.testing.assert_allclose(tr["omega_m"], om_rad, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(tr["theta_l"], th_rad, rtol=1e-14, atol=1e-16)
    np.testing.assert_allclose(tr["omega_l"], om_rad, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(tr["x_T"], x_m, rtol=1e-14)
    np.testing.assert_allclose(tr["x_probe"], x_m, rtol=1e-14)
    np.testing.assert_allclose(tr["torque_m"], 2.5 * cols["cmd_V"], rtol=1e-15)


def test_constant_sample_rate_without_time_column(tmp_path):
    from drivelash.io.config import loads_config

    (tmp_path / "r.csv").write_text(
        "pos,torque\n" + "".join(f"{np.sin(i / 9):.6f},{np.cos(i / 7):.6f}\n" for i in range(50))
    )
    cfg = loads_config(
        '[columns.pos]\ncolumn = "theta_m"\nunit = "rad"\n'
        '[columns.torque]\ncolumn = "torque_m"\nunit = "N·m"\n'
        "[sampling]\nsample_rate = 4000.0\n"
    )
    tr = load_trace(tmp_path / "r.csv", cfg)
    np.testing.assert_allclose(tr["t"], np.arange(50) / 4000.0)
    assert tr.T_s == pytest.approx(2.5e-4)


def test_unit_requirements_are_reported(tmp_path):
    path = write_trace(Trace(_good()), tmp_path / "g.parquet")
    with pytest.raises(DataError, match="counts_per_rev"):
        load_trace(path, {"theta_m": {"column": "theta_m", "unit": "counts"}})
    with pytest.raises(DataError, match="torque_constant"):
        load_trace(path, {"torque_m": {"column": "torque_m", "unit": "A"}})
    with pytest.raises(DataError, match="does not fit"):
        load_trace(path, {"theta_m": {"column": "theta_m", "unit": "rpm"}})
    with pytest.raises(DataError, match="scalar 'gtau'"):
        load_trace(path, {"torque_m": {"column": "torque_m", "unit": "V", "gain": "gtau"}})


def test_cli_prints_the_wraparound_warning(tmp_path, monkeypatch, capsys):
    """`identify` on a wrapped 12-bit encoder: exit 0, the unwrapping is said on stderr."""
    t = np.arange(6000) * DT
    turns = 1.5 * (1 - np.cos(2 * np.pi * t / 3.0))  # back and forth over 3 revolutions
    counts = np.mod(np.round(turns * 4096), 4096)
    omega = np.gradient(2 * np.pi * turns, DT)
    tq = 0.01 * np.gradient(omega, DT) + 0.05 * omega + 0.2 * np.sign(omega)
    path = write_trace(Trace({"t": t, "enc": counts, "tq": tq}), tmp_path / "enc.csv")
    cfg = tmp_path / "c.toml"
    cfg.write_text(
        '[columns.enc]\ncolumn = "theta_m"\nunit = "counts"\ncounts_per_rev = 4096\n'
        '[columns.tq]\ncolumn = "torque_m"\nunit = "N·m"\n'
    )
    out = tmp_path / "dt.toml"
    from drivelash import cli

    monkeypatch.setattr(
        sys, "argv", ["drivelash", "identify", str(path), "--config", str(cfg), "--out", str(out)]
    )
    try:
        cli.main()
        code = 0
    except SystemExit as exc:
        code = int(exc.code or 0)
    err = capsys.readouterr().err
    assert code == 0
    assert "drivelash: warning:" in err and "column 'enc'" in err and "encoder wrap-around" in err
    assert out.exists()


def test_valid_csv_without_final_newline_loads(tmp_path):
    """Control for the truncation rule: a complete last row without a newline is fine."""
    p = tmp_path / "ok.csv"
    p.write_text("t,theta_m,torque_m\n0,0,0.5\n0.001,0.01,0.7\n0.002,0.03,0.2")
    tr = load_trace(p)
    np.testing.assert_array_equal(tr["torque_m"], [0.5, 0.7, 0.2])
