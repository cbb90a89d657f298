"""``drivelash.io.outputs``: validation before work, signatures, atomic sets, concurrency."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from drivelash.errors import DataError, OutputError
from drivelash.io import Trace, load_trace, write_trace
from drivelash.io.outputs import (
    DIRECTORY_MARKER,
    GENERATOR,
    JSON_EXTENSIONS,
    PLOT_EXTENSIONS,
    TRACE_EXTENSIONS,
    Outputs,
    dumps_json,
    final_suffix,
    is_own_output,
    is_staging_path,
    write_json,
)


def _trace(n: int = 200) -> Trace:
    t = np.arange(n) * 1e-3
    return Trace(
        {"t": t, "theta_m": np.sin(7 * t), "omega_m": 7 * np.cos(7 * t), "torque_m": np.cos(3 * t)},
        {"scenario": "unit", "x": float("nan")},
    )


def _tree(d: Path) -> dict[str, bytes]:
    """Every file under ``d`` (hidden ones included) with its content."""
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


def _figure():
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(2, 2))
    fig.add_subplot().plot([0, 1], [1, 0])
    return fig


# --------------------------------------------------------------------------- write_json
def test_write_json_is_strict_and_signed(tmp_path):
    doc = {
        "a": float("nan"),
        "b": [np.float32(1.5), np.inf, -np.inf],
        "c": np.arange(3),
        "d": {1: np.int64(7), "p": tmp_path},
        "e": np.bool_(True),
        "generator": "someone else",
    }
    p = write_json(tmp_path / "x.json", doc)
    text = p.read_text()

    def _reject(name):  # json.loads accepts NaN/Infinity unless told otherwise
        raise AssertionError(f"non-strict JSON constant {name}")

    got = json.loads(text, parse_constant=_reject)
    assert list(got)[0] == "generator" and got["generator"] == GENERATOR
    assert got["a"] is None and got["b"] == [1.5, None, None]
    assert got["c"] == [0, 1, 2] and got["d"] == {"1": 7, "p": str(tmp_path)} and got["e"] is True
    assert is_own_output(p)
    # negative control: the standard library writes NaN, which our parse rejects
    with pytest.raises(AssertionError):
        json.loads(json.dumps({"a": float("nan")}), parse_constant=_reject)


def test_dumps_json_refuses_unknown_objects():
    with pytest.raises(TypeError):
        dumps_json({"x": object()})


# --------------------------------------------------------------------------- signatures
@pytest.mark.parametrize("ext", [".csv", ".parquet", ".h5", ".mat", ".mat73"])
def test_traces_we_write_are_signed_and_foreign_ones_are_not(tmp_path, ext):
    tr = _trace()
    if ext == ".mat73":
        p = write_trace(tr, tmp_path / "x.mat", fmt="mat73")
    else:
        p = write_trace(tr, tmp_path / f"x{ext}")
    assert is_own_output(p)
    foreign = tmp_path / f"foreign{p.suffix}"
    df = tr.to_pandas()
    if ext == ".csv":
        df.to_csv(foreign, index=False)
    elif ext == ".parquet":
        df.to_parquet(foreign)
    elif ext == ".h5":
        import h5py

        with h5py.File(foreign, "w") as f:
            f["t"] = tr["t"]
    elif ext == ".mat":
        import scipy.io

        scipy.io.savemat(foreign, {"t": tr["t"]})
    else:  # an HDF5 file with a MATLAB 7.3 header, written by someone else
        import h5py

        with h5py.File(foreign, "w", userblock_size=512) as f:
            f["t"] = tr["t"]
        with foreign.open("r+b") as fh:
            fh.write(b"MATLAB 7.3 MAT-file".ljust(128, b" "))
    assert not is_own_output(foreign)


@pytest.mark.parametrize("ext", PLOT_EXTENSIONS)
def test_save_figure_signs_plots(tmp_path, ext):
    from drivelash.report import save_figure

    fig = _figure()
    ours = save_figure(fig, tmp_path / f"a{ext}")
    assert is_own_output(ours)
    fig.savefig(tmp_path / f"b{ext}")  # plain matplotlib: not ours
    assert not is_own_output(tmp_path / f"b{ext}")


def test_html_report_and_toml_fragment_are_signed(tmp_path):
    from drivelash.io.config import drivetrain_fragment
    from drivelash.report.html import Section, render_html

    (tmp_path / "r.html").write_text(render_html("t", [Section("s", paragraphs=["p"])]))
    assert is_own_output(tmp_path / "r.html")
    (tmp_path / "u.html").write_text("<html><head></head></html>")
    assert not is_own_output(tmp_path / "u.html")
    (tmp_path / "d.toml").write_text(drivetrain_fragment({"J_m": 1.0}, ["drivelash identify x"]))
    assert is_own_output(tmp_path / "d.toml")
    (tmp_path / "e.toml").write_text("[drivetrain]\nJ_m = 1.0\n")
    assert not is_own_output(tmp_path / "e.toml")
    (tmp_path / "plain.json").write_text('{"a": 1, "generator": "drivelash"}')  # not first: not ours
    assert not is_own_output(tmp_path / "plain.json")


# --------------------------------------------------------------------------- validation
def test_refusals_name_option_path_and_problem(tmp_path):
    inp = tmp_path / "run.parquet"
    write_trace(_trace(), inp)
    (tmp_path / "adir").mkdir()
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    (tmp_path / "user.json").write_text('{"mine": 1}')
    (tmp_path / "model").mkdir()
    (tmp_path / "model" / "model.json").write_text("{}")
    os.link(inp, tmp_path / "hard.parquet")
    (tmp_path / "sym.json").symlink_to(inp)
    cases = [
        ("--json", tmp_path / "missing" / "x.json", "does not exist"),
        ("--json", inp / "x.json", "is not a directory"),
        ("--json", ro / "x.json", "is not writable"),
        ("--json", tmp_path / "adir", "unsupported extension"),
        ("--plot", tmp_path / "adir.png", None),  # fine (does not exist)
        ("--plot", tmp_path / "p.txt", "unsupported extension '.txt' (use .png, .pdf, .svg)"),
        ("--plot", inp, "unsupported extension '.parquet'"),
        ("--json", tmp_path / "run.json", None),
        ("-o", inp, "is an input of this command; choose another path"),
        ("-o", tmp_path / "hard.parquet", "is an input of this command"),
        ("--json", tmp_path / "user.json", "not a drivelash output; use --force"),
        ("--json", tmp_path / "model" / "out.json", "is inside the input directory"),
        ("--json", tmp_path / ".x.json.drivelash-1-ab.part", "reserved"),
    ]
    for option, path, problem in cases:
        kinds = {"--json": JSON_EXTENSIONS, "--plot": PLOT_EXTENSIONS, "-o": TRACE_EXTENSIONS}[option]
        with Outputs("t", inputs=[inp, tmp_path / "model"]) as out:
            if problem is None:
                assert out.file(path, option=option, kinds=kinds) is not None
                continue
            with pytest.raises(OutputError) as ei:
                out.file(path, option=option, kinds=kinds)
        msg = str(ei.value)
        assert "\n" not in msg and msg.startswith(f"{option} {path}: ") and problem in msg, msg
    # a directory where a file is expected
    (tmp_path / "d.json").mkdir()
    with pytest.raises(OutputError, match="is a directory"), Outputs() as out:
        out.file(tmp_path / "d.json", option="--json", kinds=JSON_EXTENSIONS)
    # a symlink to an input is the input
    with pytest.raises(OutputError, match="is an input"), Outputs(inputs=[inp]) as out:
        out.file(tmp_path / "sym.json", option="--json", kinds=JSON_EXTENSIONS)
    # a device is never a target
    with pytest.raises(OutputError, match="not a regular file"), Outputs() as out:
        out.file("/dev/null", option="--json")
    # two outputs of one command
    with pytest.raises(OutputError, match="is also the output of --json"), Outputs() as out:
        out.file(tmp_path / "a.json", option="--json")
        out.file(tmp_path / "adir" / ".." / "a.json", option="--report")
    assert sorted(os.listdir(ro)) == []


def test_allow_inside_opens_a_subdirectory_of_an_input_directory(tmp_path):
    model = tmp_path / "model"
    (model / "evaluation").mkdir(parents=True)
    with Outputs(inputs=[model], allow_inside=[model / "evaluation"]) as out:
        out.directory(model / "evaluation", option="-o")
        with pytest.raises(OutputError, match="inside the input directory"):
            out.file(model / "model.json", option="--json")


def test_existing_files_replaced_only_when_ours_or_forced(tmp_path):
    user = tmp_path / "out.json"
    user.write_text('{"precious": true}')
    with pytest.raises(OutputError), Outputs() as out:
        out.file(user, option="--json")
    assert user.read_text() == '{"precious": true}'
    with Outputs(force=True) as out:
        write_json(out.staging(out.file(user, option="--json")), {"v": 1})
    assert json.loads(user.read_text())["v"] == 1
    with Outputs() as out:  # now it is ours: no --force needed
        write_json(out.staging(out.file(user, option="--json")), {"v": 2})
    assert json.loads(user.read_text())["v"] == 2


# --------------------------------------------------------------------------- atomic set
def test_exception_leaves_targets_as_they_were_and_no_litter(tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.csv"
    write_json(a, {"v": "old"})
    write_trace(_trace(), b)
    before = _tree(tmp_path)
    with pytest.raises(RuntimeError), Outputs() as out:
        ja, jb = out.file(a, option="--json"), out.file(b, option="-o")
        write_json(out.staging(ja), {"v": "new"})
        stage = out.staging(jb)
        assert is_staging_path(stage) and stage.name.startswith(".b.csv.drivelash-")
        assert final_suffix(stage) == ".csv"
        write_trace(_trace(50), stage)
        raise RuntimeError("plot failed")
    assert _tree(tmp_path) == before


def test_staging_names_are_not_accepted_as_recordings(tmp_path):
    with Outputs() as out:
        t = out.file(tmp_path / "x.parquet", option="-o")
        s = out.staging(t)
        write_trace(_trace(), s)
        with pytest.raises(DataError, match="unsupported file type '.part'"):
            load_trace(s)
    assert load_trace(tmp_path / "x.parquet").names[0] == "t"


def test_only_staged_outputs_are_written(tmp_path):
    with Outputs() as out:
        out.file(tmp_path / "never.json", option="--json")
        write_json(out.staging(out.file(tmp_path / "yes.json", option="--x")), {})
    assert sorted(os.listdir(tmp_path)) == ["yes.json"]


@pytest.mark.parametrize("exchange", [True, False], ids=["renameat2", "two-renames"])
def test_directory_swapped_in_whole(tmp_path, monkeypatch, exchange):
    from drivelash.io import outputs as mod

    if not exchange:
        monkeypatch.setattr(mod, "_exchange", lambda a, b: False)
    d = tmp_path / "camp"
    with Outputs("c") as out:
        s = out.staging(out.directory(d, option="-o"))
        (s / "run1.csv").write_text("old")
        (s / "run2.csv").write_text("old")
    assert (d / DIRECTORY_MARKER).is_file() and is_own_output(d)
    with Outputs("c") as out:
        s = out.staging(out.directory(d, option="-o"))
        (s / "run1.csv").write_text("new")
    assert sorted(os.listdir(d)) == [DIRECTORY_MARKER, "run1.csv"]  # no file of the old set
    assert sorted(os.listdir(tmp_path)) == ["camp"]  # old copy removed, no litter
    # failure during the work: old directory intact
    before = _tree(tmp_path)
    with pytest.raises(KeyError), Outputs("c") as out:
        s = out.staging(out.directory(d, option="-o"))
        (s / "run1.csv").write_text("half")
        raise KeyError("x")
    assert _tree(tmp_path) == before


def test_directory_refusals(tmp_path, monkeypatch):
    user = tmp_path / "photos"
    user.mkdir()
    (user / "cat.jpg").write_bytes(b"x")
    inp = tmp_path / "data" / "run.csv"
    inp.parent.mkdir()
    inp.write_text("t\n1\n")
    with pytest.raises(OutputError, match="not a drivelash output; use --force"), Outputs() as out:
        out.directory(user, option="-o")
    with pytest.raises(OutputError, match="contains .*run.csv, an input"), Outputs(inputs=[inp]) as out:
        out.directory(tmp_path / "data", option="-o")
    monkeypatch.chdir(user)
    with pytest.raises(OutputError, match="contains the current directory"), Outputs(force=True) as out:
        out.directory(tmp_path, option="-o")
    with pytest.raises(OutputError, match="exists and is not a directory"), Outputs() as out:
        out.directory(inp, option="-o")
    assert (user / "cat.jpg").read_bytes() == b"x"
    (tmp_path / "empty").mkdir()  # an empty directory holds nothing to lose
    with Outputs() as out:
        out.directory(tmp_path / "empty", option="-o")


def test_stale_staging_of_dead_processes_is_swept(tmp_path):
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True)
    pid = int(dead.stdout)
    stale = tmp_path / f".a.json.drivelash-{pid}-abc.part"
    stale.write_text("half")
    live = tmp_path / f".a.json.drivelash-{os.getppid()}-abc.part"
    live.write_text("running")
    other = tmp_path / f".b.json.drivelash-{pid}-abc.part"
    other.write_text("other target")
    with Outputs() as out:
        write_json(out.staging(out.file(tmp_path / "a.json", option="--json")), {})
    assert not stale.exists() and live.exists() and other.exists()


# --------------------------------------------------------------------------- concurrency
_WRITER = textwrap.dedent(
    """
    import random, sys, time
    from pathlib import Path
    from drivelash.io.outputs import Outputs, write_json
    d, me, n = Path(sys.argv[1]), sys.argv[2], int(sys.argv[3])
    rng = random.Random(me)
    for i in range(n):
        with Outputs("w") as out:
            a = out.file(d / "a.json", option="--json")
            b = out.file(d / "b.csv", option="--csv")
            write_json(out.staging(a), {"who": me, "i": i})
            with out.staging(b).open("w") as fh:
                fh.write("# drivelash test\\n")
                for k in range(200):
                    fh.write(f"{me},{i},{k}\\n")
                    if k % 50 == 0:
                        fh.flush()
                        time.sleep(rng.random() * 1e-3)
    """
)


def test_two_processes_commit_whole_sets_never_mixed(tmp_path):
    import fcntl

    procs = [
        subprocess.Popen([sys.executable, "-c", _WRITER, str(tmp_path), who, "25"]) for who in ("p1", "p2")
    ]
    seen = set()
    while any(p.poll() is None for p in procs):
        fd = os.open(tmp_path, os.O_RDONLY)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)  # a reader taking the same lock sees whole sets
            if (tmp_path / "a.json").exists():
                a = json.loads((tmp_path / "a.json").read_text())
                rows = (tmp_path / "b.csv").read_text().splitlines()[1:]
                assert len(rows) == 200 and {r.rsplit(",", 1)[0] for r in rows} == {f"{a['who']},{a['i']}"}
                seen.add(a["who"])
        finally:
            os.close(fd)
    assert [p.returncode for p in procs] == [0, 0] and seen
    a = json.loads((tmp_path / "a.json").read_text())
    rows = (tmp_path / "b.csv").read_text().splitlines()[1:]
    assert {r.rsplit(",", 1)[0] for r in rows} == {f"{a['who']},{a['i']}"} and a["i"] == 24
    assert sorted(os.listdir(tmp_path)) == ["a.json", "b.csv"]


# --------------------------------------------------------------------------- which command
def _write_kind(out: Outputs, target: Path) -> None:
    from drivelash.report import save_figure
    from drivelash.report.html import Section, render_html

    stage = out.staging(target)
    if target.suffix == ".json":
        write_json(stage, {"v": 1})
    elif target.suffix == ".html":
        stage.write_text(render_html("t", [Section("s", paragraphs=["p"])]), encoding="utf-8")
    else:
        save_figure(_figure(), stage)


@pytest.mark.parametrize("name", ["a.json", "r.html", "p.png", "p.pdf", "p.svg"])
def test_another_commands_output_is_replaced_only_with_force(tmp_path, name):
    """Finding: ``iso230 --json est.json`` silently replaced an ``estimate`` result."""
    from drivelash.io.outputs import output_command

    target = tmp_path / name
    with Outputs("estimate") as out:
        _write_kind(out, out.file(target, option="--json"))
    assert output_command(target) == "estimate" and is_own_output(target)
    before = target.read_bytes()
    with pytest.raises(OutputError) as ei, Outputs("iso230") as out:
        out.file(target, option="--json")
    msg = str(ei.value)
    assert "\n" not in msg and msg.startswith(f"--json {target}: ")
    assert "written by 'drivelash estimate'" in msg and "--force" in msg
    assert target.read_bytes() == before
    with Outputs("estimate") as out:  # negative control: the same command re-runs freely
        _write_kind(out, out.file(target, option="--json"))
    with Outputs("iso230", force=True) as out:
        _write_kind(out, out.file(target, option="--json"))
    assert output_command(target) == "iso230"


def test_signed_output_without_recorded_command_needs_force(tmp_path):
    """A drivelash JSON written before the command was recorded may be any command's."""
    legacy = tmp_path / "est.json"
    legacy.write_text('{\n  "generator": "drivelash 0.1.0",\n  "delta": 0.105\n}\n')
    with pytest.raises(OutputError, match="does not record which command wrote it .*; use --force"):
        with Outputs("iso230") as out:
            out.file(legacy, option="--json")
    assert json.loads(legacy.read_text())["delta"] == 0.105
    # kinds that never record the command (recordings) stay replaceable as before
    rec = tmp_path / "run.parquet"
    write_trace(_trace(), rec)
    with Outputs("simulate") as out:
        assert out.file(rec, option="-o") is not None


