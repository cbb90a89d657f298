"""Operational failures of the store: a lock held by another writer, a full disk, two first
ingests at once. Each is one line naming the store, exit 2, nothing half-written."""

from __future__ import annotations

import json
import math
import os
import shutil
import sqlite3
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
import sqlalchemy as sa

from drivelash.wear.store import Store, StoreError

from .conftest import ingest_cmd, ingest_here

#: One machine, two axes, three short recordings each: enough for two batches and a trend.
TINY = {"machines": 1, "axes": 2, "recordings": 3, "seed": 7, "duration": 4.0}


@pytest.fixture(scope="module")
def tiny_fleet(tmp_path_factory) -> Path:
    """A tiny clean simulated fleet (no corrupt recordings: a good ingest exits 0)."""
    from drivelash.sim.fleet import simulate_fleet

    out = tmp_path_factory.mktemp("tiny") / "fleet"
    simulate_fleet(out, **{k: v for k, v in TINY.items() if k != "duration"}, duration=TINY["duration"])
    truth = json.loads((out / "truth.json").read_text())
    for ax in truth["axes"].values():
        for rec in ax["recordings"]:
            if rec["corrupt"]:
                (out / rec["file"]).unlink()
    assert len(_files(out)) >= 4
    return out


def _files(fleet: Path) -> list[Path]:
    return sorted((fleet / "recordings").rglob("*.parquet"))


def _fleet_copy(src: Path, dst: Path, hold_back: int = 0) -> tuple[Path, list[tuple[Path, Path]]]:
    """A private copy of the fleet; ``hold_back`` recordings of M01/X moved aside (to add later)."""
    shutil.copytree(src, dst)
    held = []
    files = sorted((dst / "recordings").rglob("M01-X_*"))
    for p in files[len(files) - hold_back :] if hold_back else []:
        aside = dst / (p.name + ".held")
        p.rename(aside)
        held.append((aside, p))
    return dst, held


def _ingested_with_two_new(cli, tiny_fleet: Path, tmp_path: Path, capsys) -> tuple[Path, list[str], Any]:
    """A store of the fleet ingested without two M01/X recordings, which are then put back: the
    next ``track ingest`` (the returned arguments) has two new recordings to store. Returns the
    store, the arguments and its rows before that ingest (:func:`_state`)."""
    fleet, held = _fleet_copy(tiny_fleet, tmp_path / "f", hold_back=2)
    db = tmp_path / "w.sqlite"
    args = ["track", "ingest", str(fleet / "fleet.toml"), "--db", str(db), "--workers", "1"]
    assert _main(cli, args) == 0
    for aside, p in held:
        aside.rename(p)
    before = _state(db)
    capsys.readouterr()
    return db, args, before


def _state(db: Path) -> tuple[list[tuple], list[tuple]]:
    """Every row of the recording and estimate tables (what must stay as it was)."""
    with sqlite3.connect(db) as c:
        rec = c.execute("SELECT id, axis_id, content_hash, path FROM recording ORDER BY id").fetchall()
        est = c.execute("SELECT id, recording_id, status, delta FROM estimate ORDER BY id").fetchall()
    return rec, est


def _one_error_line(stderr: str) -> str:
    lines = [x for x in stderr.strip().splitlines() if x.strip()]
    assert "Traceback" not in stderr, stderr
    assert len(lines) == 1 and lines[0].startswith("drivelash: error: "), stderr
    return lines[0]


def _run(args: list[str], **env: str) -> subprocess.CompletedProcess:
    return subprocess.run(args, capture_output=True, text=True, timeout=300, env={**os.environ, **env})


