"""The CLI fuzz harness (issue 15 item 6): bad-input classes × every command.

Every case runs ``drivelash …`` in-process through :func:`drivelash.cli.main` and asserts:

- exit code 2;
- exactly one line on stderr, ``drivelash: error: …``, naming the file, key or option
  (the case's *needle*);
- no traceback (an exception escaping ``main`` fails the case; numerical
  ``RuntimeWarning``\\ s are errors here: ``DRIVELASH_WARNINGS=error``);
- no new or changed file in the work directory (a snapshot of every file, hidden ones
  included, with its content hash, before and after).

How to extend it
----------------
- **A new command** gets a row in :data:`COMMANDS` (its good invocation, its inputs and
  outputs); :func:`test_every_command_has_a_row` fails until it has one.
- **A new class** is a function in :data:`CLASSES` ``(cmd, ws) -> list[Case] | str``
  (the cases, or the reason it does not apply to that command).

``make test`` runs the fast rows; ``make test-slow`` runs every row (``slow`` marker).
The count of cases (classes × commands) is printed by :func:`test_coverage_count`.
"""

from __future__ import annotations

import faulthandler
import functools
import hashlib
import inspect
import os
import shutil
import signal
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
T_S = 1e-3


# =========================================================================== workspace
def _signals(n: int = 3000) -> dict[str, np.ndarray]:
    t = np.arange(n) * T_S
    th_m = 0.5 * np.sin(2 * np.pi * 1.0 * t) + 0.05 * np.sin(2 * np.pi * 7.0 * t)
    om_m = 0.5 * 2 * np.pi * np.cos(2 * np.pi * t) + 0.05 * 2 * np.pi * 7 * np.cos(2 * np.pi * 7 * t)
    th_l = 0.9 * th_m
    return {
        "t": t,
        "theta_m": th_m,
        "omega_m": om_m,
        "theta_l": th_l,
        "omega_l": 0.9 * om_m,
        "torque_m": 0.4 * np.sin(2 * np.pi * t + 0.4) + 0.03 * np.cos(2 * np.pi * 11 * t),
    }


AXIS_TOML = """
[geometry]
m_n = 0.003
n_t = 24
helix_angle = 0.340808
i_PG = 10.0
travel = 1.2

[columns.t]
column = "t"
[columns.theta_l]
column = "x_T"
[columns.theta_m]
column = "theta_m"
[columns.torque_m]
column = "torque_m"

[[runs]]
kind = "load"
direction = 1
velocity = 0.1
load = 0.0
file = "rec.csv"
"""

IDENT_TOML = """
[drivetrain]
J_m = 0.01
beta_m = 0.001

[identification]
decimate = 2
n_border = 10
"""


def _build_workspace(d: Path) -> None:
    """Good inputs every row starts from (small, written once per module)."""
    from drivelash.io import Trace, write_trace

    sig = _signals()
    write_trace(Trace(sig), d / "rec.csv")
    write_trace(Trace(sig), d / "rec.parquet")
    shutil.copy(REPO / "examples" / "drive_bench.toml", d / "drive.toml")
    (d / "ident.toml").write_text(IDENT_TOML)
    (d / "axis.toml").write_text(AXIS_TOML)
    (d / "scen.toml").write_text('base = "bench-0A"\nduration = 0.5\n')
    # ISO 230-2 recording, as the demo writes it
    from drivelash.iso230.synthetic import SyntheticAxis, synthetic_recording

    cols, _ = synthetic_recording(SyntheticAxis(), m=5, n=2, seed=0)
    Trace(
        {"t": cols["t"], "cmd_mm": cols["P_cmd"] * 1e3, "laser_mm": cols["P_actual"] * 1e3},
        {"source": "fuzz"},
    ).to_csv(d / "iso.csv")
    cfg = (REPO / "examples" / "iso230_recording.toml").read_text()
    (d / "iso.toml").write_text(cfg.replace("[columns.encoder_mm]", "[columns.unused]"))
    (d / "campaign").mkdir()  # placeholders: exist, not valid (TE inputs fail after outputs)
    (d / "model").mkdir()
    (d / "foreign.json").write_text('{"mine": true}\n')
    (d / "foreign.png").write_bytes(b"\x89PNG\r\n\x1a\nnot really")
    (d / "foreign_dir").mkdir()
    (d / "foreign_dir" / "notes.txt").write_text("user data")
    (d / "ro").mkdir()
    (d / "a_dir.json").mkdir()
    (d / "a_dir.parquet").mkdir()


