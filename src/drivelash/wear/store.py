"""The wear history store: SQLAlchemy 2.x, schema versioned by the Alembic migrations shipped here.

One :class:`Store` per database URL (any SQLAlchemy URL; a plain path is an SQLite file,
opened in WAL mode). Opening a store runs ``alembic upgrade head``; a read-only open
(``create=False``) refuses a file that does not exist instead of creating it.

Identity (DESIGN.md): a recording is identified by the SHA-256 of its content (per axis);
an estimate by (recording, method, config hash, code version). Every write is one
transaction, so a crash leaves the store as it was before the batch or after it.

Python API for other sources of the same axis (ISO 230-2 laser checks, …)::

    from drivelash.wear.store import Store
    with Store("wear.sqlite") as st:
        st.add_measurement("M01/X", time, value=0.012, std=0.001, unit="mm", source="iso230-2",
                           reference="laser-2026-03-01.csv")

The value is kept in its unit and, when the axis has a transmission (mm per rad at the
load), also in rad, so trend plots show it next to the recording-based estimates.
"""

from __future__ import annotations

import errno
import json
import math
import os
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import sqlalchemy as sa
from sqlalchemy import event
from sqlalchemy.engine import Engine
from sqlalchemy.exc import ArgumentError, DBAPIError, NoSuchModuleError, OperationalError

from drivelash.errors import DrivelashError
from drivelash.units import LENGTH_TO_M
from drivelash.wear.words import count

__all__ = ["EstimateRow", "Store", "StoreError", "store_file", "utc_naive"]

MIGRATIONS = Path(__file__).parent / "migrations"
#: Seconds a writer waits for another writer's lock before giving up [s], SQLite (busy timeout)
#: and PostgreSQL (``lock_timeout`` on the advisory write lock) alike (the
#: environment variable :data:`BUSY_TIMEOUT_ENV` overrides it, e.g. for tests).
BUSY_TIMEOUT_S = 30.0
BUSY_TIMEOUT_ENV = "DRIVELASH_STORE_BUSY_TIMEOUT"
#: Largest busy timeout [s]: both databases take it in integer milliseconds (SQLite's
#: ``sqlite3_busy_timeout`` an ``int``, PostgreSQL's ``lock_timeout`` at most 2^31 − 1 ms); a
#: longer one overflowed to "do not wait" (SQLite) or a database error (PostgreSQL).
BUSY_TIMEOUT_MAX_S = 2_147_483.0
#: Key of the PostgreSQL advisory lock every write transaction (migrations included) holds:
#: writers of one database run one after the other, as on SQLite (``BEGIN IMMEDIATE``).
PG_WRITE_LOCK = 0x64726C77  # "drlw"
#: First key of the PostgreSQL session-level advisory lock one ingest holds from its plan to its
#: last commit (:meth:`Store.ingest_lock`; the second key is the ingested axes' checksum), so
#: that a second ingest of the same axes waits instead of estimating the same recordings again.
PG_INGEST_LOCK = 0x6472696E  # "drin"
#: Seconds between two tries of the ingest lock while another ingest holds it [s].
INGEST_LOCK_POLL_S = 0.2
#: PostgreSQL's SQLSTATE ``lock_not_available``: a lock wait ran past ``lock_timeout``.
PG_LOCK_NOT_AVAILABLE = "55P03"
#: Units a measurement may carry, and their factor to mm (rad needs no transmission).
LENGTH_UNITS = {unit: 1e3 * to_m for unit, to_m in LENGTH_TO_M.items()}


class StoreError(DrivelashError):
    """The store cannot be opened or written (bad URL, unreachable server, locked file)."""


def utc_naive(t: datetime | None) -> datetime | None:
    """A datetime as naive UTC (how the store keeps time; SQLite has no zones)."""
    if t is None:
        return None
    if t.tzinfo is not None:
        t = t.astimezone(UTC).replace(tzinfo=None)
    return t


def _now() -> datetime:
    return datetime.now(UTC).replace(tzinfo=None)


meta = sa.MetaData()
axis_t = sa.Table(
    "axis",
    meta,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("name", sa.String(200)),
    sa.Column("machine", sa.String(100)),
    sa.Column("drive_path", sa.Text),
    sa.Column("drive_hash", sa.String(64)),
    sa.Column("threshold_rad", sa.Float),
    sa.Column("transmission_mm_per_rad", sa.Float),
    sa.Column("horizon_days", sa.Float),
    sa.Column("not_excited_alarm", sa.Integer),
    sa.Column("updated_at", sa.DateTime),
    # "rotary" (δ, threshold in rad) or "prismatic" (in m); NULL: written before revision 0004, rotary
    sa.Column("kind", sa.String(16)),
)


def _file_columns() -> list[sa.Column]:
    """Where a recording's file was seen: path, size and modification time (``recording`` and,
    for further files of the same content, ``recording_path``)."""
    return [
        sa.Column("path", sa.Text),
        sa.Column("size_bytes", sa.BigInteger),
        sa.Column("mtime_ns", sa.BigInteger),
    ]


recording_t = sa.Table(
    "recording",
    meta,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("axis_id", sa.Integer),
    sa.Column("content_hash", sa.String(64)),
    *_file_columns(),
    sa.Column("start_time", sa.DateTime),
    sa.Column("duration_s", sa.Float),
    sa.Column("sample_rate_hz", sa.Float),
    sa.Column("samples", sa.BigInteger),
    sa.Column("time_spec_hash", sa.String(64)),
)
recording_path_t = sa.Table(
    "recording_path",
    meta,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("recording_id", sa.Integer),
    *_file_columns(),
)
estimate_t = sa.Table(
    "estimate",
    meta,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("recording_id", sa.Integer),
    sa.Column("axis_id", sa.Integer),
    sa.Column("method", sa.String(32)),
    sa.Column("code_version", sa.String(64)),
    sa.Column("config_hash", sa.String(64)),
    sa.Column("status", sa.String(8)),
    sa.Column("reason", sa.Text),
    sa.Column("delta", sa.Float),
    sa.Column("delta1_estimate", sa.Float),
    sa.Column("delta_std", sa.Float),
    sa.Column("excitation_ok", sa.Boolean),
    sa.Column("converged", sa.Boolean),
    sa.Column("runtime_s", sa.Float),
    sa.Column("created_at", sa.DateTime),
    sa.Column("estimate_rate_hz", sa.Float),
)
measurement_t = sa.Table(
    "measurement",
    meta,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("axis_id", sa.Integer),
    sa.Column("source", sa.String(32)),
    sa.Column("key", sa.String(128)),
    sa.Column("time", sa.DateTime),
    sa.Column("value", sa.Float),
    sa.Column("std", sa.Float),
    sa.Column("unit", sa.String(16)),
    sa.Column("value_rad", sa.Float),
    sa.Column("std_rad", sa.Float),
    sa.Column("reference", sa.Text),
    sa.Column("details", sa.Text),
    sa.Column("created_at", sa.DateTime),
)
alarm_t = sa.Table(
    "alarm",
    meta,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("axis_id", sa.Integer),
    sa.Column("kind", sa.String(32)),
    sa.Column("key", sa.String(128)),
    sa.Column("message", sa.Text),
    sa.Column("data_time", sa.DateTime),
    sa.Column("raised_at", sa.DateTime),
    sa.Column("cleared_at", sa.DateTime),
)