def test_ingest_while_another_writer_holds_the_lock_is_one_line_and_writes_nothing(
    tiny_fleet, tmp_path, capsys
):
    fleet, held = _fleet_copy(tiny_fleet, tmp_path / "f", hold_back=1)
    db = tmp_path / "w.sqlite"
    r = ingest_here(fleet / "fleet.toml", db, capsys)
    assert r.returncode == 0, r.stderr
    for aside, p in held:  # a new recording to store
        aside.rename(p)
    before = _state(db)
    other = sqlite3.connect(db, isolation_level=None)  # another writer holding the write lock
    other.execute("BEGIN IMMEDIATE")
    try:
        t0 = time.monotonic()
        r = _run(ingest_cmd(fleet / "fleet.toml", db), DRIVELASH_STORE_BUSY_TIMEOUT="1")
        waited = time.monotonic() - t0
    finally:
        other.execute("ROLLBACK")
        other.close()
    assert r.returncode == 2, r.stderr
    line = _one_error_line(r.stderr)
    assert f"{db}: database is locked by another writer for more than 1 s" in line
    assert "nothing of this ingest was written" in line and "run it again" in line
    assert waited < 60  # the lowered timeout was used, not 30 s per statement
    assert _state(db) == before
    # readers in WAL mode are not blocked by a writer, and once it is gone the ingest resumes
    r = ingest_here(fleet / "fleet.toml", db, capsys)
    assert r.returncode == 0, r.stderr
    rec, est = _state(db)
    assert rec[: len(before[0])] == before[0] and len(rec) == len(before[0]) + 1 and len(est) == len(rec)


def test_readers_hitting_a_lock_say_so_in_one_line(tiny_fleet, tmp_path, capsys):
    fleet, _ = _fleet_copy(tiny_fleet, tmp_path / "f")
    db = tmp_path / "w.sqlite"
    r = ingest_here(fleet / "fleet.toml", db, capsys)
    assert r.returncode == 0, r.stderr
    # a writer in exclusive locking mode keeps even WAL readers out
    other = sqlite3.connect(db, isolation_level=None)
    other.execute("PRAGMA locking_mode=EXCLUSIVE")
    other.execute("BEGIN EXCLUSIVE")
    other.execute("UPDATE axis SET horizon_days = horizon_days")
    try:
        cli = [sys.executable, "-m", "drivelash.cli", "track"]
        runs = {
            "status": _run([*cli, "status", "--db", str(db)], DRIVELASH_STORE_BUSY_TIMEOUT="0.5"),
            "forecast": _run(
                [*cli, "forecast", "M01/X", "--db", str(db), "--json", str(tmp_path / "f.json")],
                DRIVELASH_STORE_BUSY_TIMEOUT="0.5",
            ),
            "report": _run(
                [*cli, "report", "--db", str(db), "-o", str(tmp_path / "r.html")],
                DRIVELASH_STORE_BUSY_TIMEOUT="0.5",
            ),
        }
    finally:
        other.execute("ROLLBACK")
        other.close()
    for name, r in runs.items():
        assert r.returncode == 2, (name, r.stderr)
        line = _one_error_line(r.stderr)
        assert f"{db}: database is locked by another writer for more than 0.5 s" in line, (name, line)
        assert "nothing was written" in line and "run it again when the other one has finished" in line
    assert not (tmp_path / "f.json").exists() and not (tmp_path / "r.html").exists()


def test_full_disk_during_ingest_is_one_line_rolled_back_and_the_store_stays_usable(
    tiny_fleet, tmp_path, monkeypatch, capsys
):
    from drivelash import cli

    db, args, before = _ingested_with_two_new(cli, tiny_fleet, tmp_path, capsys)

    migrate = _disk_full_on_estimates(monkeypatch)
    assert _main(cli, args) == 2
    line = _one_error_line(capsys.readouterr().err)
    assert f"{db}: database or disk is full; the transaction was rolled back" in line
    assert "nothing of this ingest was written" in line and "free space" in line
    assert _state(db) == before  # the transaction was rolled back: same rows

    monkeypatch.setattr(Store, "_migrate", migrate)
    assert _main(cli, args) == 0
    rec, est = _state(db)
    assert rec[: len(before[0])] == before[0] and len(rec) == len(before[0]) + 2 and len(est) == len(rec)


