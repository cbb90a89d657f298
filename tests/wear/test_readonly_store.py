"""A store on a read-only mount or directory: one line naming the store and the cause, exit 2.

SQLite alone said "unable to open database file". The directory is made read-only for real:
``chmod`` when not root; as root (who ignores permissions) a read-only bind mount of it onto
itself, else ``chattr +i`` (immutable); the test is skipped only when none of them is possible.
"""

from __future__ import annotations

import os
import shutil
import sqlite3
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

TRACK = ["track"]


def _try(cmd: list[str]) -> bool:
    return (
        shutil.which(cmd[0]) is not None
        and subprocess.run(cmd, capture_output=True, timeout=30).returncode == 0
    )


@contextmanager
def read_only(path: Path) -> Iterator[str]:
    """``path`` (a directory or a file) read-only for this process while in the block; yields
    how ("chmod", "mount" or "chattr")."""
    if os.geteuid() != 0:
        mode = path.stat().st_mode
        path.chmod(0o555 if path.is_dir() else 0o444)
        try:
            yield "chmod"
        finally:
            path.chmod(mode)
        return
    if path.is_dir() and _try(["mount", "--bind", "-o", "ro", str(path), str(path)]):
        try:
            yield "mount"
        finally:
            subprocess.run(["umount", str(path)], check=True, timeout=30)
        return
    if _try(["chattr", "+i", str(path)]):
        try:
            yield "chattr"
        finally:
            subprocess.run(["chattr", "-i", str(path)], check=True, timeout=30)
        return
    pytest.skip("root, and neither a read-only bind mount nor chattr +i is possible here")


def _copy_store(serial_store, dst: Path) -> Path:
    st, _ = serial_store
    dst.parent.mkdir(parents=True, exist_ok=True)
    src = sqlite3.connect(str(st.url.database))
    out = sqlite3.connect(str(dst))
    src.backup(out)
    out.close()
    src.close()
    return dst


def _one_line_error(r) -> str:
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    return lines[0]


RO_CAUSES = ("is on a read-only file system", "is not writable (permission denied)")


def test_ingest_into_a_read_only_directory_names_the_store_and_the_cause(
    small_fleet, serial_store, tmp_path, cli250
):
    d = tmp_path / "ro"
    d.mkdir()
    old = _copy_store(serial_store, d / "old.sqlite")
    before = old.read_bytes()
    with read_only(d):
        for store in (d / "new.sqlite", old):  # a new store, and an existing one
            r = cli250(
                [*TRACK, "ingest", str(small_fleet / "fleet.toml"), "--db", str(store), "--workers", "1"]
            )
            line = _one_line_error(r)
            assert line.startswith(f"drivelash: error: {store}: cannot write the store: directory {d} ")
            assert any(c in line for c in RO_CAUSES) and "nothing was written" in line, line
            assert "unable to open database file" not in line
    assert sorted(p.name for p in d.iterdir()) == ["old.sqlite"] and old.read_bytes() == before
    # negative control: a missing directory keeps its own message
    r = cli250([*TRACK, "ingest", str(small_fleet / "fleet.toml"), "--db", str(d / "no" / "w.sqlite")])
    assert f"directory {d / 'no'} does not exist" in _one_line_error(r)


def test_status_and_report_on_a_store_in_a_read_only_directory_say_why_they_cannot_read(
    serial_store, tmp_path, cli250
):
    """SQLite in WAL mode creates NAME-wal and NAME-shm next to the file to read it: in a
    read-only directory reading is impossible, and the one line says so."""
    d = tmp_path / "ro"
    store = _copy_store(serial_store, d / "wear.sqlite")
    with read_only(d):
        for args in (["status"], ["report", "-o", str(tmp_path / "r.html")]):
            line = _one_line_error(cli250([*TRACK, *args, "--db", str(store)]))
            assert line.startswith(f"drivelash: error: {store}: cannot read the store: directory {d} ")
            assert any(c in line for c in RO_CAUSES) and "wear.sqlite-wal and wear.sqlite-shm" in line
            assert "copy the store to a writable directory" in line
    assert not (tmp_path / "r.html").exists()


def test_a_read_only_store_file_in_a_writable_directory_is_read_but_not_written(
    small_fleet, serial_store, tmp_path, cli250
):
    store = _copy_store(serial_store, tmp_path / "w" / "wear.sqlite")
    full = cli250([*TRACK, "status", "--db", str(store)])
    assert full.returncode == 0, full.stderr
    with read_only(store):
        r = cli250([*TRACK, "status", "--db", str(store)])
        assert r.returncode == 0 and r.stdout == full.stdout, r.stderr
        r = cli250([*TRACK, "ingest", str(small_fleet / "fleet.toml"), "--db", str(store), "--workers", "1"])
        line = _one_line_error(r)
        assert line.startswith(f"drivelash: error: {store}: cannot write the store: the file is read-only")