@dataclass
class Case:
    """One bad invocation: its argv (``{w}`` = work directory) and what the error must name."""

    argv: list[str]
    needle: str
    slow: bool = False
    xfail: str | None = None
    env: dict[str, str] = field(default_factory=dict)


@dataclass
class Cmd:
    """A command's row: a good invocation and where its inputs and outputs are."""

    good: list[str]
    recording: int | None = None  # argv index of the recording argument
    config: int | None = None  # argv index of the TOML configuration's value
    config_kind: str | None = None  # "drive", "ident", "scenario", "iso230", "axis"
    file_outputs: dict[str, str] = field(default_factory=dict)  # option -> a good extension
    dir_outputs: tuple[str, ...] = ()
    plot_options: tuple[str, ...] = ()
    inputs: tuple[str, ...] = ()  # input paths in good argv (for output = input)
    na: dict[str, str] = field(default_factory=dict)  # class -> reason it does not apply
    slow: bool = False  # every case of this row is slow (heavy imports)
    xfail: dict[str, str] = field(default_factory=dict)  # class -> known-miss reason
    slow_classes: tuple[str, ...] = ()  # classes whose cases are slow for this command
    needs_store: bool = False  # the workspace gets the fleet store (fl/) of :func:`fleet_store`


W = "{w}"
#: One row per command (``drivelash --help`` and ``te`` subcommands).
COMMANDS: dict[str, Cmd] = {
    "scenarios": Cmd(good=["scenarios"]),
    "simulate": Cmd(
        good=["simulate", "bench-0A", "-o", f"{W}/out.parquet", "--duration", "0.2"],
        config=1,
        config_kind="scenario",
        file_outputs={"-o": ".parquet"},
    ),
    "estimate": Cmd(
        good=[
            "estimate",
            f"{W}/rec.parquet",
            "--config",
            f"{W}/drive.toml",
            "--json",
            f"{W}/o.json",
            "--plot",
            f"{W}/o.png",
            "--report",
            f"{W}/o.html",
        ],  # fmt: skip
        recording=1,
        config=3,
        config_kind="drive",
        file_outputs={"--json": ".json", "--plot": ".png", "--report": ".html"},
        plot_options=("--plot",),
        inputs=(f"{W}/rec.parquet", f"{W}/drive.toml"),
    ),
    "reproduce": Cmd(good=["reproduce", "--quick", "-o", f"{W}/rep"], dir_outputs=("-o",)),
    "identify": Cmd(
        good=[
            "identify",
            f"{W}/rec.parquet",
            "--config",
            f"{W}/ident.toml",
            "--json",
            f"{W}/i.json",
            "--report",
            f"{W}/i.html",
            "--out",
            f"{W}/i.toml",
        ],  # fmt: skip
        recording=1,
        config=3,
        config_kind="ident",
        file_outputs={"--json": ".json", "--report": ".html", "--out": ".toml"},
        inputs=(f"{W}/rec.parquet", f"{W}/ident.toml"),
    ),
    "observe": Cmd(
        good=[
            "observe",
            f"{W}/rec.parquet",
            "--config",
            f"{W}/ident.toml",
            "--json",
            f"{W}/b.json",
            "--report",
            f"{W}/b.html",
            "--out",
            f"{W}/b.parquet",
        ],  # fmt: skip
        recording=1,
        config=3,
        config_kind="ident",
        file_outputs={"--json": ".json", "--report": ".html", "--out": ".parquet"},
        inputs=(f"{W}/rec.parquet", f"{W}/ident.toml"),
    ),
    "demo": Cmd(good=["demo", "-o", f"{W}/demo"], dir_outputs=("-o",)),
    "iso230": Cmd(
        good=[
            "iso230",
            f"{W}/iso.csv",
            "--config",
            f"{W}/iso.toml",
            "--json",
            f"{W}/s.json",
            "--report",
            f"{W}/s.html",
        ],  # fmt: skip
        recording=1,
        config=3,
        config_kind="iso230",
        file_outputs={"--json": ".json", "--report": ".html"},
        inputs=(f"{W}/iso.csv", f"{W}/iso.toml"),
        na={
            "nan": "ISO 230-2 tables may hold NaN for absent approaches (iso230 owner's rule)",
            "ns-time-stamps": "a table of approaches has no time column",
            "non-increasing-time": "a table of approaches has no time column",
            "missing-column": "covered by iso230's own tests (column names per [columns])",
        },  # fmt: skip
    ),
    "te campaign": Cmd(
        good=["te", "campaign", "-o", f"{W}/camp_out", "--quick"],
        dir_outputs=("-o",),
    ),
    "te import": Cmd(
        good=["te", "import", f"{W}/axis.toml", "-o", f"{W}/imp_out"],
        config=2,
        config_kind="axis",
        dir_outputs=("-o",),
        inputs=(f"{W}/axis.toml", f"{W}/rec.csv"),
    ),
    "te fit": Cmd(
        good=["te", "fit", f"{W}/campaign", "-o", f"{W}/model_out", "--trials", "1"],
        dir_outputs=("-o",),
        inputs=(f"{W}/campaign",),
    ),
    "te evaluate": Cmd(
        good=["te", "evaluate", f"{W}/model", f"{W}/campaign", "-o", f"{W}/eval_out"],
        dir_outputs=("-o",),
        inputs=(f"{W}/model", f"{W}/campaign"),
    ),
    "te validate": Cmd(
        good=["te", "validate", f"{W}/model", "-o", f"{W}/val_out", "--quick"],
        dir_outputs=("-o",),
        inputs=(f"{W}/model",),
    ),
    "te export": Cmd(
        good=["te", "export", f"{W}/model", "-o", f"{W}/table.json"],
        file_outputs={"-o": ".json"},
        inputs=(f"{W}/model",),
    ),
    "te update": Cmd(
        good=["te", "update", f"{W}/model", f"{W}/campaign", "-o", f"{W}/upd_out"],
        dir_outputs=("-o",),
        inputs=(f"{W}/model", f"{W}/campaign"),
    ),
    "te score": Cmd(
        good=[
            "te",
            "score",
            "--uncompensated",
            f"{W}/campaign",
            "--compensated",
            f"{W}/campaign",
            "-o",
            f"{W}/score_out",
        ],  # fmt: skip
        dir_outputs=("-o",),
        inputs=(f"{W}/campaign",),
    ),
}

