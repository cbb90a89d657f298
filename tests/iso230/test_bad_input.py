"""``drivelash iso230`` under bad input: every class is one line on stderr, exit 2, and the
output location unchanged (no new, changed or half-written file) — issue 15's contract for
this command, and issue 14's "bad input: one-line errors".

The working directory holds a good table, a good recording, a good config and estimate,
and a user's own ``notes.html``; each case runs the command once with ``--json`` and
``--report`` into that directory and compares a snapshot (names, bytes) before and after.
Cases already covered with their full message in ``test_cli.py`` (fewer than 2 runs,
unequal targets, units mismatch, config keys, output over the input) are not repeated.
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from drivelash.io import Trace
from drivelash.iso230.synthetic import SyntheticAxis, synthetic_recording, synthetic_table

AXIS = SyntheticAxis(delta=12e-6, sigma=0.5e-6)
LEAD = 0.01

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

[transmission]
lead = 0.01
"""
REC_TOML = '[columns.cmd]\ncolumn = "P_cmd"\nunit = "mm"\n[columns.laser]\ncolumn = "P_actual"\nunit = "mm"\n'


def _frame(tb: dict[str, np.ndarray]) -> pd.DataFrame:
    return pd.DataFrame(
        {
            "Target [mm]": tb["P_target"] * 1e3,
            "Run": tb["run"].astype(int),
            "Dir": tb["direction"].astype(int),
            "Error [um]": tb["x_dev"] * 1e6,
        }
    )


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("iso230-bad")
    df = _frame(synthetic_table(AXIS, m=5, n=3, seed=2))
    df.to_csv(d / "laser.csv", index=False)
    (d / "laser.toml").write_text(TABLE_TOML, encoding="utf-8")
    bad = df.copy()
    bad.loc[4, "Error [um]"] = np.nan
    bad.to_csv(d / "nan.csv", index=False)
    bad = df.astype({"Error [um]": object})
    bad.loc[4, "Error [um]"] = "1,5"
    bad.to_csv(d / "text.csv", index=False)
    bad = df.copy()
    bad.loc[3, "Dir"] = 0
    bad.to_csv(d / "dir0.csv", index=False)
    bad = df.copy()
    bad.loc[3, "Run"] = bad.loc[1, "Run"]  # the same (target, direction, run) twice
    bad.loc[3, "Dir"] = bad.loc[1, "Dir"]
    bad.loc[3, "Target [mm]"] = bad.loc[1, "Target [mm]"]
    bad.to_csv(d / "dup.csv", index=False)
    df.drop(columns=["Run"]).to_csv(d / "norun.csv", index=False)
    df.iloc[:0].to_csv(d / "header_only.csv", index=False)
    (d / "empty.csv").write_bytes(b"")
    (d / "garbage.parquet").write_bytes(np.random.default_rng(0).bytes(4096))
    df.to_parquet(d / "full.parquet")
    (d / "truncated.parquet").write_bytes((d / "full.parquet").read_bytes()[:300])
    (d / "adir.csv").mkdir()
    cols, truth = synthetic_recording(AXIS, m=5, n=2, seed=5, dwell=0.6, skip=((2, 1, 2),))
    Trace({"t": cols["t"], "cmd": cols["P_cmd"] * 1e3, "laser": cols["P_actual"] * 1e3}).to_csv(
        d / "missing_dwell.csv"
    )
    t = np.arange(0.0, 5.0, 1e-3)
    ramp = 10.0 + 20.0 * t  # mm: moves all the time, never dwells
    Trace({"t": t, "cmd": ramp, "laser": ramp}).to_csv(d / "no_dwell.csv")
    (d / "rec.toml").write_text(REC_TOML, encoding="utf-8")
    (d / "bad_syntax.toml").write_text("[columns\nx = 1\n", encoding="utf-8")
    (d / "bad_column.toml").write_text(
        TABLE_TOML.replace('"Error [um]"]', '"Fehler [um]"]'), encoding="utf-8"
    )
    k = LEAD / (2 * math.pi)
    (d / "est.json").write_text(f'{{"delta": {12e-6 / k}, "delta_std": {0.3e-6 / k}}}', encoding="utf-8")
    (d / "est_garbage.json").write_text("{ this is not json", encoding="utf-8")
    (d / "est_nodelta.json").write_text('{"excitation_ok": true}', encoding="utf-8")
    (d / "est_negative.json").write_text('{"delta": -0.001}', encoding="utf-8")
    (d / "est_nan.json").write_text('{"delta": NaN}', encoding="utf-8")
    (d / "notes.html").write_text("<html><body>my own notes</body></html>", encoding="utf-8")
    (d / "out").mkdir()
    (d / "out" / "a.json").mkdir()  # an output path that is a directory
    return d


def _snapshot(d: Path) -> dict[str, str]:
    return {
        str(p.relative_to(d)): "dir" if p.is_dir() else hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(d.rglob("*"))
    }


J, R = "{d}/out/iso.json", "{d}/out/iso.html"
GOOD = ["{d}/laser.csv", "-c", "{d}/laser.toml"]