def test_full_disk_on_a_first_ingest_says_the_axes_were_registered(tiny_fleet, tmp_path, monkeypatch, capsys):
    """A first ingest that meets a full disk at its first estimate has registered the fleet's
    axes (plan's own transaction): the line says so instead of "nothing … was written" (status
    would list those axes with no recording), and no recording or estimate is stored."""
    from drivelash import cli

    fleet, _ = _fleet_copy(tiny_fleet, tmp_path / "f")
    db = tmp_path / "w.sqlite"
    _disk_full_on_estimates(monkeypatch)
    args = ["track", "ingest", str(fleet / "fleet.toml"), "--db", str(db), "--workers", "1"]
    assert _main(cli, args) == 2
    line = _one_error_line(capsys.readouterr().err)
    with sqlite3.connect(db) as c:
        n_axes = c.execute("SELECT count(*) FROM axis").fetchone()[0]
    assert n_axes >= 2
    assert f"no estimate of this ingest was written (its {n_axes} new axes were registered)" in line, line
    assert "nothing of this ingest was written" not in line
    assert _state(db) == ([], [])


def _disk_full_on_estimates(monkeypatch):
    """Every store opened from now on meets SQLite's real "disk full" error on each INSERT of an
    estimate; returns the original ``Store._migrate`` (to undo it)."""
    migrate = Store._migrate

    def no_room(self, create):
        migrate(self, create)

        def full(conn, cursor, statement, *a):
            if statement.lstrip().upper().startswith("INSERT INTO ESTIMATE"):
                raise sqlite3.OperationalError("database or disk is full")

        sa.event.listen(self.engine, "before_cursor_execute", full)

    monkeypatch.setattr(Store, "_migrate", no_room)
    return migrate


def _main(cli, args: list[str]) -> int:
    """Exit code of ``drivelash ARGS`` run in this process."""
    try:
        cli.main(args)
    except SystemExit as ex:
        return int(ex.code or 0)
    return 0


def test_enospc_while_writing_is_one_line(tmp_path, monkeypatch):
    """An OSError ENOSPC out of a write (e.g. a journal file) is the same one-line error."""
    import errno

    from drivelash.errors import DrivelashError

    st = Store(tmp_path / "w.sqlite")
    with pytest.raises(DrivelashError) as ei, st.guard("nothing was written"):
        raise OSError(errno.ENOSPC, "No space left on device")
    assert str(ei.value).startswith(f"{st.name}: database or disk is full (")
    with pytest.raises(KeyError), st.guard("x"):  # not a store failure: left alone
        raise KeyError("bug")


