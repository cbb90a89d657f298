"""Ctrl-C pressed twice during a parallel ``track ingest``: it stops at once, in one line.

Session 19's tester: the second Ctrl-C reached the pool workers inside the pool's queue
machinery, one waited for ever on a lock the other held, and the command — which had already
printed its "interrupted" line — hung in the interpreter's exit (3 of 3 times; gdb: Py_Exit →
atexit → waitpid). Now the workers ignore SIGINT and the pool is cancelled and terminated when
the stop passes through it (``drivelash._pool``), and a second signal during that clean-up is
not raised into it (``drivelash.cli.STOP_AGAIN_AFTER_S``).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from drivelash.wear import Store

from .conftest import copy_fleet

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc (Linux)")


def _session(sid: int) -> list[int]:
    """Processes of session ``sid`` (from /proc)."""
    out = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            stat = (d / "stat").read_text()
        except OSError:
            continue
        fields = stat.rsplit(")", 1)[1].split()
        if int(fields[3]) == sid and fields[0] != "Z":  # session id; a zombie is already gone
            out.append(int(d.name))
    return out


def _default_sigint() -> None:
    """In the child: SIGINT at its default, as in a terminal (a test runner may ignore it), and
    a session of its own, so that the whole group gets the signal as from a terminal's Ctrl-C."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    os.setsid()


@pytest.mark.parametrize("presses", [1, 2])
def test_ctrl_c_during_a_parallel_ingest_stops_it_at_once(small_fleet, tmp_path, presses):
    fleet = copy_fleet(small_fleet, tmp_path / "fleet")
    db = tmp_path / "w.sqlite"
    p = subprocess.Popen(
        [sys.executable, "-m", "drivelash.cli", "track", "ingest", str(fleet / "fleet.toml"), "--db", str(db)]
        + ["--workers", "2"],
        env={**os.environ, "PYTHONWARNINGS": "ignore"},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_default_sigint,
    )
    try:
        deadline = time.monotonic() + 240
        while len(_session(p.pid)) < 3:  # the command and its two pool workers
            assert p.poll() is None and time.monotonic() < deadline, p.communicate()
            time.sleep(0.05)
        time.sleep(1.0)  # the workers estimate
        assert p.poll() is None, "the ingest ended before the signal"
        for k in range(presses):
            os.killpg(p.pid, signal.SIGINT)  # a terminal's Ctrl-C reaches the whole group
            if k + 1 < presses:
                time.sleep(0.5)
        _, err = p.communicate(timeout=120)  # before: TimeoutExpired after two presses (a hang)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()
    # 130; or, when the second press lands after the command has stopped and printed its line
    # (the interpreter exiting, Python's own handler back), death by SIGINT — which a shell
    # reports as 130 too
    assert p.returncode == 130 or (presses == 2 and p.returncode == -signal.SIGINT), (p.returncode, err)
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("drivelash: interrupted"), err  # no blank line
    assert "nothing else written" in lines[0] or "no output written" in lines[0], err
    for _ in range(100):  # the workers are gone with the command (terminated, not orphaned)
        if not _session(p.pid):
            break
        time.sleep(0.05)
    assert _session(p.pid) == []
    # the store is intact: SQLite's own check, and it opens at its schema
    import sqlite3

    with sqlite3.connect(db) as c:
        assert c.execute("PRAGMA integrity_check").fetchone() == ("ok",)
    Store(db, create=False).close()