#: (case, argv after ``iso230``, text the one line must contain)
CASES = [
    # input files
    ("missing file", ["{d}/nope.csv", "-c", "{d}/laser.toml"], "nope.csv"),
    ("empty file", ["{d}/empty.csv", "-c", "{d}/laser.toml"], "empty.csv"),
    ("header only", ["{d}/header_only.csv", "-c", "{d}/laser.toml"], "header_only.csv"),
    ("garbage bytes", ["{d}/garbage.parquet", "-c", "{d}/laser.toml"], "garbage.parquet"),
    ("truncated parquet", ["{d}/truncated.parquet", "-c", "{d}/laser.toml"], "truncated.parquet"),
    ("directory as input", ["{d}/adir.csv", "-c", "{d}/laser.toml"], "adir.csv"),
    ("unsupported type", ["{d}/laser.toml", "-c", "{d}/laser.toml"], "unsupported file type"),
    # table contents
    ("NaN deviation", ["{d}/nan.csv", "-c", "{d}/laser.toml"], "Error [um]"),
    ("text in a number column", ["{d}/text.csv", "-c", "{d}/laser.toml"], "Error [um]"),
    ("direction 0", ["{d}/dir0.csv", "-c", "{d}/laser.toml"], "direction"),
    ("approach twice", ["{d}/dup.csv", "-c", "{d}/laser.toml"], "appears twice"),
    ("missing column", ["{d}/norun.csv", "-c", "{d}/laser.toml"], "Run"),
    ("mapped column absent", ["{d}/laser.csv", "-c", "{d}/bad_column.toml"], "Fehler [um]"),
    # recordings
    ("missing dwell", ["{d}/missing_dwell.csv", "-c", "{d}/rec.toml"], "dwell(s) approached in direction"),
    ("no dwell at all", ["{d}/no_dwell.csv", "-c", "{d}/rec.toml"], "no dwell found"),
    # configuration
    ("missing config", ["{d}/laser.csv", "-c", "{d}/nope.toml"], "nope.toml"),
    ("TOML syntax", ["{d}/laser.csv", "-c", "{d}/bad_syntax.toml"], "bad_syntax.toml"),
    # deadzone estimate
    ("estimate not JSON", [*GOOD, "--estimate", "{d}/est_garbage.json"], "est_garbage.json"),
    ("estimate without delta", [*GOOD, "--estimate", "{d}/est_nodelta.json"], "est_nodelta.json"),
    ("estimate negative delta", [*GOOD, "--estimate", "{d}/est_negative.json"], "est_negative.json"),
    ("estimate NaN delta", [*GOOD, "--estimate", "{d}/est_nan.json"], "est_nan.json"),
    # outputs
    ("report over the config", [*GOOD, "--report", "{d}/laser.toml"], "--report"),
    ("json over the estimate", [*GOOD, "--estimate", "{d}/est.json", "--json", "{d}/est.json"], "--json"),
    ("report over a user's file", [*GOOD, "--report", "{d}/notes.html"], "--force"),
    ("output in a missing directory", [*GOOD, "--json", "{d}/nodir/o.json"], "does not exist"),
    ("output is a directory", [*GOOD, "--json", "{d}/out/a.json"], "is a directory"),
    ("output extension", [*GOOD, "--report", "{d}/out/r.png"], "unsupported extension"),
    # history
    ("--db without --axis", [*GOOD, "--db", "{d}/wear.sqlite"], "--db and --axis go together"),
    ("store that does not exist", [*GOOD, "--db", "{d}/wear.sqlite", "--axis", "M/X"], "wear.sqlite"),
    ("--time not a time", [*GOOD, "--time", "last tuesday"], "--time"),
]


#: Usage errors (typer's own: missing argument, unknown option, option without value) go through
#: ``cli.main`` too: one line, exit 2 (issue 15 item 1).
USAGE = [
    pytest.param("missing argument", [], "Missing argument", id="missing argument"),
    pytest.param("unknown option", [*GOOD, "--bogus"], "--bogus", id="unknown option"),
    pytest.param(
        "option without value",
        [*GOOD, "--json", J, "--report", R, "--axis"],
        "--axis",
        id="option no value",
    ),
]


@pytest.mark.parametrize(("case", "args", "needle"), [*CASES, *USAGE], ids=[c[0] for c in CASES] + [None] * 3)
def test_bad_input_is_one_line_exit_2_nothing_written(files, run_cli, case, args, needle):
    d = files
    argv = ["iso230", *[a.format(d=d) for a in args]]
    if "--json" not in argv:
        argv += ["--json", J.format(d=d)]
    if "--report" not in argv:
        argv += ["--report", R.format(d=d)]
    before = _snapshot(d)
    code, out, err = run_cli(argv)
    assert code == 2, (case, out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1, (case, err)
    assert lines[0].startswith("drivelash: error: ") and "Traceback" not in err, (case, err)
    assert needle in lines[0], (case, lines[0])
    assert _snapshot(d) == before, case


def test_negative_control_good_input_writes_both_outputs(files, run_cli):
    """The same harness on good input: exit 0 and exactly the two outputs appear."""
    d = files
    argv = ["iso230", *[a.format(d=d) for a in GOOD], "--json", J.format(d=d), "--report", R.format(d=d)]
    before = _snapshot(d)
    code, _, err = run_cli(argv)
    assert code == 0, err
    after = _snapshot(d)
    assert set(after) - set(before) == {"out/iso.json", "out/iso.html"}
    assert {k: v for k, v in after.items() if k in before} == before
    for k in ("out/iso.json", "out/iso.html"):
        (d / k).unlink()