#: The output classes of the track rows need a fleet store (:func:`fleet_store`, built once,
#: 1–2 min): they run in make test-slow; the usage classes run on the fast rotation.
_STORE_CLASSES = (
    "output-is-input",
    "output-dir-missing",
    "output-dir-read-only",
    "output-is-directory",
    "foreign-file-no-force",
)
FLEET = f"{W}/fl/fleet.toml"
COMMANDS.update(
    {
        "track ingest": Cmd(good=["track", "ingest", FLEET, "--workers", "1"]),
        "track status": Cmd(good=["track", "status", "--fleet", FLEET]),
        "track forecast": Cmd(
            good=["track", "forecast", "M01/X", "--fleet", FLEET, "--json", f"{W}/f.json"],
            file_outputs={"--json": ".json"},
            inputs=(FLEET, f"{W}/fl/wear.sqlite"),
            needs_store=True,
            slow_classes=_STORE_CLASSES,
        ),
        "track report": Cmd(
            good=["track", "report", "--fleet", FLEET, "-o", f"{W}/fleet.html"],
            file_outputs={"-o": ".html"},
            inputs=(FLEET, f"{W}/fl/wear.sqlite"),
            needs_store=True,
            slow_classes=_STORE_CLASSES,
        ),
    }
)


# =========================================================================== classes
def _sub(argv: list[str], i: int, value: str) -> list[str]:
    out = list(argv)
    out[i] = value
    return out


def _replace_opt(argv: list[str], opt: str, value: str) -> list[str]:
    i = argv.index(opt)
    return _sub(argv, i + 1, value)


def _drop_opt(argv: list[str], opt: str) -> list[str]:
    i = argv.index(opt)
    return argv[:i] + argv[i + 2 :]


@functools.cache
def _click_app():
    import typer.main

    from drivelash.cli import app

    return typer.main.get_command(app)


def _params(cmd: Cmd):
    node = _click_app()
    words = [w for w in cmd.good if not w.startswith("-")]
    for w in words:
        if not hasattr(node, "commands"):
            break
        node = node.commands[w]
    return node


# -- recordings ------------------------------------------------------------
def _recording_files(d: Path) -> dict[str, tuple[str, str]]:
    """class -> (file name, needle); written into the workspace by :func:`_write_bad_recordings`."""
    return {
        "missing-file": ("nope.csv", "nope.csv"),
        "empty-file": ("empty.csv", "empty.csv"),
        "truncated-file": ("trunc.parquet", "trunc.parquet"),
        "garbage-bytes": ("garbage.parquet", "garbage.parquet"),
        "wrong-extension": ("rec.xlsx", "rec.xlsx"),
        "wrong-content-type": ("text.parquet", "text.parquet"),
        "nan": ("nan.csv", "nan.csv"),
        "non-increasing-time": ("back.csv", "back.csv"),
        "ns-time-stamps": ("ns.csv", "ns.csv"),
        "missing-column": ("nocol.csv", "nocol.csv"),
        "units-row-contradicts": ("units.csv", "units.csv"),
    }