def _two_ingests_at_once(fleet: Path, db) -> list[int]:
    """Start two ``track ingest`` of ``fleet`` on store ``db`` at the same time; both exit 0.
    Returns how many recordings each one estimated (from its summary line)."""
    import re

    procs = [
        subprocess.Popen(ingest_cmd(fleet / "fleet.toml", db), stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
        for _ in range(2)
    ]  # fmt: skip
    outs = [p.communicate(timeout=300) for p in procs]
    estimated = []
    for p, (out, err) in zip(procs, outs, strict=True):
        assert p.returncode == 0, err
        assert "Traceback" not in err
        estimated.append(int(re.search(r"(\d+) new recordings? estimated", " ".join(out.split()))[1]))
    return estimated


# slow since session 33 (11.7 s of `make test`'s 10-minute budget): the SQLite case of the same
# protocol stays fast, so does a PostgreSQL ingest (test_ingest.py) and a kill on PostgreSQL (below)
@pytest.mark.slow
def test_two_first_ingests_at_once_on_an_empty_postgresql_database(tiny_fleet, pg_url):
    estimated = _two_ingests_at_once(tiny_fleet, pg_url)
    # one ingest at a time (Store.ingest_lock): each recording is estimated once, not by both
    assert sorted(estimated) == [0, len(_files(tiny_fleet))], estimated
    st = Store(pg_url, create=False)
    try:
        rows = st.estimates()
        n = len(_files(tiny_fleet))
        assert len(rows) == n and len({r["path"] for r in rows}) == n
        assert st.counts()["recording"] == n and st.counts()["axis"] == TINY["machines"] * TINY["axes"]
    finally:
        st.close()


def test_two_first_ingests_at_once_on_a_new_sqlite_file(tiny_fleet, tmp_path):
    db = tmp_path / "w.sqlite"
    estimated = _two_ingests_at_once(tiny_fleet, db)
    n = len(_files(tiny_fleet))
    assert sorted(estimated) == [0, n], estimated  # each recording estimated once (Store.ingest_lock)
    with sqlite3.connect(db) as c:
        assert c.execute("SELECT count(*), count(DISTINCT path) FROM recording").fetchone() == (n, n)
        assert c.execute("SELECT count(*) FROM estimate").fetchone() == (n,)


def test_readers_meeting_a_lock_after_opening_the_store_say_so_in_one_line(
    tiny_fleet, tmp_path, monkeypatch, capsys
):
    """The lock hits a read after the store was opened (e.g. a writer in exclusive mode that
    started meanwhile): the same one line, no traceback, no output file."""
    from drivelash import cli

    fleet, _ = _fleet_copy(tiny_fleet, tmp_path / "f")
    db = tmp_path / "w.sqlite"
    assert _main(cli, ["track", "ingest", str(fleet / "fleet.toml"), "--db", str(db), "--workers", "1"]) == 0
    migrate = Store._migrate

    def locked_later(self, create):
        migrate(self, create)

        def lock(conn, cursor, statement, *a):
            if "FROM estimate" in statement or "FROM measurement" in statement:
                raise sqlite3.OperationalError("database is locked")

        sa.event.listen(self.engine, "before_cursor_execute", lock)

    monkeypatch.setattr(Store, "_migrate", locked_later)
    capsys.readouterr()
    for args in (
        ["status"],
        ["forecast", "M01/X", "--json", str(tmp_path / "f.json")],
        ["report", "-o", str(tmp_path / "r.html")],
    ):
        assert _main(cli, ["track", *args, "--db", str(db)]) == 2, args
        line = _one_error_line(capsys.readouterr().err)
        assert f"{db}: database is locked by another writer for more than 30 s" in line, line
    assert not (tmp_path / "f.json").exists() and not (tmp_path / "r.html").exists()


def _pg_state(url: str) -> tuple[list[tuple], list[tuple]]:
    """Every row of the recording and estimate tables of a PostgreSQL store."""
    st = Store(url, create=False)
    try:
        with st.engine.connect() as c:
            rec = c.exec_driver_sql("SELECT id, axis_id, content_hash, path FROM recording ORDER BY id").all()
            est = c.exec_driver_sql("SELECT id, recording_id, status, delta FROM estimate ORDER BY id").all()
    finally:
        st.close()
    return [tuple(r) for r in rec], [tuple(r) for r in est]


# slow since session 33 (3.6 s of `make test`): the SQLite busy-timeout checks stay fast
@pytest.mark.slow
def test_postgresql_writer_gives_up_on_a_held_write_lock_after_the_busy_timeout(
    tiny_fleet, tmp_path, pg_server, pg_url, capsys
):
    """PostgreSQL waits for the advisory write lock no longer than SQLite for its file lock:
    ``DRIVELASH_STORE_BUSY_TIMEOUT`` seconds, then the same one line, nothing written."""
    import psycopg

    from drivelash.wear.store import PG_WRITE_LOCK

    fleet, held = _fleet_copy(tiny_fleet, tmp_path / "f", hold_back=1)
    r = ingest_here(fleet / "fleet.toml", pg_url, capsys)
    assert r.returncode == 0, r.stderr
    for aside, p in held:  # a new recording to store
        aside.rename(p)
    before = _pg_state(pg_url)
    name = sa.make_url(pg_url).database
    with psycopg.connect(
        host=pg_server["host"], port=pg_server["port"], user=pg_server["user"], dbname=name, autocommit=True
    ) as other:  # another writer holding the write lock (session-level, outside any transaction)
        other.execute("SELECT pg_advisory_lock(%s)", (PG_WRITE_LOCK,))
        t0 = time.monotonic()
        try:
            r = subprocess.run(
                ingest_cmd(fleet / "fleet.toml", pg_url),
                capture_output=True,
                text=True,
                timeout=90,
                env={**os.environ, "DRIVELASH_STORE_BUSY_TIMEOUT": "1"},
            )
        except subprocess.TimeoutExpired:
            pytest.fail("track ingest waited for the PostgreSQL write lock beyond the busy timeout")
        waited = time.monotonic() - t0
        assert r.returncode == 2, r.stderr
        line = _one_error_line(r.stderr)
        shown = sa.make_url(pg_url).render_as_string(hide_password=True)
        assert f"{shown}: database is locked by another writer for more than 1 s" in line, line
        assert "nothing of this ingest was written" in line and "run it again" in line
        assert waited < 60  # gave up, did not wait for the lock without end
        assert _pg_state(pg_url) == before
        other.execute("SELECT pg_advisory_unlock(%s)", (PG_WRITE_LOCK,))
    # the lock released, the ingest stores the new recording
    r = ingest_here(fleet / "fleet.toml", pg_url, capsys)
    assert r.returncode == 0, r.stderr
    rec, est = _pg_state(pg_url)
    assert rec[: len(before[0])] == before[0] and len(rec) == len(before[0]) + 1 and len(est) == len(rec)


@pytest.mark.parametrize("value", ["1e10", "3e6", "abc", "-1", "inf", "nan", ""])
def test_a_busy_timeout_beyond_what_the_databases_take_is_refused_in_one_line(tmp_path, monkeypatch, value):
    """SQLite takes the busy timeout in int milliseconds: 1e10 s overflowed to "do not wait"
    (a held lock failed at once, the message said "locked for more than 1e+10 s")."""
    from drivelash.wear.store import BUSY_TIMEOUT_ENV, StoreError

    monkeypatch.setenv(BUSY_TIMEOUT_ENV, value)
    with pytest.raises(StoreError, match=r"^DRIVELASH_STORE_BUSY_TIMEOUT=.*from 0 to 2147483") as e:
        Store(tmp_path / "w.sqlite")
    assert "\n" not in str(e.value) and not (tmp_path / "w.sqlite").exists()


@pytest.mark.parametrize("value", [-1.0, math.nan, 1e10])
def test_a_bad_busy_timeout_argument_is_refused(tmp_path, value):
    from drivelash.wear.store import StoreError

    with pytest.raises(StoreError, match=r"^busy_timeout="):
        Store(tmp_path / "w.sqlite", busy_timeout=value)  # type: ignore[arg-type]


def test_the_largest_busy_timeout_still_waits(tmp_path, monkeypatch):
    from drivelash.wear.store import BUSY_TIMEOUT_MAX_S

    st = Store(tmp_path / "w.sqlite", busy_timeout=BUSY_TIMEOUT_MAX_S)
    with st.engine.connect() as conn:
        assert conn.exec_driver_sql("PRAGMA busy_timeout").scalar_one() == int(BUSY_TIMEOUT_MAX_S * 1000)


def test_the_busy_timeout_is_30_s_unless_the_environment_sets_it(tmp_path, monkeypatch):
    """README: a store locked by another writer "for more than 30 s (DRIVELASH_STORE_BUSY_TIMEOUT
    seconds, if set)" ends the ingest — 30 s is what SQLite is told when nothing is set."""
    monkeypatch.delenv("DRIVELASH_STORE_BUSY_TIMEOUT", raising=False)
    st = Store(tmp_path / "w.sqlite")
    with st.engine.connect() as conn:
        assert conn.exec_driver_sql("PRAGMA busy_timeout").scalar_one() == 30_000
    # negative control: the variable, when set, is what SQLite is told
    monkeypatch.setenv("DRIVELASH_STORE_BUSY_TIMEOUT", "2.5")
    st = Store(tmp_path / "v.sqlite")
    with st.engine.connect() as conn:
        assert conn.exec_driver_sql("PRAGMA busy_timeout").scalar_one() == 2_500


def test_ctrl_c_during_ingest_says_what_the_store_kept(tiny_fleet, tmp_path, monkeypatch, capsys):
    """Ctrl-C during ``track ingest``: one line, exit 130. Interrupted before any transaction
    of this ingest: "no output written" and the rows are as they were; interrupted after a
    committed transaction: the line names the store instead of claiming nothing was written."""
    from drivelash import cli

    db, args, before = _ingested_with_two_new(cli, tiny_fleet, tmp_path, capsys)
    commit_batch = Store.commit_batch

    def interrupted_before(self, *a, **k):
        raise cli.Interrupted()

    monkeypatch.setattr(Store, "commit_batch", interrupted_before)
    assert _main(cli, args) == 130
    lines = [x for x in capsys.readouterr().err.splitlines() if x.strip()]  # the progress line ends
    assert lines == ["drivelash: interrupted; no output written"]
    assert _state(db) == before

    def interrupted_after(self, *a, **k):
        commit_batch(self, *a, **k)
        raise cli.Interrupted()

    monkeypatch.setattr(Store, "commit_batch", interrupted_after)
    assert _main(cli, args) == 130
    store = f"sqlite:///{db}"  # the store as every message names it
    line = f"drivelash: interrupted after writing {store} (the transactions committed so far)"
    line += "; nothing else written"
    assert [x for x in capsys.readouterr().err.splitlines() if x.strip()] == [line]
    assert len(_state(db)[0]) == len(before[0]) + 2


@pytest.fixture
def tiny_tmpfs(tmp_path):
    """A 16 KiB tmpfs (root only): too small for SQLite's WAL files of a new store."""
    d = tmp_path / "small"
    d.mkdir()
    if os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("mounting a tmpfs needs root")
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=16k", "tmpfs", str(d)], capture_output=True)
    if r.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {r.stderr.decode().strip()}")
    try:
        yield d
    finally:
        subprocess.run(["umount", str(d)], check=False)


def test_a_new_store_on_a_full_disk_says_the_disk_is_full(tiny_fleet, tmp_path, tiny_tmpfs, capsys):
    """A first ingest into a store on a (16 KiB) full disk: SQLite fails to create its WAL files
    with "disk I/O error", which the line used to repeat ("cannot open the store (disk I/O
    error)"); it now says the disk is full, naming the store file, exit 2."""
    from drivelash import cli

    fleet, _ = _fleet_copy(tiny_fleet, tmp_path / "f")
    db = tiny_tmpfs / "w.sqlite"
    args = ["track", "ingest", str(fleet / "fleet.toml"), "--db", str(db), "--workers", "1"]
    assert _main(cli, args) == 2
    line = _one_error_line(capsys.readouterr().err)
    assert line.startswith(f"drivelash: error: {db}: the disk is full ("), line
    assert "nothing was written" in line and "free space" in line and "cannot open the store" not in line
    # and nothing was: no empty w.sqlite is left behind (sessions 17–18 left one for the next
    # ingest to migrate)
    assert sorted(x.name for x in tiny_tmpfs.iterdir()) == []


@pytest.mark.parametrize("free", [0, 64 << 20], ids=["full", "plenty-free"])
def test_a_disk_io_error_is_called_a_full_disk_only_when_the_disk_is_full(tmp_path, monkeypatch, free):
    """The same SQLite "disk I/O error" while creating a store: "the disk is full" when the
    store's file system has less than FULL_DISK_BYTES free; with 64 MiB free (negative control)
    SQLite's own words, not a full disk."""
    import drivelash.wear.store as store_mod
    from drivelash.errors import DrivelashError

    migrate = Store._migrate

    def io_error(self, create):
        def fail(conn, cursor, statement, *a):
            raise sqlite3.OperationalError("disk I/O error")

        sa.event.listen(self.engine, "before_cursor_execute", fail)
        migrate(self, create)

    monkeypatch.setattr(Store, "_migrate", io_error)
    monkeypatch.setattr(store_mod, "_free_bytes", lambda d: free)
    db = tmp_path / "w.sqlite"
    with pytest.raises(DrivelashError) as ei:
        Store(db)
    msg = str(ei.value)
    assert "\n" not in msg
    if free < store_mod.FULL_DISK_BYTES:
        assert msg.startswith(f"{db}: the disk is full (0 bytes free; SQLite: disk I/O error)"), msg
    else:
        assert "disk is full" not in msg and "disk I/O error" in msg, msg


def test_only_a_store_file_without_any_table_is_removed_after_a_full_disk(tmp_path):
    """What a failed creation on a full disk may remove (`_remove_empty_store`, judged by the
    file's bytes since SQLite cannot open it there): an empty file, or a header page with an
    empty schema and an empty WAL. Negative controls, each kept: a store with its schema, a
    file that is not SQLite, a header page whose WAL holds frames."""
    from drivelash.wear.store import _remove_empty_store

    def fresh(name: str, tables: bool = False, wal_frames: bool = False) -> Path:
        p = tmp_path / name
        con = sqlite3.connect(p)
        con.execute("PRAGMA journal_mode=WAL")  # writes the header page, as the store does
        if tables:
            con.execute("CREATE TABLE t (x)")
            con.commit()
            con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        if wal_frames:
            con.execute("PRAGMA wal_autocheckpoint=0")
            con.execute("CREATE TABLE t (x)")
            con.commit()
            shutil.copy(p.with_name(p.name + "-wal"), tmp_path / "frames")
        con.close()
        if wal_frames:  # the WAL as a crashed writer leaves it (closing checkpoints it away)
            shutil.copy(tmp_path / "frames", p.with_name(p.name + "-wal"))
        return p

    empty = tmp_path / "zero.sqlite"
    empty.write_bytes(b"")
    header_only = fresh("header.sqlite")
    assert header_only.stat().st_size == 4096
    with_schema = fresh("schema.sqlite", tables=True)
    in_wal = fresh("wal.sqlite", wal_frames=True)
    assert in_wal.with_name("wal.sqlite-wal").stat().st_size > 0
    other = tmp_path / "notes.sqlite"
    other.write_text("my notes")
    store = tmp_path / "store.sqlite"
    Store(store).close()
    for p in (empty, header_only, with_schema, in_wal, other, store):
        _remove_empty_store(p)
    assert not empty.exists() and not header_only.exists()
    assert not header_only.with_name("header.sqlite-wal").exists()
    assert with_schema.exists() and in_wal.exists() and other.read_text() == "my notes" and store.exists()


def _store_url(backend: str, tmp_path: Path, request) -> Any:
    return tmp_path / "w.sqlite" if backend == "sqlite" else request.getfixturevalue("pg_url")


# the PostgreSQL case is slow since session 33 (7.8 s of `make test`); the SQLite case stays fast
@pytest.mark.parametrize("backend", ["sqlite", pytest.param("postgresql", marks=pytest.mark.slow)])
def test_a_second_ingest_waits_for_the_first_and_says_so(tiny_fleet, tmp_path, request, backend):
    """While one ingest holds the store (``Store.ingest_lock``), ``track ingest`` says in one line
    that it waits, writes nothing and does not finish; once the lock is released it runs. Without
    the lock (measured with ``ingest_lock`` made a no-op) two ingests at once both estimated every
    recording: [5, 5] instead of [0, 5] in the two tests above."""
    import threading

    from drivelash.wear import load_fleet

    db = _store_url(backend, tmp_path, request)
    axes = [a.name for a in load_fleet(tiny_fleet / "fleet.toml").axes]
    st = Store(db)
    err: list[str] = []
    try:
        # an ingest of other axes (one writer per axis range, docs/scaling.md) does not wait
        with st.ingest_lock(axes[:1]) as held, st.ingest_lock(axes[1:], timeout=0.0) as other:
            assert held and other
        with st.ingest_lock(reversed(axes)) as held:  # the set is the identity, not the order
            assert held
            p = subprocess.Popen(ingest_cmd(tiny_fleet / "fleet.toml", db), stdout=subprocess.PIPE,
                                 stderr=subprocess.PIPE, text=True)  # fmt: skip
            reader = threading.Thread(target=lambda: err.extend(p.stderr), daemon=True)
            reader.start()
            deadline = time.monotonic() + 180
            while not any("waiting for it to finish" in line for line in err):
                assert p.poll() is None and time.monotonic() < deadline, err
                time.sleep(0.1)
            time.sleep(1.0)
            assert p.poll() is None, err  # still waiting
            assert st.counts()["estimate"] == 0  # and nothing written
        out = p.stdout.read()
        assert p.wait(timeout=300) == 0, err
        reader.join(timeout=10)
    finally:
        st.close()
    wait_lines = [line for line in err if "waiting" in line]
    assert len(wait_lines) == 1, err
    assert wait_lines[0].startswith(f"drivelash: {st.name}: another 'track ingest' of these axes is running")
    assert "Traceback" not in "".join(err)
    assert f"{len(_files(tiny_fleet))} new recordings estimated" in " ".join(out.split())


@pytest.mark.parametrize("backend", ["sqlite", "postgresql"])
def test_an_ingest_killed_while_holding_the_store_does_not_block_the_next(tmp_path, request, backend):
    """The ingest lock belongs to the process (an OS file lock; a PostgreSQL session lock): after
    SIGKILL the next ingest gets it at once. Negative control: while the process lives, the
    lock is held (a 1 s wait ends in one line)."""
    import signal

    db = _store_url(backend, tmp_path, request)
    Store(db).close()
    code = (
        "import sys; from drivelash.wear.store import Store\n"
        "st = Store(sys.argv[1])\n"
        "with st.ingest_lock(['M01/X']) as held:\n"
        "    print(held, flush=True); sys.stdin.read()\n"
    )
    p = subprocess.Popen([sys.executable, "-c", code, str(db)], stdin=subprocess.PIPE,
                         stdout=subprocess.PIPE, text=True)  # fmt: skip
    try:
        assert p.stdout.readline().strip() == "True"
        st = Store(db)
        waited: list[str] = []
        t = time.monotonic()
        with (
            pytest.raises(StoreError, match="of these axes has been running for more than 1 s"),
            st.ingest_lock(["M01/X"], on_wait=waited.append, timeout=1.0),
        ):
            pass  # held by the other process: this one waits, then gives up
        assert len(waited) == 1 and time.monotonic() - t >= 1.0
        p.send_signal(signal.SIGKILL)
        p.wait(timeout=30)
        # at once: an OS file lock goes with the process; PostgreSQL ends the session when it
        # reads the closed socket, a moment after the kill
        t = time.monotonic()
        with st.ingest_lock(["M01/X"], timeout=10.0) as held:
            assert held and time.monotonic() - t < 5.0
        st.close()
    finally:
        if p.poll() is None:
            p.kill()
