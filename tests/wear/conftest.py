"""Fixtures of the wear tests: a small simulated fleet and a throwaway PostgreSQL server."""

from __future__ import annotations

import glob
import os
import pwd
import shutil
import socket
import subprocess
import tempfile
import uuid
from pathlib import Path

import numpy as np
import pytest

from drivelash.wear import Store, ingest, load_fleet

#: The small fleet of the fast tests: 2 machines × 2 axes × 8 recordings (8 s each).
SMALL = {"machines": 2, "axes": 2, "recordings": 8, "seed": 5}


def _add_corrupt(fleet_dir: Path) -> list[Path]:
    """Two corrupt recordings under M01/X with valid names: garbage bytes and a truncated file."""
    d = fleet_dir / "recordings" / "M01" / "X"
    good = sorted(d.glob("*.parquet"))[0]
    bad1 = d / "M01-X_20260301T060000.parquet"
    bad1.write_bytes(np.random.default_rng(0).bytes(3000))
    bad2 = d / "M01-X_20260302T060000.parquet"
    data = good.read_bytes()
    bad2.write_bytes(data[: len(data) // 3])
    return [bad1, bad2]


@pytest.fixture(scope="session")
def small_fleet(tmp_path_factory) -> Path:
    """A small simulated fleet (fleet.toml, truth.json, recordings) plus two corrupt files."""
    from drivelash.sim.fleet import simulate_fleet

    out = tmp_path_factory.mktemp("fleet") / "fleet"
    simulate_fleet(out, **SMALL, workers=1)
    _add_corrupt(out)
    return out


@pytest.fixture(scope="session")
def serial_store(small_fleet, tmp_path_factory):
    """The small fleet ingested serially into SQLite (session-scoped: several checks read it)."""
    db = tmp_path_factory.mktemp("serial") / "wear.sqlite"
    st = Store(db)
    rep = ingest(load_fleet(small_fleet / "fleet.toml"), st, workers=1, batch_size=5)
    return st, rep


@pytest.fixture
def cli250(monkeypatch, capsys):
    """``drivelash ARGS`` run in this process at 250 columns (the commands read COLUMNS per call);
    returns :class:`cli_runner.CliResult`."""
    from cli_runner import run_in_process

    monkeypatch.setenv("COLUMNS", "250")
    return lambda args: run_in_process(args, capsys)


def copy_fleet(src: Path, dst: Path) -> Path:
    """A private copy of a fleet directory (tests that write stores next to it)."""
    shutil.copytree(src, dst)
    for p in dst.glob("wear.sqlite*"):
        p.unlink()
    return dst


# ----------------------------------------------------------------------------- PostgreSQL
def _pg_bindir() -> str | None:
    for d in sorted(glob.glob("/usr/lib/postgresql/*/bin"), reverse=True):
        if os.path.exists(os.path.join(d, "initdb")):
            return d
    w = shutil.which("initdb")
    return os.path.dirname(w) if w else None


def pg_missing_reason(euid: int, have_apt: bool) -> str:
    """The skip reason when the PostgreSQL server binaries are missing: what was looked for and
    why ``make test`` (``make components``) did not install them."""
    why = (
        "this run is not root, so `make test` could not install Debian's postgresql"
        if euid != 0
        else "`make test` (as root) tried `apt-get install postgresql` and it failed; see its output"
        if have_apt
        else "there is no apt-get to install it with"
    )
    return f"no PostgreSQL server binaries (initdb in /usr/lib/postgresql/*/bin or on PATH): {why}"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture(scope="session")
def pg_server():
    """A throwaway PostgreSQL server on 127.0.0.1 (initdb + pg_ctl in a temp dir), stopped at the end.

    Skips, saying why, when the distribution's PostgreSQL binaries are not installed (``make
    test`` installs them when run as root) or the server cannot be started.
    """
    bindir = _pg_bindir()
    if bindir is None:
        pytest.skip(pg_missing_reason(os.geteuid(), shutil.which("apt-get") is not None))
    base = Path(tempfile.mkdtemp(prefix="drivelash-pg-"))
    run_as: list[str] = []
    if os.geteuid() == 0:  # initdb refuses to run as root: use the package's system user
        try:
            pwd.getpwnam("postgres")
        except KeyError:
            shutil.rmtree(base, ignore_errors=True)
            pytest.skip("running as root and there is no 'postgres' user to run the server as")
        shutil.chown(base, "postgres", "postgres")
        run_as = ["runuser", "-u", "postgres", "--"]
    data = base / "data"
    port = _free_port()
    try:
        subprocess.run(
            [
                *run_as,
                f"{bindir}/initdb",
                "-D",
                str(data),
                "-A",
                "trust",
                "-U",
                "drivelash",
                "-E",
                "UTF8",
                "--no-sync",
                "--no-instructions",
            ],
            check=True,
            capture_output=True,
            timeout=120,
        )
        opts = f"-c listen_addresses=127.0.0.1 -p {port} -k {base} -c fsync=off -c full_page_writes=off"
        subprocess.run(
            [
                *run_as,
                f"{bindir}/pg_ctl",
                "-D",
                str(data),
                "-l",
                str(base / "server.log"),
                "-w",
                "-t",
                "60",
                "-o",
                opts,
                "start",
            ],
            check=True,
            capture_output=True,
            timeout=120,
        )
    except (subprocess.CalledProcessError, subprocess.TimeoutExpired) as exc:
        err = getattr(exc, "stderr", b"") or b""
        shutil.rmtree(base, ignore_errors=True)
        pytest.skip(f"could not start a throwaway PostgreSQL server: {err.decode(errors='replace')[-300:]}")
    try:
        yield {"host": "127.0.0.1", "port": port, "user": "drivelash"}
    finally:
        subprocess.run(
            [*run_as, f"{bindir}/pg_ctl", "-D", str(data), "-m", "immediate", "-w", "stop"],
            capture_output=True,
            timeout=60,
        )
        shutil.rmtree(base, ignore_errors=True)


@pytest.fixture
def pg_url(pg_server) -> str:
    """URL of a fresh, empty database on the throwaway server."""
    import psycopg

    name = "t_" + uuid.uuid4().hex[:12]
    with psycopg.connect(
        host=pg_server["host"],
        port=pg_server["port"],
        user=pg_server["user"],
        dbname="postgres",
        autocommit=True,
    ) as conn:
        conn.execute(f"CREATE DATABASE {name}")
    return f"postgresql+psycopg://{pg_server['user']}@{pg_server['host']}:{pg_server['port']}/{name}"


def ingest_here(fleet_toml: Path, db, capsys):
    """:func:`ingest_cmd`'s ``track ingest`` run in this process (a :class:`cli_runner.CliResult`):
    for checks whose subject is the command's output, not the process (no other writer, no
    signal); a fresh interpreter costs ≈ 2.5 s of `make test` per call (session 33)."""
    import sys

    from cli_runner import run_in_process

    cmd = ingest_cmd(fleet_toml, db)
    assert cmd[:3] == [sys.executable, "-m", "drivelash.cli"], cmd
    return run_in_process(cmd[3:], capsys)


def ingest_cmd(fleet_toml: Path, db: Path) -> list[str]:
    """``drivelash track ingest FLEET --db DB --workers 1`` as a subprocess argument list."""
    import sys

    return [sys.executable, "-m", "drivelash.cli", "track", "ingest", str(fleet_toml), "--db", str(db)] + [
        "--workers",
        "1",
    ]


def old_store(db: Path, revision: str, *sql: str) -> Path:
    """A SQLite store at Alembic ``revision`` (an older schema) holding the rows ``sql`` inserts —
    what a store written by an earlier drivelash looks like to the migrations."""
    import sqlalchemy as sa
    from alembic import command
    from alembic.config import Config

    from drivelash.wear.store import MIGRATIONS

    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS))
    eng = sa.create_engine(f"sqlite:///{db}")
    with eng.begin() as conn:
        cfg.attributes["connection"] = conn
        command.upgrade(cfg, revision)
        for s in sql:
            conn.exec_driver_sql(s)
    eng.dispose()
    return db
