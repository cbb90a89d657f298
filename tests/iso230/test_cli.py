"""``drivelash iso230``: end to end on both inputs; bad input is one line, exit 2, no output."""

from __future__ import annotations

import html
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from drivelash.io import Trace
from drivelash.iso230.synthetic import SyntheticAxis, synthetic_recording, synthetic_table

AXIS = SyntheticAxis(delta=12e-6, sigma=0.5e-6)
LEAD = 0.01  # m per screw revolution

TABLE_TOML = """
[columns."Target [mm]"]
column = "P_target"
unit = "mm"
[columns.Run]
column = "run"
[columns.Dir]
column = "direction"
[columns."Error [um]"]
column = "x_dev"
unit = "um"
"""


def _table_csv(path: Path, tb: dict[str, np.ndarray]) -> Path:
    df = pd.DataFrame(
        {
            "Target [mm]": tb["P_target"] * 1e3,
            "Run": tb["run"].astype(int),
            "Dir": tb["direction"].astype(int),
            "Error [um]": tb["x_dev"] * 1e6,
        }
    )
    df.to_csv(path, index=False)
    return path


@pytest.fixture
def table(tmp_path) -> tuple[Path, Path]:
    csv = _table_csv(tmp_path / "laser.csv", synthetic_table(AXIS, m=11, n=5, seed=4))
    toml = tmp_path / "axis.toml"
    toml.write_text(TABLE_TOML + f"\n[transmission]\nlead = {LEAD}\n", encoding="utf-8")
    return csv, toml


def _estimate(path: Path, delta_load: float, u_load: float | None) -> Path:
    k = LEAD / (2 * math.pi)
    data = {"delta": delta_load / k, "excitation_ok": True, "reason": "ok"}
    if u_load is not None:
        data["delta_std"] = u_load / k
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


def test_table_end_to_end_with_deadzone(table, tmp_path, run_cli):
    csv, toml = table
    est = _estimate(tmp_path / "est.json", 12e-6, 0.3e-6)
    j, r = tmp_path / "iso.json", tmp_path / "iso.html"
    code, out, err = run_cli(
        [
            "iso230",
            str(csv),
            "--config",
            str(toml),
            "--estimate",
            str(est),
            "--json",
            str(j),
            "--report",
            str(r),
        ]
    )
    assert code == 0, err
    s = json.loads(j.read_text())
    assert s["generator"].startswith("drivelash ")
    assert s["input"] == "table" and s["targets"] == 11 and s["runs_per_direction"] == 5
    B_mean = s["reversal"]["B_mean"]
    assert -B_mean == pytest.approx(12e-6, abs=3 * s["reversal"]["u_B_mean"])
    cmp_ = s["deadzone_comparison"]
    assert cmp_["deadzone_at_load"] == pytest.approx(12e-6, rel=1e-12)
    assert cmp_["agree"] is True and cmp_["E_n"] <= 1
    html = r.read_text()
    assert "ISO 230-2" in html and "agree" in html and 'src="data:image/png;base64,' in html
    assert "B = " in out and "E_n" in out


def test_deadzone_that_does_not_match_disagrees(table, tmp_path, run_cli):
    """Negative control: a deadzone 30 % larger than the lost motion is flagged."""
    csv, toml = table
    est = _estimate(tmp_path / "est.json", 15.6e-6, 0.3e-6)
    j = tmp_path / "iso.json"
    code, _, err = run_cli(["iso230", str(csv), "-c", str(toml), "--estimate", str(est), "--json", str(j)])
    assert code == 0, err
    c = json.loads(j.read_text())["deadzone_comparison"]
    assert c["agree"] is False and c["E_n"] > 1


