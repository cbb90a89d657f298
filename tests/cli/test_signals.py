"""SIGTERM and SIGKILL at random points of ``simulate -o EXISTING``: never a result a later command takes.

After the signal, the target is either the old complete file or (if the run finished
first) the new complete one — never truncated; a SIGTERM leaves no temporary file, a
SIGKILL only hidden ``….part`` names that no command accepts as a recording.
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from drivelash.errors import DataError
from drivelash.io import Trace, load_trace, write_trace

ENV = {**os.environ, "PYTHONWARNINGS": "ignore"}


@pytest.fixture(autouse=True)
def _ctrl_c_as_in_a_terminal():
    """Python's own Ctrl-C handler in the test process while a test runs, as in a terminal. A
    test run started in the background by a shell without job control (``make test &`` in a
    script) inherits SIGINT ignored; the CLI rightly keeps an ignored SIGINT ignored, and so
    did the commands these tests start (measured: exit 0 instead of 130 in 4 tests). With a
    handler installed here, the children start with SIGINT at its default (exec resets a
    caught signal, not an ignored one)."""
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


def _drivelash(*args: str, cwd: Path) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-c", "from drivelash.cli import main; main()", *args],
        cwd=cwd,
        env=ENV,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


@pytest.fixture(scope="module")
def old_file(tmp_path_factory) -> tuple[Path, dict[str, np.ndarray]]:
    """A complete earlier output of drivelash (signed, so no --force is needed)."""
    d = tmp_path_factory.mktemp("sig")
    t = np.arange(4000) * 125e-6
    cols = {
        "t": t,
        "theta_m": np.sin(2 * np.pi * t),
        "omega_m": 2 * np.pi * np.cos(2 * np.pi * t),
        "torque_m": np.cos(5 * t),
    }
    write_trace(Trace(cols, {"scenario": "old"}), d / "old.parquet")
    return d / "old.parquet", load_trace(d / "old.parquet").columns


def _one_run(tmp_path: Path, old: tuple[Path, dict], sig: int, delay: float) -> str:
    src, old_cols = old
    target = tmp_path / "existing.parquet"
    target.write_bytes(src.read_bytes())
    p = _drivelash("simulate", "bench-0A", "-o", str(target), "--duration", "30", "--seed", "3", cwd=tmp_path)
    time.sleep(delay)
    p.send_signal(sig)
    _, err = p.communicate(timeout=300)
    names = sorted(os.listdir(tmp_path))
    visible = [n for n in names if not n.startswith(".")]
    assert visible == ["existing.parquet"], names
    if sig == signal.SIGTERM:
        assert names == ["existing.parquet"], names  # staging removed
        if p.returncode == -signal.SIGTERM:
            pass  # killed while Python was still importing, before cli.main ran: nothing was staged
        elif p.returncode != 0:
            last = err.strip().splitlines()[-1]
            assert p.returncode == 143 and last == "drivelash: terminated; no output written", err
    for n in names:
        if n.startswith("."):
            with pytest.raises(DataError):  # a killed run's temporary file is refused by every reader
                load_trace(tmp_path / n)
    tr = load_trace(target)  # complete: loads and validates
    if len(tr) == len(old_cols["t"]):
        assert all(np.array_equal(tr[k], old_cols[k]) for k in old_cols), "changed but not replaced"
        return "old"
    assert tr.duration == pytest.approx(30.0, abs=1e-3)
    return "new"


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_signal_during_simulate_keeps_old_file_or_gives_new_one(tmp_path, old_file, sig):
    rng = random.Random(int(sig))
    outcome = _one_run(tmp_path, old_file, sig, rng.uniform(0.5, 3.0))
    assert outcome in ("old", "new")


@pytest.mark.slow
@pytest.mark.parametrize("k", range(12))
def test_signal_at_random_points_of_simulate(tmp_path, old_file, k):
    rng = random.Random(1000 + k)
    sig = (signal.SIGTERM, signal.SIGKILL)[k % 2]
    _one_run(tmp_path, old_file, sig, rng.uniform(0.05, 8.0))


@pytest.mark.parametrize("jit", [False, True], ids=["warm-cache", "while-numba-compiles"])
def test_ctrl_c_during_simulate_one_line_exit_130_existing_output_unchanged(tmp_path, old_file, jit):
    """Ctrl-C (SIGINT) while ``simulate -o EXISTING`` runs: exit 130, exactly one stderr line
    saying no output was written, no traceback, no temporary file, the existing file byte for
    byte as it was. (Before: typer turned the KeyboardInterrupt into a silent exit 130; and
    during numba's first compilation, an empty cache, the interrupt landed in a ctypes
    callback, was printed as "Exception ignored … Traceback" and the run wrote its output.)"""
    src, _ = old_file
    env = dict(ENV)
    if jit:
        env["NUMBA_CACHE_DIR"] = str(tmp_path / "numba-cache")
        tmp_path = tmp_path / "out"
        tmp_path.mkdir()
    target = tmp_path / "existing.parquet"
    target.write_bytes(src.read_bytes())
    before = target.read_bytes()
    # "ready" once the CLI is imported; main() installs its handler right after
    code = "import sys, drivelash.cli as c; sys.stderr.write('ready\\n'); sys.stderr.flush(); c.main()"
    p = subprocess.Popen(
        [sys.executable, "-c", code, "simulate", "bench-0A", "-o", str(target), "--duration", "120"],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert p.stderr.readline() == "ready\n"
    # inside the run: a warm-cache 60 s run took 2.9 s in all on an idle 2-core machine (session 34:
    # the signal at 1.5 s after "ready" then met the exiting interpreter, −2, in a clean-clone
    # make test); 120 s simulated and 0.5 s after "ready" leave margin both ways
    time.sleep(0.5)
    assert p.poll() is None, "the run ended before the signal"
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=300)
    assert p.returncode == 130, err
    assert err.splitlines() == ["drivelash: interrupted; no output written"], err
    assert "Traceback" not in err
    assert sorted(os.listdir(tmp_path)) == ["existing.parquet"]  # no .part left
    assert target.read_bytes() == before


def test_ctrl_c_in_process_is_one_line_whatever_raises_it(tmp_path, capsys, monkeypatch):
    """A KeyboardInterrupt that typer catches itself (raised by code, not by our handler) and
    our Interrupted both give the one line and 130; a command that has already put an output in
    place says which (negative control: that line is not "no output written")."""
    from tests.cli_runner import run_in_process

    import drivelash.io.formats as formats
    from drivelash.cli import Interrupted
    from drivelash.io import outputs

    for exc in (KeyboardInterrupt, Interrupted):

        def boom(*a, _exc=exc, **k):
            raise _exc()

        monkeypatch.setattr(formats, "write_trace", boom)
        code, _, err = run_in_process(
            ["simulate", "bench-0A", "-o", str(tmp_path / "x.parquet"), "--duration", "0.1"], capsys
        )
        assert (code, err.splitlines()) == (130, ["drivelash: interrupted; no output written"]), exc
        assert os.listdir(tmp_path) == []
    monkeypatch.undo()

    real_commit = outputs.Outputs.commit

    def commit_then_interrupt(self):
        real_commit(self)
        raise Interrupted()

    monkeypatch.setattr(outputs.Outputs, "commit", commit_then_interrupt)
    out = tmp_path / "y.parquet"
    code, _, err = run_in_process(["simulate", "bench-0A", "-o", str(out), "--duration", "0.1"], capsys)
    assert code == 130
    assert err.splitlines() == [f"drivelash: interrupted after writing {out}; nothing else written"], err
    assert out.exists()


@pytest.mark.parametrize("busy", [10.0, 0.0], ids=["stopped-in-python-code", "command-ends-first"])
def test_ctrl_c_inside_a_ctypes_callback_still_stops_the_command(tmp_path, capsys, monkeypatch, busy):
    """A Ctrl-C that arrives while C code runs a Python callback (numba's JIT does, through
    ctypes) cannot propagate from there; it is delivered again and stops the command: one line,
    130, no "Exception ignored" traceback, no output. Should the command end before the
    re-delivery, it still exits 130 and the line names the output it wrote. (Before: the stub
    below returned normally, the output was committed, exit 0, and a traceback was printed.)"""
    import ctypes

    from tests.cli_runner import run_in_process

    import drivelash.io.formats as formats

    @ctypes.CFUNCTYPE(None)
    def callback():
        signal.raise_signal(signal.SIGINT)  # the handler raises inside the callback

    def write_trace(*a, **k):
        callback()
        t0 = time.monotonic()
        while time.monotonic() - t0 < busy:  # ordinary Python code, where the signal lands
            pass  # (ended by the re-delivered signal within ~10 ms; 10 s only bounds a failure)

    monkeypatch.setattr(formats, "write_trace", write_trace)
    if not busy:
        # the command ends before the re-delivery: held back here, else the race with the
        # 10 ms timer decides the outcome on a loaded machine (seen under pytest -n 2)
        import drivelash.cli as cli

        monkeypatch.setattr(cli, "_redeliver_later", lambda signum: None)
    out = tmp_path / "x.parquet"
    code, _, err = run_in_process(["simulate", "bench-0A", "-o", str(out), "--duration", "0.1"], capsys)
    if busy:
        assert (code, err.splitlines()) == (130, ["drivelash: interrupted; no output written"]), err
        assert os.listdir(tmp_path) == []
    else:
        line = f"drivelash: interrupted after writing {out}; nothing else written"
        assert (code, err.splitlines()) == (130, [line]), err