@pytest.mark.parametrize("name", ["run.parquet", "run.csv", "run.h5", "run.mat"])
def test_a_recording_records_its_command_and_another_command_needs_force(tmp_path, name):
    """Session 13's left-alone item: ``simulate -o`` replaced ``observe -o``'s recording silently.

    Both writers (:func:`write_trace` and the chunked :class:`TraceWriter`) record the command
    in the metadata's ``generator``; a reader does not put it into ``Trace.meta``.
    """
    from drivelash.io.formats import TraceWriter
    from drivelash.io.outputs import output_command

    tr = _trace()
    target = tmp_path / name
    with Outputs("observe") as out:
        t = out.file(target, option="--out")
        with TraceWriter(out.staging(t), tr.names, len(tr), dict(tr.meta)) as w:
            w.write(tr.columns)
    assert output_command(target) == "observe"
    assert "generator" not in load_trace(target).meta
    before = target.read_bytes()
    with pytest.raises(OutputError, match="written by 'drivelash observe'.*--force"):
        with Outputs("simulate") as out:
            out.file(target, option="-o")
    assert target.read_bytes() == before
    with Outputs("simulate", force=True) as out:
        write_trace(tr, out.staging(out.file(target, option="-o")))
    assert output_command(target) == "simulate"
    with Outputs("simulate") as out:  # negative control: the same command re-runs freely
        write_trace(tr, out.staging(out.file(target, option="-o")))
    # a library write records no command: any command may replace it, as before
    write_trace(tr, target)
    assert output_command(target) == ""