def _write_bad_recordings(d: Path) -> None:
    from drivelash.io import Trace, write_trace

    sig = _signals()
    (d / "empty.csv").write_bytes(b"")
    good = (d / "rec.parquet").read_bytes()
    (d / "trunc.parquet").write_bytes(good[: len(good) // 2])
    (d / "garbage.parquet").write_bytes(bytes(range(256)) * 8)
    (d / "rec.xlsx").write_bytes(b"PK\x03\x04" + b"\x00" * 64)
    (d / "text.parquet").write_text((d / "rec.csv").read_text())
    c = dict(sig)
    c["torque_m"] = sig["torque_m"].copy()
    c["torque_m"][100] = np.nan
    write_trace(Trace(c), d / "nan.csv")
    c = dict(sig)
    c["t"] = sig["t"].copy()
    c["t"][200] = c["t"][198]
    write_trace(Trace(c), d / "back.csv")
    c = dict(sig)
    c["t"] = np.round(sig["t"] * 1e9)
    write_trace(Trace(c), d / "ns.csv")
    # no theta_m and no torque_m: every command that reads a recording needs one of them
    c = {k: v for k, v in sig.items() if k not in ("theta_m", "torque_m")}
    write_trace(Trace(c), d / "nocol.csv")
    # a DAQ's units row under the header that says theta_m is in degrees (the numbers are rad)
    lines = (d / "rec.csv").read_text().splitlines(keepends=True)
    h = next(i for i, ln in enumerate(lines) if not ln.startswith("#"))
    names = lines[h].strip().split(",")
    units = {"t": "s", "theta_m": "deg", "theta_l": "rad", "omega_m": "rad/s", "omega_l": "rad/s"}
    row = ",".join(units.get(n, "Nm") for n in names) + "\n"
    (d / "units.csv").write_text("".join([*lines[: h + 1], row, *lines[h + 1 :]]))


def _recording_class(name: str) -> Callable[[Cmd, Path], list[Case] | str]:
    def make(cmd: Cmd, d: Path) -> list[Case] | str:
        if cmd.recording is None:
            return "takes no recording"
        fname, needle = _recording_files(d)[name]
        return [Case(_sub(cmd.good, cmd.recording, f"{W}/{fname}"), needle)]

    make.__name__ = name
    return make


# -- configuration ------------------------------------------------------------
_CONFIG_BAD = {
    # kind -> class -> (text, needle)
    "drive": {
        "bad-toml": ("[drivetrain\nJ_m = 1\n", ""),
        "unknown-key": ("[drivetrain]\nJ_mm = 1.0\n[backlash]\ndelta1 = 0.1\n", "J_mm"),
        "missing-key": ("[drivetrain]\nJ_m = 8.31e-4\n[backlash]\ndelta1 = 0.1\n", "J_l"),
        "wrong-type": ('[drivetrain]\nJ_m = "heavy"\n[backlash]\ndelta1 = 0.1\n', "J_m"),
    },
    "ident": {
        "bad-toml": ("[identification\n", ""),
        "unknown-key": ("[identification]\ncutof_hz = 5.0\n", "cutof_hz"),
        "missing-key": ("[drivetrain]\nbeta_m = 0.001\n", "J_m"),
        "wrong-type": ('[identification]\ndecimate = "two"\n', "decimate"),
    },
    "scenario": {
        "bad-toml": ('base = "bench-0A"\nduration = \n', ""),
        "unknown-key": ('base = "bench-0A"\nduraton = 1.0\n', "duraton"),
        "missing-key": ('base = "no-such-scenario"\n', "no-such-scenario"),
        "wrong-type": ('base = "bench-0A"\nduration = "long"\n', "duration"),
    },
    "axis": {
        "bad-toml": ("[geometry\n", ""),
        "unknown-key": ("[geometry]\ntravl = 1.0\n", "travl"),
        "missing-key": ("[geometry]\nn_t = 24\n", "runs"),
        "wrong-type": (
            '[geometry]\nn_t = "many"\n[[runs]]\nkind = "load"\ndirection = 1\nfile = "rec.csv"\n',
            "n_t",
        ),
    },
    "iso230": {
        "bad-toml": ("[dwell\n", ""),
        "unknown-key": ("[dwell]\nT_dwel_min = 0.5\n", "T_dwel_min"),
        "missing-key": ('[columns.t]\nunit = "s"\n', "column"),
        "wrong-type": ('[dwell]\nT_dwell_min = "long"\n', "T_dwell_min"),
    },
}


def _config_class(name: str) -> Callable[[Cmd, Path], list[Case] | str]:
    def make(cmd: Cmd, d: Path) -> list[Case] | str:
        if cmd.config is None or cmd.config_kind is None:
            return "takes no configuration file"
        text, needle = _CONFIG_BAD[cmd.config_kind][name]
        fname = f"bad-{cmd.config_kind}-{name}.toml"
        if name == "bad-toml":
            needle = fname  # a syntax error names the file (and the line)
        (d / fname).write_text(text)
        return [Case(_sub(cmd.good, cmd.config, f"{W}/{fname}"), needle)]

    make.__name__ = name
    return make


# -- usage ------------------------------------------------------------
def _missing_required(cmd: Cmd, d: Path) -> list[Case] | str:
    node = _params(cmd)
    words = cmd.good[:2] if cmd.good[0] in ("te", "track") else cmd.good[:1]
    cases = []
    for p in node.params:
        if p.required and p.param_type_name == "option":
            opt = next(o for o in p.opts if o in cmd.good)
            cases.append(Case(_drop_opt(cmd.good, opt), "missing option"))
    if any(p.required and p.param_type_name == "argument" for p in node.params):
        cases.append(Case(list(words), "missing argument"))
    return cases or "has no required parameter"


def _unknown_option(cmd: Cmd, d: Path) -> list[Case] | str:
    return [Case([*cmd.good, "--no-such-option"], "--no-such-option")]


def _bad_value_type(cmd: Cmd, d: Path) -> list[Case] | str:
    node = _params(cmd)
    sig = inspect.signature(node.callback)
    cases = []
    for p in node.params:
        ann = str(sig.parameters[p.name].annotation)
        if p.param_type_name == "option" and ("int" in ann or "float" in ann) and "bool" not in ann:
            cases.append(Case([*cmd.good, p.opts[0], "abc"], p.opts[0]))
    return cases or "has no numeric option"


def _bad_value_range(cmd: Cmd, d: Path) -> list[Case] | str:
    node = _params(cmd)
    cases = []
    for p in node.params:
        if p.param_type_name != "option":
            continue
        if getattr(p, "min", None) is not None:
            cases.append(Case([*cmd.good, p.opts[0], str(p.min - 1)], p.opts[0]))
        if getattr(p, "max", None) is not None:
            cases.append(Case([*cmd.good, p.opts[0], str(p.max + 1)], p.opts[0]))
    return cases or "has no bounded option"


def _unknown_command(cmd: Cmd, d: Path) -> list[Case] | str:
    if cmd.good[0] in ("te", "track"):
        return [Case([cmd.good[0], cmd.good[1] + "x"], "no such command")]
    return [Case([cmd.good[0] + "x"], "no such command")]


# -- outputs ------------------------------------------------------------
def _output_is_input(cmd: Cmd, d: Path) -> list[Case] | str:
    if not cmd.inputs:
        return "reads no input file"
    cases = []
    for opt in cmd.file_outputs:
        for inp in cmd.inputs:
            if inp.endswith(("campaign", "model")):
                continue
            cases.append(Case(_replace_opt(cmd.good, opt, inp), f"{opt} "))
    for opt in cmd.dir_outputs:
        for inp in cmd.inputs:
            cases.append(Case(_replace_opt(cmd.good, opt, inp), f"{opt} "))
    return cases or "no output can name an input"


def _output_missing_dir(cmd: Cmd, d: Path) -> list[Case] | str:
    outs = [*cmd.file_outputs, *cmd.dir_outputs]
    if not outs:
        return "writes no file"
    return [
        Case(_replace_opt(cmd.good, o, f"{W}/missing/x{cmd.file_outputs.get(o, '')}"), f"{o} ") for o in outs
    ]


def _output_read_only_dir(cmd: Cmd, d: Path) -> list[Case] | str:
    outs = [*cmd.file_outputs, *cmd.dir_outputs]
    if not outs:
        return "writes no file"
    return [Case(_replace_opt(cmd.good, o, f"{W}/ro/x{cmd.file_outputs.get(o, '')}"), f"{o} ") for o in outs]


def _output_is_directory(cmd: Cmd, d: Path) -> list[Case] | str:
    cases = []
    for o, ext in cmd.file_outputs.items():
        target = f"{W}/a_dir{ext}"
        if not (d / f"a_dir{ext}").exists():
            (d / f"a_dir{ext}").mkdir()
        cases.append(Case(_replace_opt(cmd.good, o, target), f"{o} "))
    for o in cmd.dir_outputs:  # an existing *file* where a directory is written
        cases.append(Case(_replace_opt(cmd.good, o, f"{W}/foreign.json"), f"{o} "))
    return cases or "writes no file"


def _unknown_plot_extension(cmd: Cmd, d: Path) -> list[Case] | str:
    if not cmd.plot_options:
        return "writes no plot"
    cases = []
    for o in cmd.plot_options:
        cases.append(Case(_replace_opt(cmd.good, o, f"{W}/p.txt"), f"{o} "))
        cases.append(Case(_replace_opt(cmd.good, o, f"{W}/p.parquet"), f"{o} "))
    return cases


def _foreign_file(cmd: Cmd, d: Path) -> list[Case] | str:
    cases = []
    for o, ext in cmd.file_outputs.items():
        name = f"foreign{ext}"
        if not (d / name).exists():
            (d / name).write_bytes(b"a user's file, not ours\n")
        cases.append(Case(_replace_opt(cmd.good, o, f"{W}/{name}"), f"{o} "))
    for o in cmd.dir_outputs:
        cases.append(Case(_replace_opt(cmd.good, o, f"{W}/foreign_dir"), f"{o} "))
    return cases or "writes no file"


# -- absurd sizes ------------------------------------------------------------
def _absurd(name: str) -> Callable[[Cmd, Path], list[Case] | str]:
    def make(cmd: Cmd, d: Path) -> list[Case] | str:
        if cmd.good[0] != "simulate":
            return "no size to ask for" if cmd.good[0] != "te" else "TE sizes: te export grid (h5-te-axis)"
        if name == "absurd-duration":
            return [Case(_replace_opt(cmd.good, "--duration", "1e300"), "--duration"),
                    Case(_replace_opt(cmd.good, "--duration", "nan"), "duration")]  # fmt: skip
        if name == "absurd-seed":
            return [
                Case([*cmd.good, "--seed", "-1"], "--seed"),
                Case([*cmd.good, "--seed", str(2**70)], "--seed"),
            ]
        if name == "absurd-sample-time":
            (d / "fast.toml").write_text('base = "bench-0A"\nduration = 1.0\n[gains]\nT_s = 1e-12\n')
            return [Case(_sub(cmd.good, 1, f"{W}/fast.toml"), "would need")]
        (d / "sub.toml").write_text('base = "bench-0A"\nduration = 60.0\nn_sub = 100000000\n')
        return [Case(_sub(cmd.good, 1, f"{W}/sub.toml"), "substeps")]

    make.__name__ = name
    return make


# -- campaign manifests ------------------------------------------------------------
def _manifest(name: str) -> Callable[[Cmd, Path], list[Case] | str]:
    """A campaign directory whose manifest or run file is broken (``te fit`` reads campaigns)."""

    def make(cmd: Cmd, d: Path) -> list[Case] | str:
        if cmd.good[:2] != ["te", "fit"]:
            if cmd.good[:2] == ["te", "evaluate"]:
                return "the model directory is read first; te fit covers the campaign manifest"
            return "reads no campaign"
        import json

        from drivelash.io import Trace, write_trace

        c = d / f"camp-{name}"
        c.mkdir(exist_ok=True)
        from drivelash.io.campaign import AxisBlock
        from drivelash.physics.rack_pinion import RackPinionBench

        run = {"file": "r.parquet", "kind": "load", "load": 1000.0, "velocity": 0.05, "direction": 1}
        manifest: object = {  # the published schema (docs/te-formats.md), everything else valid
            "format": "drivelash.te-campaign",
            "version": 2,
            "source": "imported",
            "axis": AxisBlock.of(RackPinionBench()).model_dump(mode="json"),
            "columns": ["t", "x_T", "theta_m", "torque_m"],
            "runs": [run],
        }
        t = np.arange(500) * 1e-3
        cols = {"t": t, "x_T": 0.05 * t, "theta_m": 2.0 * t, "torque_m": np.sin(t)}
        needle = "r.parquet"
        if name == "manifest-missing-key":
            del run["load"]
            needle = "load"
        elif name == "manifest-list":
            manifest = [run]
            needle = "manifest.json"
        elif name == "manifest-path-escape":
            run["file"] = "../../../../../../etc/hostname"
            needle = "hostname"
        elif name == "manifest-missing-column":
            del cols["x_T"]
            needle = "x_T"
        if not (c / "r.parquet").exists():
            write_trace(Trace(cols), c / "r.parquet")
        if name == "manifest-truncated-run":
            data = (c / "r.parquet").read_bytes()
            (c / "r.parquet").write_bytes(data[: len(data) // 2])
        elif name == "manifest-empty-run":
            (c / "r.parquet").write_bytes(b"")
        (c / "manifest.json").write_text(json.dumps(manifest))
        return [Case(_sub(cmd.good, 2, f"{W}/camp-{name}"), needle)]

    make.__name__ = name
    return make


MANIFEST_CLASSES = (
    "manifest-missing-key",
    "manifest-list",
    "manifest-path-escape",
    "manifest-missing-column",
    "manifest-truncated-run",
    "manifest-empty-run",
)

CLASSES: dict[str, Callable[[Cmd, Path], list[Case] | str]] = {
    **{n: _recording_class(n) for n in _recording_files(Path())},
    **{n: _config_class(n) for n in ("bad-toml", "unknown-key", "missing-key", "wrong-type")},
    "missing-required": _missing_required,
    "unknown-option": _unknown_option,
    "bad-value-type": _bad_value_type,
    "bad-value-range": _bad_value_range,
    "unknown-command": _unknown_command,
    "output-is-input": _output_is_input,
    "output-dir-missing": _output_missing_dir,
    "output-dir-read-only": _output_read_only_dir,
    "output-is-directory": _output_is_directory,
    "unknown-plot-extension": _unknown_plot_extension,
    "foreign-file-no-force": _foreign_file,
    **{n: _absurd(n) for n in ("absurd-duration", "absurd-sample-time", "absurd-substeps", "absurd-seed")},
    **{n: _manifest(n) for n in MANIFEST_CLASSES},
}


# =========================================================================== running
@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("fuzz-ws")
    _build_workspace(d)
    _write_bad_recordings(d)
    return d


def _all_cases(d: Path) -> list[tuple[str, str, int, Case | str]]:
    out = []
    for cname, cmd in COMMANDS.items():
        for klass, make in CLASSES.items():
            if klass in cmd.na:
                out.append((cname, klass, 0, cmd.na[klass]))
                continue
            got = make(cmd, d)
            if isinstance(got, str):
                out.append((cname, klass, 0, got))
                continue
            for i, case in enumerate(got):
                if klass in cmd.xfail:
                    case.xfail = cmd.xfail[klass]
                if cmd.slow or klass in cmd.slow_classes:
                    case.slow = True
                out.append((cname, klass, i, case))
    return out


def _snapshot(d: Path) -> dict[str, str]:
    snap = {}
    for root, dirs, files in os.walk(d):
        for n in dirs:
            snap[os.path.relpath(os.path.join(root, n), d) + "/"] = "dir"
        for n in files:
            p = os.path.join(root, n)
            snap[os.path.relpath(p, d)] = hashlib.sha256(Path(p).read_bytes()).hexdigest()
    return snap


class _Timeout(BaseException):
    pass


def _run_main(argv: list[str], capsys, seconds: int = 120) -> tuple[int, str, str]:
    from drivelash import cli

    def on_alarm(signum, frame):
        raise _Timeout(f"drivelash {' '.join(argv)} did not refuse within {seconds} s")

    old = signal.signal(signal.SIGALRM, on_alarm)
    signal.alarm(seconds)
    # backstop for a hang inside a compiled kernel (no Python bytecode runs, SIGALRM waits):
    # dump the stacks and end the worker rather than hang the suite
    faulthandler.dump_traceback_later(seconds + 30, exit=True, file=sys.__stderr__)
    try:
        cli.main(argv)
        code = 0
    except SystemExit as exc:
        code = int(exc.code or 0) if not isinstance(exc.code, str) else 1
    finally:
        faulthandler.cancel_dump_traceback_later()
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    out, err = capsys.readouterr()
    return code, out, err


def _case_params() -> list:
    import tempfile

    d = Path(tempfile.mkdtemp(prefix="drivelash-fuzz-collect-"))
    try:
        _build_workspace_light(d)
        rows = _all_cases(d)
    finally:
        shutil.rmtree(d, ignore_errors=True)
    params = []
    commands, classes = list(COMMANDS), list(CLASSES)
    for cname, klass, i, case in rows:
        if isinstance(case, str):
            continue
        marks = []
        # the fast subset (make test): every 4th (command, class) pair on a rotation, so each
        # class runs on about a quarter of the commands and each command gets about a quarter
        # of the classes; make test-slow runs every case
        fast = (commands.index(cname) + classes.index(klass)) % 4 == 0
        if case.slow or not fast:
            marks.append(pytest.mark.slow)
        if case.xfail:
            marks.append(pytest.mark.xfail(strict=True, reason=case.xfail))
        params.append(pytest.param(cname, klass, i, id=f"{cname}-{klass}-{i}", marks=marks))
    return params


def _build_workspace_light(d: Path) -> None:
    """Only what the case generators look at (existence of files), for collection."""
    (d / "a_dir.json").mkdir()
    (d / "a_dir.parquet").mkdir()


@pytest.fixture(scope="session")
def fleet_store(tmp_path_factory) -> Path:
    """A one-axis simulated fleet with its store (``simulate fleet`` + ``track ingest``)."""
    from drivelash import cli

    d = tmp_path_factory.mktemp("fuzz-fleet") / "fl"
    for argv in (
        ["simulate", "fleet", "-o", str(d), "--machines", "1", "--axes", "1", "--recordings", "3",
         "--duration", "10"],
        ["track", "ingest", str(d / "fleet.toml"), "--workers", "1"],
    ):  # fmt: skip
        try:
            cli.main(argv)
        except SystemExit as exc:
            assert not exc.code, f"building the fleet store: drivelash {' '.join(argv)}: exit {exc.code}"
    return d


@pytest.mark.parametrize(("cname", "klass", "i"), _case_params())
def test_bad_input_is_one_line_exit_2_and_no_files(
    cname, klass, i, workspace, tmp_path, capsys, monkeypatch, request
):
    work = tmp_path / "w"
    shutil.copytree(workspace, work, symlinks=True)
    if COMMANDS[cname].needs_store and klass in COMMANDS[cname].slow_classes:
        shutil.copytree(request.getfixturevalue("fleet_store"), work / "fl")
    (work / "ro").chmod(0o555)
    case = CLASSES[klass](COMMANDS[cname], work)
    assert not isinstance(case, str)
    case = case[i]
    argv = [a.replace(W, str(work)) for a in case.argv]
    monkeypatch.setenv("DRIVELASH_WARNINGS", "error")
    monkeypatch.chdir(work)
    for k, v in case.env.items():
        monkeypatch.setenv(k, v)
    before = _snapshot(work)
    code, _out, err = _run_main(argv, capsys)
    after = _snapshot(work)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2, f"exit {code}: {err}"
    assert "Traceback" not in err
    assert len(lines) == 1 and lines[0].startswith("drivelash: error: "), err
    assert case.needle.lower() in lines[0].lower(), f"{case.needle!r} not in {lines[0]!r}"
    assert after == before, "files changed: " + ", ".join(
        sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
    )


# =========================================================================== coverage
def _registered() -> list[str]:
    names = []

    def walk(node, path):
        if hasattr(node, "commands"):
            for n, sub in node.commands.items():
                walk(sub, [*path, n])
        else:
            names.append(" ".join(path))

    walk(_click_app(), [])
    return names


def test_every_command_has_a_row():
    missing = [c for c in _registered() if c not in COMMANDS]
    assert not missing, f"add a row to tests/cli/test_fuzz_cli.py COMMANDS for: {', '.join(missing)}"
    stale = [c for c in COMMANDS if c not in _registered()]
    assert not stale, f"rows for commands that no longer exist: {stale}"


def test_coverage_count(workspace, capsys):
    """Every class is applied to every command or has a stated reason; prints the count."""
    rows = _all_cases(workspace)
    cases = [r for r in rows if not isinstance(r[3], str)]
    pairs = {(r[0], r[1]) for r in cases}
    na = [r for r in rows if isinstance(r[3], str)]
    assert all(reason for *_, reason in na)
    with capsys.disabled():
        sys.stderr.write(
            f"\nCLI fuzz harness: {len(CLASSES)} classes x {len(COMMANDS)} commands: "
            f"{len(pairs)} class-command pairs covered by {len(cases)} cases, "
            f"{len(na)} pairs not applicable\n"
        )
    assert len(CLASSES) >= 30 and len(pairs) >= 150


def test_no_arguments_prints_help_and_exits_2(capsys):
    code, out, err = _run_main([], capsys)
    assert code == 2 and "Usage" in out + err and "Traceback" not in err


def test_console_script_usage_error_has_no_traceback(tmp_path):
    """A real process (the console script's entry point): one line, exit 2."""
    import subprocess

    p = subprocess.run(
        [sys.executable, "-c", "from drivelash.cli import main; main()", "estimate", "x.csv"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert p.stderr.strip() == (
        "drivelash: error: Missing option '--config' / '-c'. (try 'drivelash estimate --help')"
    )