@dataclass(frozen=True)
class EstimateRow:
    """One recording's result as the workers return it (one row each in recording and estimate).

    Attributes
    ----------
    axis : str
        ``machine/axis``.
    path : str
        The recording file.
    size_bytes, mtime_ns : int
        File size and modification time (a shortcut to skip unchanged files on a rerun;
        the identity is ``content_hash``).
    content_hash : str
        SHA-256 of the file's bytes (hex).
    start_time : datetime or None
        Start of the recording, naive UTC (None when it could not be found).
    duration_s, sample_rate_hz : float or None
        Length [s] and sample rate [Hz].
    samples : int or None
        Number of samples.
    method, code_version, config_hash : str
        Estimate identity besides the recording.
    status : {"ok", "failed"}
        ``failed``: the recording could not be read or validated; ``reason`` says why.
    reason : str
        Failure reason, or the estimator's excitation reason.
    delta : float or None
        δ̂ [rad].
    delta1_estimate : float or None
        The estimator's δ1 estimate or check value [rad].
    delta_std : float or None
        Standard uncertainty of δ̂ [rad] from the estimator; None when it gives none
        (never made up), or when a blocking warning made the estimate unconverged (its σ is
        conditional on parameters the data contradict; ``reason`` names the cause).
    excitation_ok, converged : bool or None
        The estimator's verdicts.
    runtime_s : float
        Wall time of read + validate + estimate in the worker [s].
    estimate_rate_hz : float or None
        Rate of the samples the estimator saw [Hz] (the recording's rate, or less when the
        fleet's ``estimate_rate_hz`` keeps every k-th sample); None when nothing was estimated.
    time_spec_hash : str or None
        SHA-256 of the ``time`` specification ``start_time`` was found with
        (:func:`drivelash.wear.fleet.time_spec_hash`).
    """

    axis: str
    path: str
    size_bytes: int
    mtime_ns: int
    content_hash: str
    start_time: datetime | None
    duration_s: float | None
    sample_rate_hz: float | None
    samples: int | None
    method: str
    code_version: str
    config_hash: str
    status: str
    reason: str
    delta: float | None = None
    delta1_estimate: float | None = None
    delta_std: float | None = None
    excitation_ok: bool | None = None
    converged: bool | None = None
    runtime_s: float = 0.0
    estimate_rate_hz: float | None = None
    time_spec_hash: str | None = None

    def values(self) -> dict[str, Any]:
        """The result fields only (what must be bit-identical between runs)."""
        d = asdict(self)
        d.pop("runtime_s")
        return d


def one_per_recording(rows: Sequence[dict[str, Any]], config_hash: str | None) -> list[dict[str, Any]]:
    """Of :meth:`Store.estimates` rows, one per recording (``content_hash``), order kept: the
    newest (highest id) with ``config_hash`` if any, else the newest of that recording."""

    def rank(r: dict[str, Any]) -> tuple[bool, int]:
        return (r["config_hash"] == config_hash, r["id"])

    best: dict[str, dict[str, Any]] = {}
    for r in rows:
        b = best.get(r["content_hash"])
        if b is None or rank(r) > rank(b):
            best[r["content_hash"]] = r
    keep = {id(r) for r in best.values()}
    return [r for r in rows if id(r) in keep]


def _url(db: str | Path) -> sa.URL:
    s = str(db)
    try:
        if "://" in s:
            return sa.make_url(s)
        return sa.URL.create("sqlite", database=str(Path(s).expanduser().resolve()))
    except ArgumentError:
        raise StoreError(f"--db {s!r}: not a database URL or file path") from None


#: Key in a connection's ``info``: the current write transaction changed what the store holds.
_WROTE = "drivelash_wrote"


def _wrote(conn: sa.Connection) -> None:
    """Mark the write transaction of ``conn`` as one that stores something (see ``Store._write``)."""
    conn.info[_WROTE] = True


def _sqlite_file(url: sa.URL) -> str | None:
    """The local file of an SQLite URL; None for a database server or an in-memory SQLite."""
    if url.drivername.startswith("sqlite") and url.database not in (None, "", ":memory:"):
        return url.database
    return None


def store_file(db: str | Path) -> Path | None:
    """The local file of the store at ``db`` (an SQLite path or ``sqlite:///`` URL); None for a
    database server or an in-memory SQLite.

    Commands that read the store and write files name it among their inputs, so that no output
    (``--json``, ``-o``) can be written over it, ``--force`` or not.
    """
    path = _sqlite_file(_url(db))
    return Path(path) if path is not None else None


def _show(url: sa.URL) -> str:
    """The store as messages name it: the URL without its password; an SQLite file's path as
    written (SQLAlchemy's rendering percent-encodes it: ``sp ace %C3%BC`` for ``sp ace ü``)."""
    path = _sqlite_file(url)
    if path is not None:
        return f"{url.drivername}:///{path}"
    return url.render_as_string(hide_password=True)


def _busy_timeout(given: float | None) -> float:
    """The writers' busy timeout [s]: ``given``, else ``$DRIVELASH_STORE_BUSY_TIMEOUT``, else 30 s.

    Raises
    ------
    StoreError
        Not a number in [0, :data:`BUSY_TIMEOUT_MAX_S`] s (one line naming the variable or
        ``busy_timeout``).
    """
    if given is None:
        env = os.environ.get(BUSY_TIMEOUT_ENV)
        if env is None:
            return BUSY_TIMEOUT_S
        name = f"{BUSY_TIMEOUT_ENV}={env!r}"
        try:
            value = float(env)
        except ValueError:
            value = math.nan
    else:
        name = f"busy_timeout={given!r}"
        try:
            value = float(given)
        except (TypeError, ValueError):
            value = math.nan
    if not (math.isfinite(value) and 0 <= value <= BUSY_TIMEOUT_MAX_S):
        raise StoreError(
            f"{name}: must be a number of seconds from 0 to {BUSY_TIMEOUT_MAX_S:.0f} (24.8 days)"
        )
    return value


def _kind(exc: BaseException) -> str | None:
    """``"locked"``, ``"full"``, ``"other"`` (another database error) or None (no store failure)."""
    orig = getattr(exc, "orig", None) or exc
    if isinstance(orig, OSError) and orig.errno in (errno.ENOSPC, errno.EDQUOT):
        return "full"
    if not isinstance(exc, DBAPIError):
        return None
    text = str(orig).lower()
    code = getattr(orig, "sqlstate", None) or getattr(orig, "pgcode", None)
    if "database is locked" in text or "database table is locked" in text or code == PG_LOCK_NOT_AVAILABLE:
        return "locked"
    if "database or disk is full" in text or code in ("53100", "53200"):
        return "full"
    return "other"


#: An SQLite "disk I/O error" on a file system with less free space than this [bytes] is taken
#: for a full disk: SQLite reports a full disk as an I/O error where it maps its ``-shm`` file
#: or writes its ``-wal`` file (a new store on a disk with 8–32 KiB free: "disk I/O error").
FULL_DISK_BYTES = 1 << 20


def _free_bytes(directory: str | Path) -> int | None:
    """Free space [bytes] of the file system holding ``directory`` (what this user may use:
    root writes into the reserved blocks as well); None when it cannot be asked."""
    try:
        st = os.statvfs(directory)
    except OSError:
        return None
    return (st.f_bfree if os.geteuid() == 0 else st.f_bavail) * st.f_frsize


def sqlite_access_problem(path: str | Path, write: bool) -> str | None:
    """Why an SQLite store file cannot be opened, from the file system (None when no such
    reason shows): a directory on a read-only file system or not writable to this user, or a
    read-only file. Asked after SQLite's own "unable to open database file" / "attempt to write
    a readonly database", which names no cause.

    A reader needs the directory too: in WAL mode SQLite creates ``NAME-wal`` and ``NAME-shm``
    next to the file when it opens it (it removes them when the last connection closes).

    Parameters
    ----------
    path : str or Path
        The SQLite file.
    write : bool
        Whether the store was opened to write (``track ingest``) or to read.

    Returns
    -------
    str or None
        The cause, e.g. ``"directory /mnt/x is on a read-only file system"``.
    """
    p = Path(path)
    d = p.parent
    if not d.is_dir():
        return f"directory {d} does not exist"
    wal = f"SQLite's WAL mode needs to create {p.name}-wal and {p.name}-shm next to it"
    try:
        rofs = bool(os.statvfs(d).f_flag & os.ST_RDONLY)
    except OSError:
        rofs = False
    if rofs:
        return f"directory {d} is on a read-only file system" + ("" if write else f", and {wal}")
    if not os.access(d, os.W_OK | os.X_OK):
        return f"directory {d} is not writable (permission denied)" + ("" if write else f", and {wal}")
    if p.exists() and not os.access(p, os.R_OK):
        return "the file is not readable (permission denied)"
    if write and p.exists() and not os.access(p, os.W_OK):
        return "the file is read-only (permission denied)"
    return None