def test_an_oserror_while_writing_names_the_output_and_others_pass_through(tmp_path, monkeypatch):
    """A write failure is one line naming the option and the path as given; the targets stay.

    Matched by the file name (a file inside a staged directory) or, without one, by a
    write errno (the output staged last); an ``OSError`` of another file is not an output's.
    """
    import errno

    keep = tmp_path / "model"
    with Outputs("te fit") as out:
        write_json(out.staging(out.directory(keep, option="-o")) / "model.json", {"v": 1})
    before = _tree(tmp_path)
    with pytest.raises(OutputError) as ei, Outputs("te fit") as out:
        d = out.staging(out.directory(keep, option="-o"))
        raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(d / "weights.bin"))
    assert str(ei.value) == (
        f"-o {keep}: cannot write it: Permission denied; the existing files were left as they were"
    )
    with pytest.raises(OutputError, match=r"^--json a\.json: cannot write it: Disk quota exceeded;"):
        with Outputs() as out:
            monkeypatch.chdir(tmp_path)
            out.staging(out.file("b.json", option="--plot"))
            out.staging(out.file("a.json", option="--json"))  # staged last: the one being written
            raise OSError(errno.EDQUOT, os.strerror(errno.EDQUOT))
    with pytest.raises(FileNotFoundError), Outputs() as out:  # reading an input: not an output's
        out.staging(out.file(tmp_path / "c.json", option="--json"))
        raise FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), str(tmp_path / "in.csv"))
    assert _tree(tmp_path) == before