def test_time_series_end_to_end(tmp_path, run_cli):
    cols, truth = synthetic_recording(AXIS, m=7, n=3, seed=5, dwell=0.8)
    p = tmp_path / "rec.parquet"
    Trace({"t": cols["t"], "cmd": cols["P_cmd"] * 1e3, "laser": cols["P_actual"] * 1e3}).to_parquet(p)
    toml = tmp_path / "rec.toml"
    toml.write_text(
        '[columns.cmd]\ncolumn = "P_cmd"\nunit = "mm"\n[columns.laser]\ncolumn = "P_actual"\nunit = "mm"\n'
        "[iso230]\ntargets = [" + ", ".join(repr(float(x)) for x in truth["targets"]) + "]\n",
        encoding="utf-8",
    )
    j = tmp_path / "rec.json"
    code, _, err = run_cli(["iso230", str(p), "--config", str(toml), "--json", str(j)])
    assert code == 0, err
    s = json.loads(j.read_text())
    assert s["input"] == "timeseries" and s["dwells"]["count"] == 7 * 3 * 2
    assert "rest position" in err  # the rest after the test is reported


def _bad(run_cli, argv: list[str], pattern: str, outputs: list[Path]) -> None:
    code, out, err = run_cli(argv)
    assert code == 2, (out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("drivelash: error: "), err
    assert pattern in lines[0], lines[0]
    assert "Traceback" not in err
    for o in outputs:
        assert not o.exists()
    assert not [q for q in outputs[0].parent.iterdir() if q.name.endswith(".part")]


def test_fewer_than_two_runs(tmp_path, run_cli):
    tb = synthetic_table(AXIS, m=5, n=1, seed=1)
    csv = _table_csv(tmp_path / "one.csv", tb)
    toml = tmp_path / "t.toml"
    toml.write_text(TABLE_TOML, encoding="utf-8")
    j = tmp_path / "o.json"
    _bad(
        run_cli,
        ["iso230", str(csv), "-c", str(toml), "--json", str(j)],
        "needs at least 2 runs per direction",
        [j],
    )


def test_unequal_targets(tmp_path, run_cli):
    tb = synthetic_table(AXIS, m=5, n=3, seed=1)
    keep = ~((tb["P_target"] == tb["P_target"].max()) & (tb["direction"] < 0))
    csv = _table_csv(tmp_path / "u.csv", {k: v[keep] for k, v in tb.items()})
    toml = tmp_path / "t.toml"
    toml.write_text(TABLE_TOML, encoding="utf-8")
    j = tmp_path / "o.json"
    _bad(
        run_cli,
        ["iso230", str(csv), "-c", str(toml), "--json", str(j)],
        "unequal targets: target 500 mm",
        [j],
    )


def test_units_mismatch_length_and_angle(tmp_path, run_cli):
    tb = synthetic_table(AXIS, m=5, n=3, seed=1)
    csv = _table_csv(tmp_path / "u.csv", tb)
    toml = tmp_path / "t.toml"
    toml.write_text(TABLE_TOML.replace('unit = "um"', 'unit = "arcsec"'), encoding="utf-8")
    j = tmp_path / "o.json"
    _bad(run_cli, ["iso230", str(csv), "-c", str(toml), "--json", str(j)], "units mismatch", [j])


def test_units_mismatch_factor_1000(tmp_path, run_cli):
    """The laser column written in mm but declared µm moves 0.001× the command."""
    cols, _ = synthetic_recording(AXIS, m=5, n=2, seed=5, dwell=0.6)
    p = tmp_path / "rec.csv"
    Trace({"t": cols["t"], "cmd": cols["P_cmd"] * 1e3, "laser": cols["P_actual"] * 1e3}).to_csv(p)
    toml = tmp_path / "rec.toml"
    toml.write_text(
        '[columns.cmd]\ncolumn = "P_cmd"\nunit = "mm"\n[columns.laser]\ncolumn = "P_actual"\nunit = "um"\n',
        encoding="utf-8",
    )
    r = tmp_path / "o.html"
    _bad(
        run_cli,
        ["iso230", str(p), "-c", str(toml), "--report", str(r)],
        "units mismatch: 'laser' moves 0.00099",
        [r],
    )


def test_deviation_in_the_wrong_unit(tmp_path, run_cli):
    """Deviations in µm declared as mm spread over a large part of the travel: refused."""
    tb = synthetic_table(AXIS, m=5, n=3, seed=1)
    csv = _table_csv(tmp_path / "u.csv", tb)
    toml = tmp_path / "t.toml"
    toml.write_text(TABLE_TOML.replace('unit = "um"', 'unit = "mm"'), encoding="utf-8")
    j = tmp_path / "o.json"
    _bad(
        run_cli,
        ["iso230", str(csv), "-c", str(toml), "--json", str(j)],
        "units mismatch: the deviations spread",
        [j],
    )


def test_estimate_without_transmission(table, tmp_path, run_cli):
    csv, _ = table
    toml = tmp_path / "t.toml"
    toml.write_text(TABLE_TOML, encoding="utf-8")
    est = _estimate(tmp_path / "est.json", 12e-6, None)
    j = tmp_path / "o.json"
    _bad(
        run_cli,
        ["iso230", str(csv), "-c", str(toml), "--estimate", str(est), "--json", str(j)],
        "[transmission]",
        [j],
    )


def test_config_errors_name_table_and_key(table, tmp_path, run_cli):
    csv, _ = table
    toml = tmp_path / "t.toml"
    toml.write_text(TABLE_TOML + "[dwell]\nT_setle = 0.3\n", encoding="utf-8")
    j = tmp_path / "o.json"
    _bad(
        run_cli,
        ["iso230", str(csv), "-c", str(toml), "--json", str(j)],
        "table [dwell], key 'T_setle': unknown key; did you mean 'T_settle'?",
        [j],
    )
    toml.write_text(TABLE_TOML + "[transmission]\nlead = -1\n", encoding="utf-8")
    _bad(
        run_cli,
        ["iso230", str(csv), "-c", str(toml), "--json", str(j)],
        "table [transmission], key 'lead': must be a finite number > 0",
        [j],
    )


def test_output_may_not_overwrite_the_input(table, run_cli):
    csv, toml = table
    before = csv.read_bytes()
    code, _, err = run_cli(["iso230", str(csv), "-c", str(toml), "--json", str(csv)])
    assert code == 2 and "--json" in err
    assert csv.read_bytes() == before


def test_unconverged_estimate_is_compared_only_with_its_uncertainty_and_said_so(table, tmp_path, run_cli):
    """Found by an exploratory tester (session 13): an estimate the estimator called not converged
    ("… the estimate is not a measurement") was compared without a word. With a stated
    uncertainty the comparison runs and says the estimate did not converge, quoting the
    estimator; without one it is refused (exit 2). Negative control: a converged one, no note."""
    csv, toml = table
    est = _estimate(tmp_path / "est.json", 12e-6, 0.3e-6)
    data = json.loads(est.read_text())
    said = "δ̂ = 145.5 mrad exceeds the whole Δθ range observed (120.8 mrad): the gap was never crossed"
    est.write_text(
        json.dumps({**data, "converged": False, "warnings": ["note: a note", said]}), encoding="utf-8"
    )
    j, r = tmp_path / "iso.json", tmp_path / "iso.html"
    code, _, err = run_cli(
        ["iso230", str(csv), "-c", str(toml), "--estimate", str(est), "--json", str(j), "--report", str(r)]
    )
    assert code == 0, err
    w = json.loads(j.read_text())["warnings"]
    assert any("did not converge" in x and said in x for x in w), w
    # s19 F19: the report said nothing of it — now the warning, and a flag next to the number
    page = r.read_text(encoding="utf-8")
    note = next(x for x in w if "did not converge" in x)
    assert page.count(html.escape(note)) == 2  # in the comparison section and under Warnings
    assert "(not converged: see above)" in page
    bare = {k: v for k, v in data.items() if k != "delta_std"}
    est.write_text(json.dumps({**bare, "converged": False, "warnings": [said]}), encoding="utf-8")
    code, _, err = run_cli(
        ["iso230", str(csv), "-c", str(toml), "--estimate", str(est), "--json", str(j), "--force"]
    )
    assert code == 2 and "did not converge and states no uncertainty" in err and "Traceback" not in err
    est.write_text(json.dumps({**data, "converged": True}), encoding="utf-8")
    code, _, err = run_cli(
        ["iso230", str(csv), "-c", str(toml), "--estimate", str(est), "--json", str(j), "--force"]
    )
    assert code == 0, err
    assert not any("did not converge" in x for x in json.loads(j.read_text())["warnings"])
    code, _, err = run_cli(
        ["iso230", str(csv), "-c", str(toml), "--estimate", str(est), "--report", str(r), "--force"]
    )
    assert code == 0 and "not converged" not in r.read_text(encoding="utf-8"), err


def test_nominal_targets_written_in_mm_get_a_unit_hint(table, tmp_path, run_cli):
    """Found by an exploratory tester (session 13): [iso230] targets written in mm (the file's
    unit) were refused as "do not match" with no hint. Negative control: targets in m pass;
    targets that are simply wrong get no unit hint."""
    csv, toml = table
    mm = sorted({float(v) for v in pd.read_csv(csv)["Target [mm]"]})
    for targets, code_want, hint in (
        (mm, 2, True),
        ([v * 1e-3 for v in mm], 0, False),
        ([v * 1e-3 + 0.05 for v in mm], 2, False),
    ):
        cfg = tmp_path / "t.toml"
        cfg.write_text(toml.read_text() + f"\n[iso230]\ntargets = {targets}\n", encoding="utf-8")
        code, _, err = run_cli(["iso230", str(csv), "-c", str(cfg)])
        assert code == code_want, err
        assert ("these look like mm" in err) is hint, err


def test_deviations_in_mm_declared_as_um_are_warned(table, tmp_path, run_cli):
    """Found by an exploratory tester (session 13): a deviation column in mm declared as µm gave
    A = 0.021 µm, R = 0.013 µm without a word. Negative control: the right unit, no warning."""
    csv, toml = table
    df = pd.read_csv(csv)
    bad = tmp_path / "mm.csv"
    df.assign(**{"Error [um]": df["Error [um]"] * 1e-3}).to_csv(bad, index=False)  # mm values, µm label
    for path, warned in ((bad, True), (csv, False)):
        j = tmp_path / "o.json"
        code, _, err = run_cli(["iso230", str(path), "-c", str(toml), "--json", str(j), "--force"])
        assert code == 0, err
        w = json.loads(j.read_text())["warnings"]
        assert any("mm declared as µm" in x for x in w) is warned, w


def test_json_of_another_command_is_not_overwritten_without_force(table, tmp_path, run_cli):
    """Finding: `iso230 --json est.json` replaced an `estimate` result (any JSON starting with
    {"generator": "drivelash …} counted as ours). Re-running iso230 onto its own output is free."""
    from drivelash.io.outputs import Outputs, write_json

    csv, toml = table
    est = tmp_path / "est.json"
    with Outputs("estimate") as o:
        write_json(o.staging(o.file(est, option="--json")), {"delta": 0.105})
    before = est.read_bytes()
    code, _, err = run_cli(["iso230", str(csv), "-c", str(toml), "--json", str(est)])
    assert code == 2 and err.count("\n") == 1, err
    assert f"--json {est}: an existing file written by 'drivelash estimate', not by this command" in err
    assert "--force" in err and est.read_bytes() == before
    own = tmp_path / "iso.json"
    for _ in range(2):  # negative control: the same command replaces its own output
        code, _, err = run_cli(["iso230", str(csv), "-c", str(toml), "--json", str(own)])
        assert code == 0, err
    assert json.loads(own.read_text())["generator"].endswith(" iso230")
    code, _, err = run_cli(["iso230", str(csv), "-c", str(toml), "--json", str(est), "--force"])
    assert code == 0, err


def test_jittered_time_stamps_name_the_config_key_not_an_option(tmp_path, run_cli):
    """Found by an exploratory tester (s19 F21): a laser time series stamped by a PC clock
    (±2 ms jitter at 100 Hz) was refused with "resample explicitly with --resample or
    [sampling] resample = true", and `iso230 --resample` is "No such option". The message now
    names only the configuration key; following it evaluates the file (negative control)."""
    cols, truth = synthetic_recording(AXIS, m=5, n=3, seed=5, dwell=0.8)
    k = slice(None, None, 10)  # 100 Hz, as a laser's PC software writes
    t = cols["t"][k] + np.random.default_rng(1).uniform(-0.002, 0.002, cols["t"][k].size)
    p = tmp_path / "jit.csv"
    pd.DataFrame({"t": t, "cmd": cols["P_cmd"][k] * 1e3, "laser": cols["P_actual"][k] * 1e3}).to_csv(
        p, index=False
    )
    toml = tmp_path / "jit.toml"
    cfg = '[columns.cmd]\ncolumn = "P_cmd"\nunit = "mm"\n[columns.laser]\ncolumn = "P_actual"\nunit = "mm"\n'
    toml.write_text(cfg, encoding="utf-8")
    code, out, err = run_cli(["iso230", str(p), "-c", str(toml)])
    assert code == 2 and "non-uniform sampling" in err, (out, err)
    assert "--resample" not in err and "[sampling] resample = true" in err, err
    toml.write_text(cfg + "[sampling]\nresample = true\n", encoding="utf-8")
    code, _, err = run_cli(["iso230", str(p), "-c", str(toml)])
    assert code == 0, err


def test_direction_words_are_refused_saying_what_the_column_holds(table, tmp_path, run_cli):
    """Found by an exploratory tester (s19 F9): a laser export's direction column with words
    (Up/Down) was refused as "not a number: 'Up'" without saying what the column must hold.
    Now the same line says it is +1 / -1. Negative control: a bad number in another column
    gets no direction hint."""
    csv, toml = table
    df = pd.read_csv(csv)
    words = df.assign(Dir=df["Dir"].map({1: "Up", -1: "Down"}))
    p = tmp_path / "words.csv"
    words.to_csv(p, index=False)
    j = tmp_path / "o.json"
    _bad(run_cli, ["iso230", str(p), "-c", str(toml), "--json", str(j)], "not a number: 'Up'", [j])
    _, _, err = run_cli(["iso230", str(p), "-c", str(toml)])
    assert "column 'Dir'" in err and "a direction is +1 (approach in the positive direction) or -1" in err
    bad = df.astype({"Error [um]": object})
    bad.loc[3, "Error [um]"] = "n/a"
    bad.to_csv(p, index=False)
    code, _, err = run_cli(["iso230", str(p), "-c", str(toml)])
    assert code == 2 and "not a number" in err and "a direction is" not in err, err


def test_a_target_column_with_micrometre_scatter_is_assigned_to_the_nominal_targets(table, tmp_path, run_cli):
    """Found by an exploratory tester (s19 F14): a table whose target column holds the control's
    actual position (±2 µm between runs) was "unequal targets: target -0.0015 mm has no approach
    …", even with the nominal `[iso230] targets` given — they only verified, never assigned. Now
    with them each row is taken at its nominal target (warned), and the result equals the file
    with exact targets; without them the refusal says what is going on and what to give."""
    csv, toml = table
    df = pd.read_csv(csv)
    nominal = sorted({float(v) * 1e-3 for v in df["Target [mm]"]})
    jit = df.assign(
        **{"Target [mm]": df["Target [mm]"] + np.random.default_rng(2).uniform(-2e-3, 2e-3, len(df))}
    )
    p = tmp_path / "jit.csv"
    jit.to_csv(p, index=False)
    code, _, err = run_cli(["iso230", str(p), "-c", str(toml)])
    assert code == 2 and "unequal targets" in err, err
    assert "give the nominal targets as [iso230] targets" in err, err
    cfg = tmp_path / "nominal.toml"
    cfg.write_text(toml.read_text() + f"\n[iso230]\ntargets = {nominal}\n", encoding="utf-8")
    j, jr = tmp_path / "jit.json", tmp_path / "ref.json"
    code, _, err = run_cli(["iso230", str(p), "-c", str(cfg), "--json", str(j)])
    assert code == 0, err
    assert "each row taken at its nominal target" in err
    code, _, err = run_cli(["iso230", str(csv), "-c", str(cfg), "--json", str(jr)])
    assert code == 0 and "nominal target" not in err, err  # negative control: exact targets, no warning
    got, ref = json.loads(j.read_text()), json.loads(jr.read_text())
    for key in ("B", "B_mean", "u_B_mean"):
        assert got["reversal"][key] == pytest.approx(ref["reversal"][key], rel=1e-12), key
    assert got["axis"]["A"] == pytest.approx(ref["axis"]["A"], rel=1e-12)