def _remove_empty_store(p: Path) -> None:
    """Remove the SQLite file ``p`` (with its ``-wal``/``-shm``/``-journal``) that a failed
    creation of a new store on a full disk left without a single table, so that "nothing was
    written" holds for the directory too.

    Called only when the disk is full, where SQLite cannot even open the file read-only (its
    WAL index needs space) and no other process can have committed a schema either. The file
    is judged by its bytes (sqlite.org/fileformat2.html): at most one page, the 16-byte magic
    string, an empty write-ahead log, and no cell on page 1 (the schema table's b-tree header
    at offset 100; cell count at bytes 103–104). Anything else is kept."""
    try:
        if not p.is_file():
            return
        wal = p.with_name(p.name + "-wal")
        if wal.is_file() and wal.stat().st_size != 0:
            return
        head = p.read_bytes()[: 65536 + 1]
        if head and (not head.startswith(b"SQLite format 3\x00") or len(head) < 105):
            return
        if head:
            page = int.from_bytes(head[16:18], "big")
            page = 65536 if page == 1 else page
            if len(head) > page or int.from_bytes(head[103:105], "big") != 0:
                return
        for side in ("-wal", "-shm", "-journal"):
            p.with_name(p.name + side).unlink(missing_ok=True)
        p.unlink()
    except OSError:
        pass


def _brief(exc: BaseException) -> str:
    """First line of a driver error, without SQLAlchemy's background links."""
    orig = getattr(exc, "orig", None) or exc
    text = str(orig).strip().splitlines()
    return text[0] if text else type(orig).__name__


def _axes_key(axes: Iterable[str]) -> int:
    """CRC-32 of the sorted, distinct axis names (the identity of an ingest's lock)."""
    import zlib

    return zlib.crc32("\n".join(sorted(set(axes))).encode())