@pytest.mark.parametrize("exchange", [True, False], ids=["renameat2", "two-renames"])
def test_a_rename_failing_half_way_through_the_commit_puts_the_set_back(tmp_path, monkeypatch, exchange):
    """``estimate --json a.json --plot p.png`` with p.png immutable (``chattr +i``): a.json was
    already replaced when p.png's rename failed — a mixed set, and a traceback. Now the outputs
    renamed before the failure are put back (files, a new file, a directory) and no temporary
    name is left."""
    import errno

    import drivelash.io.outputs as outputs_mod

    if not exchange:
        monkeypatch.setattr(outputs_mod, "_exchange", lambda a, b: False)
    d, a, last = tmp_path / "model", tmp_path / "a.json", tmp_path / "z.json"
    with Outputs("x") as out:
        write_json(out.staging(out.directory(d, option="-o")) / "m.json", {"v": "old"})
        write_json(out.staging(out.file(a, option="--json")), {"v": "old"})
        write_json(out.staging(out.file(last, option="--last")), {"v": "old"})
    before = _tree(tmp_path)
    real_replace = os.replace

    def replace(src, dst):
        if Path(dst) == last and outputs_mod.is_staging_path(src):
            raise PermissionError(errno.EPERM, os.strerror(errno.EPERM), os.fspath(dst))
        real_replace(src, dst)

    monkeypatch.setattr(outputs_mod.os, "replace", replace)
    real_link = os.link

    def link(src, dst, **k):  # the last target cannot be linked (as an immutable file), the rest can
        if Path(src) == last:
            raise PermissionError(errno.EPERM, os.strerror(errno.EPERM), os.fspath(src))
        real_link(src, dst, **k)

    monkeypatch.setattr(outputs_mod.os, "link", link)
    with pytest.raises(OutputError) as ei, Outputs("x") as out:
        write_json(out.staging(out.directory(d, option="-o")) / "m.json", {"v": "new"})
        write_json(out.staging(out.file(a, option="--json")), {"v": "new"})
        write_json(out.staging(out.file(tmp_path / "new.json", option="--new")), {"v": "new"})
        write_json(out.staging(out.file(last, option="--last")), {"v": "new"})
    assert str(ei.value) == (
        f"--last {last}: cannot write it: Operation not permitted; the existing files were left as they were"
    )
    assert _tree(tmp_path) == before


def test_a_name_too_long_for_its_temporary_name_is_refused_before_any_work(tmp_path):
    """``simulate -o <240 chars>.csv`` ended, after the whole simulation, in a traceback
    (ENAMETOOLONG creating ``.NAME.drivelash-PID-RAND.part``); 260 chars the same."""
    from drivelash.io.outputs import STAGE_NAME_OVERHEAD

    limit = os.pathconf(tmp_path, "PC_NAME_MAX") - STAGE_NAME_OVERHEAD
    ok = tmp_path / ("a" * (limit - 4) + ".csv")
    with Outputs("simulate") as out:
        write_trace(_trace(), out.staging(out.file(ok, option="-o")))
    assert ok.is_file()
    for n in (limit + 1, 260):
        bad = tmp_path / ("b" * (n - 4) + ".csv")
        with pytest.raises(OutputError) as ei, Outputs("simulate") as out:
            out.file(bad, option="-o")
        assert str(ei.value) == (
            f"-o {bad}: file name too long ({n} bytes; at most {limit} here: it is first written under"
            f" a temporary name {STAGE_NAME_OVERHEAD} bytes longer, and the file system allows {limit + 33})"
        )
    assert sorted(os.listdir(tmp_path)) == [ok.name]


def test_a_dangling_symlink_at_an_output_is_named_as_one(tmp_path):
    """``--json link.json`` with link.json → a missing file: "an existing file that is not a
    drivelash output" (there is no file); with ``--force`` the link is replaced, nothing else."""
    link = tmp_path / "link.json"
    link.symlink_to("gone/x.json")
    with pytest.raises(OutputError) as ei, Outputs("estimate") as out:
        out.file(link, option="--json")
    assert str(ei.value) == (
        f"--json {link}: a symbolic link to gone/x.json, which does not exist; use --force to replace it"
        " or choose another path"
    )
    assert os.readlink(link) == "gone/x.json"
    with Outputs("estimate", force=True) as out:
        write_json(out.staging(out.file(link, option="--json")), {"v": 1})
    assert not link.is_symlink() and json.loads(link.read_text())["v"] == 1