class Store:
    """The history store on one database.

    Parameters
    ----------
    db : str or Path
        An SQLAlchemy URL (``postgresql+psycopg://user@host/db``, ``sqlite:///x.sqlite``) or
        a path of an SQLite file.
    create : bool
        Create the database (SQLite file) and run the migrations. With False, a missing
        SQLite file is an error and the schema must already be at ``head``.
    connect_timeout : float
        Seconds to wait for a server [s].
    busy_timeout : float, optional
        Seconds a writer waits for another writer's lock [s], SQLite and PostgreSQL (default
        :data:`BUSY_TIMEOUT_S`, or the environment variable ``DRIVELASH_STORE_BUSY_TIMEOUT``).

    Raises
    ------
    StoreError
        Unreachable server, missing driver, bad URL, unreadable file — one line.
    """

    def __init__(
        self,
        db: str | Path,
        *,
        create: bool = True,
        connect_timeout: float = 10.0,
        busy_timeout: float | None = None,
    ) -> None:
        self.url = _url(db)
        self.name = _show(self.url)
        self.busy_timeout = _busy_timeout(busy_timeout)
        backend = self.url.get_backend_name()
        self.backend = backend
        kw: dict[str, Any] = {}
        new_file: Path | None = None  # the SQLite file this call creates, if any
        if backend == "sqlite":
            path = _sqlite_file(self.url)
            if path is not None:
                p = Path(path)
                new_file = None if p.exists() else p
                if p.is_dir():  # was "cannot open the store (unable to open database file)"
                    raise StoreError(
                        f"{p}: is a directory, not a store file; give a file, e.g. {p / 'wear.sqlite'}"
                    )
                if not create and not p.is_file():
                    raise StoreError(
                        f"{p}: no such store (run `drivelash track ingest` first, or give --fleet FLEET.toml"
                        " or --db)"
                    )
                if not p.parent.is_dir():
                    raise StoreError(f"{p}: directory {p.parent} does not exist")
            kw["connect_args"] = {"timeout": self.busy_timeout}
        elif backend == "postgresql":
            kw["connect_args"] = {"connect_timeout": max(1, int(math.ceil(connect_timeout)))}
        try:
            self.engine: Engine = sa.create_engine(self.url, future=True, **kw)
        except (NoSuchModuleError, ModuleNotFoundError, ArgumentError) as exc:
            raise StoreError(f"--db {self.name}: unsupported database or missing driver ({exc})") from None
        if backend == "sqlite":
            event.listen(self.engine, "connect", _sqlite_pragmas)
        try:
            self._migrate(create)
        except (OperationalError, DBAPIError, OSError) as exc:
            self.engine.dispose()
            if new_file is not None and (_kind(exc) == "full" or self._disk_full_io(exc) is not None):
                _remove_empty_store(new_file)
            if _kind(exc) in ("locked", "full") or self._disk_full_io(exc) is not None:
                raise self.failure(exc, "nothing was written") from None  # type: ignore[misc]
            if isinstance(exc, OSError):
                raise
            err = self._access_error(exc, "write" if create else "read", "nothing was written")
            if err is not None:
                raise err from None
            raise StoreError(f"--db {self.name}: cannot open the store ({_brief(exc)})") from None

    # -- set-up ----------------------------------------------------------------------------
    def _migrate(self, create: bool) -> None:
        from alembic import command
        from alembic.config import Config
        from alembic.runtime.migration import MigrationContext
        from alembic.script import ScriptDirectory

        cfg = Config()
        cfg.set_main_option("script_location", str(MIGRATIONS))
        head = ScriptDirectory.from_config(cfg).get_current_head()
        with self.engine.connect() as conn:
            current = MigrationContext.configure(conn).get_current_revision()
        if current == head:
            return
        if not create:
            raise StoreError(
                f"--db {self.name}: schema revision {current} is not the current {head} "
                "(run `drivelash track ingest` to migrate)"
            )
        with self._write() as conn:
            # under the write lock: a process that started at the same time on the same empty
            # database may have created the schema meanwhile (it then is at head already)
            if MigrationContext.configure(conn).get_current_revision() == head:
                return
            cfg.attributes["connection"] = conn
            command.upgrade(cfg, "head")
            _wrote(conn)

    def _access_error(self, exc: BaseException, what: str, consequence: str) -> StoreError | None:
        """The one-line :class:`StoreError` for an SQLite file this process may not open or
        write (:func:`sqlite_access_problem`: read-only file system or directory, read-only
        file), else None. ``what``: "read" or "write"."""
        path = _sqlite_file(self.url)
        if path is None or not isinstance(exc, DBAPIError):
            return None
        text = str(getattr(exc, "orig", None) or exc).lower()
        if "unable to open database file" not in text and "readonly database" not in text:
            return None
        why = sqlite_access_problem(path, write=what == "write")
        if why is None:
            return None
        fix = (
            "give --db a writable place"
            if what == "write"
            else "copy the store to a writable directory and give --db the copy"
        )
        return StoreError(f"{path}: cannot {what} the store: {why}; {consequence} — {fix}")

    @contextmanager
    def _write(self) -> Iterator[sa.Connection]:
        """One write transaction holding the store's write lock from its first statement.

        SQLite: ``BEGIN IMMEDIATE`` (the file's write lock, waited for up to
        :attr:`busy_timeout`); PostgreSQL: the transaction-scoped advisory lock
        :data:`PG_WRITE_LOCK`, waited for up to :attr:`busy_timeout` as well (``SET LOCAL
        lock_timeout``, at least 1 ms: PostgreSQL reads 0 as no limit). Every write (schema
        migration included) goes through here, so two processes on one store never interleave
        a read-then-insert (two first ingests on an empty database both creating the schema,
        or both inserting one recording).

        A committed transaction marked with :func:`_wrote` (a schema created, an axis
        registered, a recording re-dated, a batch of results: what ``track ingest``'s messages
        count as written) is noted with :func:`drivelash.io.outputs.note_written`, so the line
        after Ctrl-C names the store rather than claiming nothing was written.
        """
        with self.engine.begin() as conn:
            conn.info.pop(_WROTE, None)
            if self.backend == "sqlite":
                conn.exec_driver_sql("BEGIN IMMEDIATE")
            elif self.backend == "postgresql":
                # the same time limit as SQLite's busy timeout: lock_timeout bounds every lock
                # wait of this transaction, the advisory lock's included (SQLSTATE 55P03 on
                # expiry, see _kind); 0 would mean "no limit" to PostgreSQL, so 1 ms at least
                ms = max(1, round(1000 * self.busy_timeout))
                conn.execute(sa.text("SELECT set_config('lock_timeout', :v, true)"), {"v": f"{ms}ms"})
                conn.execute(sa.text("SELECT pg_advisory_xact_lock(:k)"), {"k": PG_WRITE_LOCK})
            yield conn
            wrote = conn.info.pop(_WROTE, False)
        if wrote:
            from drivelash.io.outputs import note_written

            note_written(f"store:{self.name}", f"{self.name} (the transactions committed so far)")

    def failure(self, exc: BaseException, consequence: str) -> StoreError | None:
        """The one-line :class:`StoreError` for an operational failure of the store, else None.

        Parameters
        ----------
        exc : BaseException
            What the driver raised: a lock held by another writer beyond :attr:`busy_timeout`,
            a full database or disk (SQLite ``SQLITE_FULL``, PostgreSQL ``disk_full``, an
            ``OSError`` ENOSPC), or another database error.
        consequence : str
            What became of the work, e.g. ``"nothing of this ingest was written"``.

        Returns
        -------
        StoreError or None
            None for an exception that is no store failure (a bug: left to propagate).
        """
        kind = _kind(exc)
        if kind is None:
            return None
        free = self._disk_full_io(exc)
        if free is not None:
            return StoreError(
                f"{_sqlite_file(self.url)}: the disk is full ({free} bytes free; SQLite: {_brief(exc)}); "
                f"the transaction was rolled back and {consequence} — free space for the store and run it "
                "again"
            )
        if kind == "other":
            err = self._access_error(exc, "write", consequence)
            if err is not None:
                return err
        if kind == "locked":
            return StoreError(
                f"{self.name}: database is locked by another writer for more than {self.busy_timeout:g} s "
                f"(another 'track ingest' running?); {consequence} — run it again when the other one "
                "has finished"
            )
        brief = _brief(exc)
        if kind == "full":
            why = "" if brief.lower() == "database or disk is full" else f" ({brief})"
            return StoreError(
                f"{self.name}: database or disk is full{why}; the transaction was rolled back and "
                f"{consequence} — free space for the store and run it again"
            )
        return StoreError(
            f"{self.name}: the store failed ({brief}); {consequence} — check the database, then run it again"
        )

    def _disk_full_io(self, exc: BaseException) -> int | None:
        """The free bytes of the store's file system when ``exc`` is SQLite's "disk I/O error"
        on a full disk (less than :data:`FULL_DISK_BYTES` free); else None."""
        path = _sqlite_file(self.url)
        if path is None or not isinstance(exc, DBAPIError):
            return None
        if "disk i/o error" not in str(getattr(exc, "orig", None) or exc).lower():
            return None
        free = _free_bytes(Path(path).parent)
        return free if free is not None and free < FULL_DISK_BYTES else None

    @contextmanager
    def guard(self, consequence: str | Callable[[], str]) -> Iterator[None]:
        """Turn an operational failure of the store inside the block into a one-line
        :class:`StoreError` (:meth:`failure`); ``consequence`` (or its value when called at
        the failure) says what became of the work.

        Parameters
        ----------
        consequence : str or callable
            What became of the work (or a callable giving it at the failure).
        """
        try:
            yield
        except (DBAPIError, OSError) as exc:
            err = self.failure(exc, consequence() if callable(consequence) else consequence)
            if err is None:
                raise
            raise err from None

    def ingest_lock_file(self, axes: Iterable[str] = ()) -> Path | None:
        """The file whose advisory lock :meth:`ingest_lock` takes on an SQLite store: the hidden
        ``.NAME.ingest-CRC.lock`` beside the store file ``NAME``, CRC the checksum of ``axes``
        (None for other databases and for an in-memory SQLite store).

        Parameters
        ----------
        axes : iterable of str
            The axes (``machine/axis``) of the ingest.
        """
        path = _sqlite_file(self.url)
        if self.backend != "sqlite" or path is None:
            return None
        p = Path(path)
        return p.with_name(f".{p.name}.ingest-{_axes_key(axes):08x}.lock")

    @contextmanager
    def ingest_lock(
        self,
        axes: Iterable[str] = (),
        on_wait: Callable[[str], None] | None = None,
        timeout: float | None = None,
    ) -> Iterator[bool]:
        """Hold the store for one ingest of ``axes``: a second ingest of the same axes waits here
        until the first has finished, then finds the first one's results stored and does not
        estimate them again. Ingests of other axis sets (one writer per axis range for a bulk
        re-processing, docs/scaling.md) do not wait for each other.

        Without it two ingests started at once (two cron jobs, a user's second shell) both
        estimated every new recording and the store's unique keys kept one copy: the result was
        right, the work doubled. The lock is advisory and held by the process: an SQLite store
        takes an OS file lock (``filelock``) on :meth:`ingest_lock_file`, PostgreSQL a
        session-level advisory lock (:data:`PG_INGEST_LOCK` and the axes' checksum) on a
        connection of its own. Either is released when the process ends, however it ends
        (Ctrl-C, a crash, SIGKILL), so a dead ingest never blocks the next one. Where the lock
        file cannot be created (a directory without write access) the ingest goes on without
        it; the store's unique keys still keep one copy of each estimate.

        Parameters
        ----------
        axes : iterable of str
            The axes (``machine/axis``) of the ingest; the lock is that of their sorted set.
        on_wait : callable, optional
            ``on_wait(message)``, called once when another ingest holds the store, before
            waiting (e.g. to tell the user why nothing happens); Ctrl-C ends the wait.
        timeout : float, optional
            Longest wait [s]; None (default) waits as long as the other ingest runs.

        Yields
        ------
        bool
            True when the lock is held, False when the ingest goes on without it.

        Raises
        ------
        StoreError
            Another ingest still held the store after ``timeout`` seconds (nothing was written).
        """
        limit = math.inf if timeout is None else time.monotonic() + float(timeout)

        def too_long() -> StoreError:
            return StoreError(
                f"{self.name}: another 'track ingest' of these axes has been running for more than "
                f"{float(timeout):g} s (the wait's limit); nothing was written — run it again when "
                "the other one has finished"
            )

        axes = list(axes)
        key = _axes_key(axes)
        msg = (
            f"{self.name}: another 'track ingest' of these axes is running; waiting for it to finish "
            "(its results are then skipped here; Ctrl-C stops waiting, nothing written)"
        )
        if self.backend == "postgresql":
            with self.engine.connect() as conn:
                lock = sa.text("SELECT pg_try_advisory_lock(:k, :a)")
                keys = {"k": PG_INGEST_LOCK, "a": key - (1 << 32) if key >= 1 << 31 else key}  # int4
                told = False
                while not conn.execute(lock, keys).scalar():
                    conn.rollback()  # no transaction left open while waiting
                    if not told and on_wait is not None:
                        on_wait(msg)
                    told = True
                    if time.monotonic() >= limit:
                        raise too_long()
                    time.sleep(INGEST_LOCK_POLL_S)
                conn.commit()
                try:
                    yield True
                finally:
                    conn.execute(sa.text("SELECT pg_advisory_unlock(:k, :a)"), keys)
                    conn.commit()
            return
        path = self.ingest_lock_file(axes)
        if path is None:
            yield False
            return
        from filelock import FileLock, Timeout

        lock = FileLock(str(path))
        try:
            try:
                lock.acquire(timeout=0)
            except Timeout:
                if on_wait is not None:
                    on_wait(msg)
                try:
                    wait = -1 if timeout is None else max(0.0, limit - time.monotonic())
                    lock.acquire(timeout=wait, poll_interval=INGEST_LOCK_POLL_S)
                except Timeout:
                    raise too_long() from None
        except OSError:  # cannot create the lock file: go on without it (see above)
            yield False
            return
        try:
            yield True
        finally:
            lock.release()

    def close(self) -> None:
        """Release the connection pool."""
        self.engine.dispose()

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def revision(self) -> str | None:
        """The schema revision of the database (Alembic)."""
        from alembic.runtime.migration import MigrationContext

        with self.engine.connect() as conn:
            return MigrationContext.configure(conn).get_current_revision()

    # -- axes ------------------------------------------------------------------------------
    def upsert_axes(self, axes: Iterable[Any]) -> dict[str, int]:
        """Insert or update the axes of a fleet (``AxisSpec``-like objects); returns name → id.

        Parameters
        ----------
        axes : iterable of AxisSpec
            The fleet's axes.
        """
        ids: dict[str, int] = {}
        now = _now()
        with self._write() as conn:
            for a in axes:
                vals = {
                    "name": a.name,
                    "machine": a.name.split("/", 1)[0],
                    "drive_path": str(a.drive_path),
                    "drive_hash": a.drive_hash,
                    "threshold_rad": a.threshold_rad,
                    "transmission_mm_per_rad": a.transmission,
                    "horizon_days": a.horizon_days,
                    "not_excited_alarm": a.not_excited_alarm,
                    "updated_at": now,
                    "kind": getattr(a, "kind", "rotary"),
                }
                row = conn.execute(sa.select(axis_t.c.id).where(axis_t.c.name == a.name)).first()
                if row is None:
                    ids[a.name] = int(conn.execute(sa.insert(axis_t).values(**vals)).inserted_primary_key[0])
                    _wrote(conn)
                else:
                    conn.execute(sa.update(axis_t).where(axis_t.c.id == row.id).values(**vals))
                    ids[a.name] = int(row.id)
        return ids

    def axis_id(self, name: str, conn: sa.Connection | None = None) -> int:
        """Id of axis ``name`` (ensured to exist: an unknown axis is a one-line error).

        Parameters
        ----------
        name : str
            ``machine/axis``.
        conn : sqlalchemy.Connection, optional
            Run the query in this transaction.

        Raises
        ------
        StoreError
            No such axis (one line, with the closest name).
        """
        q = sa.select(axis_t.c.id).where(axis_t.c.name == name)
        rows = conn.execute(q).all() if conn is not None else self._read(q)
        row = rows[0] if rows else None
        if row is None:
            known = [r.name for r in self._read(sa.select(axis_t.c.name).order_by(axis_t.c.name))]
            import difflib

            # 0.7: 'M01/Z' → 'M01/X' (0.8) is a likely slip, 'M09/Z' → 'M04/X' (0.6, the shared
            # "M0" and "/") is not (session 30 tester B, B-10)
            close = difflib.get_close_matches(name, known, n=1, cutoff=0.7)
            hint = (
                f"; did you mean {close[0]!r}?"
                if close
                else f" ({count(len(known), 'axis', 'axes')} in the store)"
            )
            raise StoreError(f"{self.name}: no axis {name!r}{hint}")
        return int(row.id)

    def axes(self) -> list[dict[str, Any]]:
        """Every axis as a dict (columns of the axis table), sorted by name; ``kind`` is
        "rotary" or "prismatic" (NULL, an axis written before revision 0004, reads "rotary")."""
        rows = [dict(r._mapping) for r in self._read(sa.select(axis_t).order_by(axis_t.c.name))]
        for r in rows:
            r["kind"] = r.get("kind") or "rotary"
        return rows

    def _read(self, q: Any) -> list[Any]:
        with self.engine.connect() as conn:
            return list(conn.execute(q).all())

    # -- recordings and estimates -------------------------------------------------------------
    def known_files(self, axis_id: int, method: str, config_hash: str, code_version: str) -> set[tuple]:
        """(path, size, mtime_ns) of recordings of the axis that already have this estimate and
        it did not fail (under any of the paths their content was seen as: ``recording`` and
        ``recording_path``); a ``failed`` estimate is retried by every ingest.

        Parameters
        ----------
        axis_id : int
            Id of the axis (:meth:`axis_id`).
        method : str
            Estimator law.
        config_hash : str
            The axis's configuration hash (``AxisSpec.drive_hash``).
        code_version : str
            drivelash version of the estimate.
        """
        same = (
            recording_t.c.axis_id == axis_id,
            estimate_t.c.status != "failed",
            estimate_t.c.method == method,
            estimate_t.c.config_hash == config_hash,
            estimate_t.c.code_version == code_version,
        )
        out: set[tuple] = set()
        for files, joins in (
            (recording_t, ()),
            (recording_path_t, ((recording_t, recording_t.c.id == recording_path_t.c.recording_id),)),
        ):
            q = sa.select(files.c.path, files.c.size_bytes, files.c.mtime_ns)
            for table, on in joins:
                q = q.join(table, on)
            q = q.join(estimate_t, estimate_t.c.recording_id == recording_t.c.id).where(*same)
            out.update((r.path, int(r.size_bytes), int(r.mtime_ns)) for r in self._read(q))
        return out

    def known_contents(
        self, axis_id: int, method: str, config_hash: str, code_version: str, hashes: Iterable[str]
    ) -> dict[str, dict[str, Any]]:
        """The stored recordings of the axis among ``hashes`` (content hashes) that have this
        estimate and it did not fail — the identity :meth:`known_files` uses, by content
        instead of by file facts (a file moved, renamed, touched or copied).

        Parameters
        ----------
        axis_id : int
            Id of the axis (:meth:`axis_id`).
        method : str
            Estimator law.
        config_hash : str
            The axis's configuration hash (``AxisSpec.drive_hash``).
        code_version : str
            drivelash version of the estimate.
        hashes : iterable of str
            SHA-256 content hashes (hex) of the files.

        Returns
        -------
        dict
            content hash → the recording's columns (``path``, ``start_time``, ``duration_s``,
            ``sample_rate_hz``, ``samples``, ``time_spec_hash``) and the estimate's (``status``,
            ``reason``, ``delta``, …, ``estimate_rate_hz``).
        """
        want = sorted(set(hashes))
        cols = (
            recording_t.c.content_hash,
            recording_t.c.path,
            recording_t.c.start_time,
            recording_t.c.duration_s,
            recording_t.c.sample_rate_hz,
            recording_t.c.samples,
            recording_t.c.time_spec_hash,
            *[c for c in estimate_t.c if c.name not in ("id", "axis_id", "recording_id", "created_at")],
        )
        out: dict[str, dict[str, Any]] = {}
        for k in range(0, len(want), 500):
            q = (
                sa.select(*cols)
                .join(estimate_t, estimate_t.c.recording_id == recording_t.c.id)
                .where(
                    recording_t.c.axis_id == axis_id,
                    recording_t.c.content_hash.in_(want[k : k + 500]),
                    estimate_t.c.status != "failed",
                    estimate_t.c.method == method,
                    estimate_t.c.config_hash == config_hash,
                    estimate_t.c.code_version == code_version,
                )
            )
            out.update((r.content_hash, dict(r._mapping)) for r in self._read(q))
        return out

    def dated_files(
        self, axis_id: int
    ) -> dict[tuple[str, int, int], tuple[int, str | None, datetime | None]]:
        """(path, size, mtime_ns) → (recording id, time_spec_hash, start_time) of the axis's
        recordings that have an ``ok`` estimate (under any of the paths they were seen as).

        Parameters
        ----------
        axis_id : int
            Id of the axis (:meth:`axis_id`).
        """
        ok = sa.select(estimate_t.c.recording_id).where(
            estimate_t.c.status == "ok", estimate_t.c.axis_id == axis_id
        )
        cols = (recording_t.c.id, recording_t.c.time_spec_hash, recording_t.c.start_time)
        q1 = sa.select(recording_t.c.path, recording_t.c.size_bytes, recording_t.c.mtime_ns, *cols).where(
            recording_t.c.axis_id == axis_id, recording_t.c.id.in_(ok)
        )
        q2 = (
            sa.select(
                recording_path_t.c.path, recording_path_t.c.size_bytes, recording_path_t.c.mtime_ns, *cols
            )
            .join(recording_t, recording_t.c.id == recording_path_t.c.recording_id)
            .where(recording_t.c.axis_id == axis_id, recording_t.c.id.in_(ok))
        )
        out = {}
        for r in [*self._read(q1), *self._read(q2)]:
            out[(r[0], int(r[1]), int(r[2]))] = (int(r[3]), r[4], r[5])
        return out

    def redate(self, changes: Sequence[tuple[int, datetime | None, str]]) -> int:
        """Set (recording id, start time, time_spec_hash) in ONE transaction; returns how many
        start times changed.

        Parameters
        ----------
        changes : sequence of (int, datetime or None, str)
            (recording id, start time — naive = UTC —, time_spec_hash) per recording.
        """
        if not changes:
            return 0
        moved = 0
        with self._write() as conn:
            for rid, start, h in changes:
                old = conn.execute(
                    sa.select(recording_t.c.start_time).where(recording_t.c.id == rid)
                ).scalar()
                new = utc_naive(start)
                moved += old != new
                if old != new:
                    _wrote(conn)
                conn.execute(
                    sa.update(recording_t)
                    .where(recording_t.c.id == rid)
                    .values(start_time=new, time_spec_hash=h)
                )
        return moved

    def commit_batch(
        self,
        rows: Sequence[EstimateRow],
        axis_ids: dict[str, int],
        duplicates: list[str] | None = None,
        retried: list[tuple[str, str]] | None = None,
        replaced: list[str] | None = None,
        kept: list[str] | None = None,
    ) -> int:
        """Store a batch of results in ONE transaction; returns how many estimates were new or
        replaced a failed one.

        Idempotent: a recording (axis, content hash) is stored once; an estimate (recording,
        method, config hash, code version) is stored once — a repeated row is skipped, except
        that a new result replaces a stored ``failed`` estimate of the same identity (a retry:
        ``retried`` gets (path, new status); on success the recording's start time, length
        and rate are the new result's). Set
        based: a handful of statements per batch, not per row (the writer is the one serial
        part of an ingest). Every path a recording's content is seen under is kept
        (``recording_path``); a file with the content of a recording whose stored path still
        exists is a duplicate — the recording keeps its path, ``duplicates`` gets one line.

        A file rewritten in place (a new recording whose axis and path are those of a stored
        recording of other content) replaces that recording in the same transaction: its
        estimates and paths are deleted (``replaced`` gets the path), so the trend never counts
        the old and the new content of one file twice. The old recording stays only while its
        content is still at another path it was seen under (that path becomes its own) — or
        when the new content is a new recording whose start time (from the axis's time
        source) differs from the old one's: a new measurement under a fixed export name, not a
        re-export of the same one (a new file that cannot be dated still replaces); the old
        recording stays in the history, as a deleted file's does (``kept`` gets the path;
        session 30 tester B, B-02: a controller overwriting one file name each day kept 1
        recording of 6).

        Parameters
        ----------
        rows : sequence of EstimateRow
            The workers' results.
        axis_ids : dict
            ``machine/axis`` → id (:meth:`upsert_axes`).
        duplicates : list of str, optional
            Receives one line per duplicate file.
        retried : list of (str, str), optional
            Receives (path, new status) per retried ``failed`` estimate.
        replaced : list of str, optional
            Receives the path of each recording replaced by new content.
        kept : list of str, optional
            Receives the path of each file rewritten with a new measurement (another start
            time) whose old recording stays in the history.
        """
        if not rows:
            return 0
        now = _now()
        keyed = [(axis_ids[r.axis], r) for r in rows]  # an unknown axis fails before any write
        with self._write() as conn:
            _wrote(conn)
            hashes = sorted({r.content_hash for _, r in keyed})
            rec_id: dict[tuple[int, str], int] = {}
            rec_path: dict[tuple[int, str], str] = {}
            for k in range(0, len(hashes), 500):
                q = sa.select(
                    recording_t.c.id, recording_t.c.axis_id, recording_t.c.content_hash, recording_t.c.path
                ).where(recording_t.c.content_hash.in_(hashes[k : k + 500]))
                for x in conn.execute(q):
                    rec_id[(int(x.axis_id), x.content_hash)] = int(x.id)
                    rec_path[(int(x.axis_id), x.content_hash)] = x.path
            new_recs: dict[tuple[int, str], EstimateRow] = {}
            moved = []
            for aid, r in keyed:
                key = (aid, r.content_hash)
                first = new_recs[key].path if key in new_recs else rec_path.get(key)
                if first is not None and first != r.path and Path(first).is_file():
                    if duplicates is not None:
                        duplicates.append(f"{r.path}: same content as {first} (stored once, estimated once)")
                elif key in rec_id:
                    moved.append(
                        {
                            "rid": rec_id[key],
                            "p": r.path,
                            "s": r.size_bytes,
                            "m": r.mtime_ns,
                            "t": utc_naive(r.start_time),
                        }
                    )
                else:
                    new_recs.setdefault(key, r)
            if new_recs:
                conn.execute(
                    sa.insert(recording_t),
                    [
                        {
                            "axis_id": aid,
                            "content_hash": h,
                            "path": r.path,
                            "size_bytes": r.size_bytes,
                            "mtime_ns": r.mtime_ns,
                            "start_time": utc_naive(r.start_time),
                            "duration_s": r.duration_s,
                            "sample_rate_hz": r.sample_rate_hz,
                            "samples": r.samples,
                            "time_spec_hash": r.time_spec_hash,
                        }
                        for (aid, h), r in new_recs.items()
                    ],
                )
                fresh = sorted({h for _, h in new_recs})
                for k in range(0, len(fresh), 500):
                    q = sa.select(recording_t.c.id, recording_t.c.axis_id, recording_t.c.content_hash).where(
                        recording_t.c.content_hash.in_(fresh[k : k + 500])
                    )
                    rec_id.update({(int(x.axis_id), x.content_hash): int(x.id) for x in conn.execute(q)})
            if moved:
                # the same content under a new name or time stamp: keep the newest file facts,
                # and the start time the row carries (a file renamed to correct the time stamp
                # its name dates it by: ingest.plan's ``renamed_dated``; otherwise the stored one)
                conn.execute(
                    sa.update(recording_t)
                    .where(recording_t.c.id == sa.bindparam("rid"))
                    .values(
                        path=sa.bindparam("p"),
                        size_bytes=sa.bindparam("s"),
                        mtime_ns=sa.bindparam("m"),
                        start_time=sa.bindparam("t"),
                    ),
                    moved,
                )
            # every file of the batch now shows its row's content: a stored recording of other
            # content at that path was rewritten — by new content, by a copy of another stored
            # recording (a duplicate) or by a stored recording moved onto its name
            fresh_ids = {rec_id[k] for k in new_recs}
            _replace_rewritten(conn, keyed, rec_id, replaced, fresh_ids, kept)
            seen = [
                {
                    "rid_": rec_id[(aid, r.content_hash)],
                    "p_": r.path,
                    "s": r.size_bytes,
                    "m": r.mtime_ns,
                }
                for aid, r in {
                    (aid, r.path): (aid, r)
                    for aid, r in keyed
                    if not r.content_hash.startswith("unreadable:")
                }.values()
            ]
            if seen:
                conn.execute(
                    sa.delete(recording_path_t).where(
                        recording_path_t.c.recording_id == sa.bindparam("rid_"),
                        recording_path_t.c.path == sa.bindparam("p_"),
                    ),
                    seen,
                )
                conn.execute(
                    sa.insert(recording_path_t).values(
                        recording_id=sa.bindparam("rid_"),
                        path=sa.bindparam("p_"),
                        size_bytes=sa.bindparam("s"),
                        mtime_ns=sa.bindparam("m"),
                    ),
                    seen,
                )
            rids = sorted({rec_id[(aid, r.content_hash)] for aid, r in keyed})
            # estimate identity -> (estimate id, status); None: inserted by this batch
            have: dict[tuple[int, str, str, str], tuple[int | None, str]] = {}
            for k in range(0, len(rids), 500):
                q = sa.select(
                    estimate_t.c.recording_id,
                    estimate_t.c.method,
                    estimate_t.c.config_hash,
                    estimate_t.c.code_version,
                    estimate_t.c.id,
                    estimate_t.c.status,
                ).where(estimate_t.c.recording_id.in_(rids[k : k + 500]))
                have.update(((int(x[0]), x[1], x[2], x[3]), (int(x[4]), x[5])) for x in conn.execute(q))
            ins = []
            upd = []
            redo = []
            undated = []  # failed again, now dated (ingest dates failures): fill a missing start
            for aid, r in keyed:
                rid = rec_id[(aid, r.content_hash)]
                ident = (rid, r.method, r.config_hash, r.code_version)
                vals = {
                    "recording_id": rid,
                    "axis_id": aid,
                    "method": r.method,
                    "code_version": r.code_version,
                    "config_hash": r.config_hash,
                    "status": r.status,
                    "reason": r.reason,
                    "delta": _finite(r.delta),
                    "delta1_estimate": _finite(r.delta1_estimate),
                    "delta_std": _finite(r.delta_std),
                    "excitation_ok": r.excitation_ok,
                    "converged": r.converged,
                    "runtime_s": r.runtime_s,
                    "created_at": now,
                    "estimate_rate_hz": _finite(r.estimate_rate_hz),
                }
                prev = have.get(ident)
                if prev is None:
                    have[ident] = (None, r.status)
                    ins.append(vals)
                elif prev[0] is not None and prev[1] == "failed":
                    # a failed estimate is retried: the new result replaces it (same row)
                    have[ident] = (None, r.status)
                    upd.append(
                        {**{f"v_{k}": v for k, v in vals.items() if k != "recording_id"}, "eid": prev[0]}
                    )
                    if retried is not None:
                        retried.append((r.path, r.status))
                    if r.status != "ok" and r.start_time is not None:
                        undated.append({"rid_": rid, "st": utc_naive(r.start_time)})
                    if r.status == "ok":
                        redo.append(
                            {
                                "rid_": rid,
                                "st": utc_naive(r.start_time),
                                "d": r.duration_s,
                                "sr": r.sample_rate_hz,
                                "n": r.samples,
                                "th": r.time_spec_hash,
                            }
                        )
            if ins:
                conn.execute(sa.insert(estimate_t), ins)
            if upd:
                cols = [k.removeprefix("v_") for k in upd[0] if k != "eid"]
                conn.execute(
                    sa.update(estimate_t)
                    .where(estimate_t.c.id == sa.bindparam("eid"))
                    .values({c: sa.bindparam(f"v_{c}") for c in cols}),
                    upd,
                )
            if undated:
                conn.execute(
                    sa.update(recording_t)
                    .where(recording_t.c.id == sa.bindparam("rid_"), recording_t.c.start_time.is_(None))
                    .values(start_time=sa.bindparam("st")),
                    undated,
                )
            if redo:
                # the recording's facts as the successful estimate found them (a failed one may
                # have had no start time: e.g. a time format that did not match its name)
                conn.execute(
                    sa.update(recording_t)
                    .where(recording_t.c.id == sa.bindparam("rid_"))
                    .values(
                        start_time=sa.bindparam("st"),
                        duration_s=sa.bindparam("d"),
                        sample_rate_hz=sa.bindparam("sr"),
                        samples=sa.bindparam("n"),
                        time_spec_hash=sa.bindparam("th"),
                    ),
                    redo,
                )
        return len(ins) + len(upd)

    def seen_paths(self, axis: str) -> dict[str, set[str]]:
        """Every path the content of each recording of ``axis`` was seen under: content hash →
        paths (its stored ``path`` and those of ``recording_path``: copies, moves).

        Parameters
        ----------
        axis : str
            The axis (``machine/axis``).
        """
        out: dict[str, set[str]] = {}
        mine = (axis_t.c.name == axis, axis_t.c.id == recording_t.c.axis_id)
        q1 = sa.select(recording_t.c.content_hash, recording_t.c.path).where(*mine)
        q2 = (
            sa.select(recording_t.c.content_hash, recording_path_t.c.path)
            .join(recording_t, recording_t.c.id == recording_path_t.c.recording_id)
            .where(*mine)
        )
        for h, p in [*self._read(q1), *self._read(q2)]:
            out.setdefault(h, set()).add(p)
        return out

    def estimates(self, axis: str | None = None) -> list[dict[str, Any]]:
        """Recording-based estimates joined with their recordings, ordered by axis and time.

        Each dict has the estimate's columns plus ``axis``, ``axis_kind`` (the axis's kind,
        "rotary" — also for a store written before revision 0004 — or "prismatic": δ in m),
        ``path``, ``content_hash``, ``start_time``, ``duration_s``, ``sample_rate_hz``, ``samples``.

        Parameters
        ----------
        axis : str, optional
            Only this axis (``machine/axis``); default all.
        """
        q = (
            sa.select(
                axis_t.c.name.label("axis"),
                sa.func.coalesce(axis_t.c.kind, "rotary").label("axis_kind"),
                recording_t.c.path,
                recording_t.c.content_hash,
                recording_t.c.start_time,
                recording_t.c.duration_s,
                recording_t.c.sample_rate_hz,
                recording_t.c.samples,
                recording_t.c.size_bytes,
                recording_t.c.mtime_ns,
                *[c for c in estimate_t.c if c.name not in ("axis_id", "recording_id")],
            )
            .join(recording_t, recording_t.c.id == estimate_t.c.recording_id)
            .join(axis_t, axis_t.c.id == estimate_t.c.axis_id)
            .order_by(axis_t.c.name, recording_t.c.start_time, recording_t.c.path, estimate_t.c.id)
        )
        if axis is not None:
            q = q.where(axis_t.c.name == axis)
        return [dict(r._mapping) for r in self._read(q)]

    def current_estimates(self, axis: dict[str, Any]) -> list[dict[str, Any]]:
        """One estimate per recording of ``axis`` (a row of :meth:`axes`): the one of the axis's
        current configuration (its ``drive_hash``: drive file, method, estimation rate) from
        the newest drivelash version, else the newest estimate of that recording. What trends,
        alarms and reports use: the store keeps the estimates of every configuration, and a
        recording estimated under two of them is still one recording.

        Parameters
        ----------
        axis : dict
            A row of :meth:`axes` (its ``id`` and ``drive_hash``).
        """
        return one_per_recording(self.estimates(axis["name"]), axis.get("drive_hash"))

    def counts(self) -> dict[str, int]:
        """Rows per table (for status lines and tests)."""
        out = {}
        with self.engine.connect() as conn:
            for t in (axis_t, recording_t, estimate_t, measurement_t, alarm_t):
                out[t.name] = int(conn.execute(sa.select(sa.func.count()).select_from(t)).scalar_one())
        return out

    # -- other sources ---------------------------------------------------------------------------
    def add_measurement(
        self,
        axis: str,
        time: datetime,
        value: float,
        std: float | None,
        unit: str,
        source: str = "iso230-2",
        *,
        reference: str | None = None,
        key: str | None = None,
        details: dict[str, Any] | None = None,
        transmission_mm_per_rad: float | None = None,
    ) -> int:
        """Store a backlash value from another source (e.g. an ISO 230-2 reversal value B).

        Parameters
        ----------
        axis : str
            ``machine/axis`` (must exist: ingest the fleet first).
        time : datetime
            When it was measured (naive = UTC).
        value : float
            The value, e.g. B at the load [``unit``].
        std : float or None
            Its standard uncertainty [``unit``] (None when unknown).
        unit : {"rad", "mm", "um", "µm", "m"}
            Unit of ``value``/``std``; lengths are converted to rad with the axis's
            transmission when it has one — on a linear axis (``kind`` "prismatic") to m, the
            unit of its δ, and an angle gets no δ value.
        source : str
            Kind of measurement, e.g. ``"iso230-2"``.
        reference : str, optional
            Where it came from (file, report).
        key : str, optional
            Identity for idempotency (default: the time stamp); storing the same
            (axis, source, key) again returns the existing row's id.
        details : dict, optional
            JSON-serialisable extras (e.g. the other ISO 230-2 quantities).
        transmission_mm_per_rad : float, optional
            mm of load travel per rad for the conversion to rad when the axis has no
            transmission in the store (e.g. the ``[transmission]`` of an iso230 config).

        Returns
        -------
        int
            The measurement's id.

        Raises
        ------
        StoreError
            An unknown ``unit``, a non-finite ``value``, a ``std`` not finite ≥ 0, or an unknown
            axis. (A length without a transmission is stored unconverted: no value in rad.)
        """
        if unit != "rad" and unit not in LENGTH_UNITS:
            raise StoreError(f"measurement unit {unit!r}: must be rad, mm, um or m")
        if not (isinstance(value, int | float) and math.isfinite(value)):
            raise StoreError(f"measurement value: must be a finite number, got {value!r}")
        if std is not None and not (math.isfinite(std) and std >= 0):
            raise StoreError(f"measurement std: must be finite and >= 0, got {std!r}")
        t = utc_naive(time)
        k = key if key is not None else t.isoformat()
        with self._write() as conn:
            aid = self.axis_id(axis, conn)
            old = conn.execute(
                sa.select(measurement_t.c.id).where(
                    measurement_t.c.axis_id == aid, measurement_t.c.source == source, measurement_t.c.key == k
                )
            ).first()
            if old is not None:
                return int(old.id)
            tr, kind = conn.execute(
                sa.select(axis_t.c.transmission_mm_per_rad, axis_t.c.kind).where(axis_t.c.id == aid)
            ).one()
            tr = tr or transmission_mm_per_rad
            if kind == "prismatic":
                # a linear axis's δ is a length (m) already: no transmission; an angle is not its δ
                f = LENGTH_UNITS.get(unit, math.nan) * 1e-3
                ok = math.isfinite(f)
                v_rad, s_rad = (
                    (float(value) * f if ok else None),
                    (None if std is None or not ok else float(std) * f),
                )
            elif unit == "rad":
                v_rad, s_rad = float(value), std
            elif tr:
                f = LENGTH_UNITS[unit] / float(tr)
                v_rad, s_rad = float(value) * f, (None if std is None else float(std) * f)
            else:
                v_rad, s_rad = None, None
            return int(
                conn.execute(
                    sa.insert(measurement_t).values(
                        axis_id=aid,
                        source=source,
                        key=k,
                        time=t,
                        value=float(value),
                        std=std,
                        unit=unit,
                        value_rad=v_rad,
                        std_rad=s_rad,
                        reference=reference,
                        details=json.dumps(details) if details else None,
                        created_at=_now(),
                    )
                ).inserted_primary_key[0]
            )

    def measurements(self, axis: str | None = None) -> list[dict[str, Any]]:
        """Measurements of other sources, with ``axis``, ordered by axis and time.

        Parameters
        ----------
        axis : str, optional
            Only this axis (``machine/axis``); default all.
        """
        q = (
            sa.select(axis_t.c.name.label("axis"), *[c for c in measurement_t.c if c.name != "axis_id"])
            .join(axis_t, axis_t.c.id == measurement_t.c.axis_id)
            .order_by(axis_t.c.name, measurement_t.c.time)
        )
        if axis is not None:
            q = q.where(axis_t.c.name == axis)
        return [dict(r._mapping) for r in self._read(q)]

    # -- alarms ------------------------------------------------------------------------------------
    def sync_alarms(self, axis: str, alarms: Sequence[Any]) -> None:
        """Make the axis's active alarms equal ``alarms`` (objects with kind, key, message,
        data_time): new ones are raised, ones no longer present are cleared (kept as history).

        Parameters
        ----------
        axis : str
            ``machine/axis``.
        alarms : sequence
            The axis's alarms now (``kind``, ``key``, ``message``, ``data_time``).
        """
        now = _now()
        with self._write() as conn:
            aid = self.axis_id(axis, conn)
            rows = conn.execute(sa.select(alarm_t).where(alarm_t.c.axis_id == aid)).all()
            have = {(r.kind, r.key): r for r in rows}
            want = {(a.kind, a.key): a for a in alarms}
            for k, a in want.items():
                r = have.get(k)
                if r is None:
                    conn.execute(
                        sa.insert(alarm_t).values(
                            axis_id=aid,
                            kind=a.kind,
                            key=a.key,
                            message=a.message,
                            data_time=utc_naive(a.data_time),
                            raised_at=now,
                            cleared_at=None,
                        )
                    )
                else:
                    conn.execute(
                        sa.update(alarm_t)
                        .where(alarm_t.c.id == r.id)
                        .values(message=a.message, data_time=utc_naive(a.data_time), cleared_at=None)
                    )
            for k, r in have.items():
                if k not in want and r.cleared_at is None:
                    conn.execute(sa.update(alarm_t).where(alarm_t.c.id == r.id).values(cleared_at=now))

    def alarms(self, active_only: bool = True) -> list[dict[str, Any]]:
        """Alarms with ``axis``, ordered by axis, kind and key.

        Parameters
        ----------
        active_only : bool
            Only the alarms not cleared.
        """
        q = sa.select(axis_t.c.name.label("axis"), *[c for c in alarm_t.c if c.name != "axis_id"]).join(
            axis_t, axis_t.c.id == alarm_t.c.axis_id
        )
        if active_only:
            q = q.where(alarm_t.c.cleared_at.is_(None))
        q = q.order_by(axis_t.c.name, alarm_t.c.kind, alarm_t.c.key)
        return [dict(r._mapping) for r in self._read(q)]