def test_an_output_named_by_a_symlink_is_written_through_it(tmp_path):
    """``--json link.json`` with link.json → a file in another directory: the file there is
    replaced (atomically, in its own directory), the link stays a link to it; the same for a
    chain of links, a library write and a directory output. Before: the link was replaced by a
    regular file and the file it pointed to was left as it was."""
    here, there = tmp_path / "here", tmp_path / "there"
    here.mkdir()
    there.mkdir()
    real = there / "real.json"
    with Outputs("estimate") as out:
        write_json(out.staging(out.file(real, option="--json")), {"v": 1})
    link = here / "link.json"
    link.symlink_to(os.path.relpath(real, here))
    chain = here / "chain.json"
    chain.symlink_to("link.json")

    for k, name in enumerate([link, chain], start=2):
        with Outputs("estimate") as out:
            target = out.file(name, option="--json")
            assert target == real
            write_json(out.staging(target), {"v": k})
        assert json.loads(real.read_text())["v"] == k
        assert link.is_symlink() and os.readlink(link) == os.path.relpath(real, here)
        assert chain.is_symlink() and os.readlink(chain) == "link.json"
        assert sorted(os.listdir(here)) == ["chain.json", "link.json"]  # no litter next to the link
        assert sorted(os.listdir(there)) == ["real.json"]  # nor next to the target
    write_json(link, {"v": 9})  # a library call: the one writer's same rule
    assert link.is_symlink() and json.loads(real.read_text())["v"] == 9

    # a directory output named by a link
    camp = there / "camp"
    with Outputs("c") as out:
        (out.staging(out.directory(camp, option="-o")) / "a.csv").write_text("old")
    dlink = here / "camp"
    dlink.symlink_to(camp)
    with Outputs("c") as out:
        assert out.directory(dlink, option="-o") == camp
        (out.staging(camp) / "a.csv").write_text("new")
    assert dlink.is_symlink() and (camp / "a.csv").read_text() == "new"
    assert sorted(os.listdir(there)) == ["camp", "real.json"]