def _replace_rewritten(
    conn: sa.Connection,
    keyed: Sequence[tuple[int, EstimateRow]],
    rec_id: dict[tuple[int, str], int],
    replaced: list[str] | None,
    fresh: set[int] | None = None,
    kept: list[str] | None = None,
) -> None:
    """Drop the recordings that the batch's files replace: same axis and path, another content
    hash (the file was rewritten, e.g. re-exported, or overwritten by a copy of another
    recording or by another recording moved onto its name). See :meth:`Store.commit_batch`.

    An unreadable file (``unreadable:`` marker, content unknown) replaces nothing. A new
    recording (its id in ``fresh``: first stored by this batch) replaces a dated one only when
    it starts at the same time or its start is unknown (it failed before being dated): another
    start time is another measurement written under the same name (a fixed export file name),
    and the old recording stays (``kept`` gets the path).
    """
    starts = {
        (aid, r.path): utc_naive(r.start_time)
        for aid, r in keyed
        if not r.content_hash.startswith("unreadable:")
    }
    # (axis, path) -> the recording whose content the file shows now
    by_path = {
        (aid, r.path): rec_id[(aid, r.content_hash)]
        for aid, r in keyed
        if not r.content_hash.startswith("unreadable:")
    }
    paths = sorted({p for _, p in by_path})
    gone: list[int] = []
    for k in range(0, len(paths), 500):
        chunk = paths[k : k + 500]
        q = sa.select(
            recording_t.c.id, recording_t.c.axis_id, recording_t.c.path, recording_t.c.start_time
        ).where(recording_t.c.path.in_(chunk))
        for x in conn.execute(q).all():
            rid = int(x.id)
            now_there = by_path.get((int(x.axis_id), x.path))
            if now_there is None or rid == now_there:
                continue
            if (
                fresh
                and now_there in fresh
                and x.start_time is not None
                and starts.get((int(x.axis_id), x.path)) not in (None, x.start_time)
            ):
                if kept is not None:  # another measurement under the same name: both stay
                    kept.append(x.path)
                continue
            others = conn.execute(
                sa.select(recording_path_t.c.path, recording_path_t.c.size_bytes, recording_path_t.c.mtime_ns)
                .where(recording_path_t.c.recording_id == rid, recording_path_t.c.path != x.path)
                .order_by(recording_path_t.c.id.desc())
            ).all()
            alive = next((o for o in others if Path(o.path).is_file()), None)
            if alive is not None:  # its content lives on under another name: keep it there
                conn.execute(
                    sa.update(recording_t)
                    .where(recording_t.c.id == rid)
                    .values(path=alive.path, size_bytes=alive.size_bytes, mtime_ns=alive.mtime_ns)
                )
            else:
                gone.append(rid)
                if replaced is not None:
                    replaced.append(x.path)
        # the rewritten path no longer shows the content of any other recording of the axis
        q = (
            sa.select(recording_path_t.c.id, recording_t.c.axis_id, recording_path_t.c.path,
                      recording_path_t.c.recording_id)
            .join(recording_t, recording_t.c.id == recording_path_t.c.recording_id)
            .where(recording_path_t.c.path.in_(chunk))
        )  # fmt: skip
        stale = [
            int(x.id)
            for x in conn.execute(q).all()
            if by_path.get((int(x.axis_id), x.path), int(x.recording_id)) != int(x.recording_id)
        ]
        if stale:
            conn.execute(sa.delete(recording_path_t).where(recording_path_t.c.id.in_(stale)))
    if gone:
        conn.execute(sa.delete(estimate_t).where(estimate_t.c.recording_id.in_(gone)))
        conn.execute(sa.delete(recording_path_t).where(recording_path_t.c.recording_id.in_(gone)))
        conn.execute(sa.delete(recording_t).where(recording_t.c.id.in_(gone)))


def _finite(x: float | None) -> float | None:
    return float(x) if x is not None and math.isfinite(x) else None


def _sqlite_pragmas(dbapi_conn: Any, _record: Any) -> None:
    cur = dbapi_conn.cursor()
    cur.execute("PRAGMA journal_mode=WAL")
    cur.execute("PRAGMA synchronous=NORMAL")
    cur.execute("PRAGMA foreign_keys=ON")
    cur.close()