def test_a_symlink_output_keeps_the_checks_of_its_target(tmp_path):
    """Written through, a link's target is what is checked: a user's file there needs --force
    (then it is replaced, the link kept); a target in a read-only directory is one line naming
    the link and that directory, before any work; a link to an input is the input."""
    here, there = tmp_path / "here", tmp_path / "there"
    here.mkdir()
    there.mkdir()
    user = there / "notes.json"
    user.write_text('{"precious": true}')
    link = here / "link.json"
    link.symlink_to(user)
    with pytest.raises(OutputError, match="not a drivelash output; use --force"), Outputs("e") as out:
        out.file(link, option="--json")
    assert user.read_text() == '{"precious": true}'
    with Outputs("e", force=True) as out:
        write_json(out.staging(out.file(link, option="--json")), {"v": 1})
    assert link.is_symlink() and json.loads(user.read_text())["v"] == 1

    os.chmod(there, 0o555)
    try:
        with pytest.raises(OutputError) as ei, Outputs("e", force=True) as out:
            out.file(link, option="--json")
        assert str(ei.value) == (
            f"--json {link}: a symbolic link to {user}, whose directory {there} is not writable"
        )
    finally:
        os.chmod(there, 0o755)
    with pytest.raises(OutputError, match="is an input"), Outputs("e", inputs=[user]) as out:
        out.file(link, option="--json")
