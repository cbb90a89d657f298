"""Ingest a fleet's recordings into the history store: workers compute, one writer commits.

Pipeline of :func:`ingest`:

1. **plan** (writer): register the fleet's axes; list each axis's recordings; skip the files
   whose (path, size, mtime) already carry an estimate with this method, config hash and
   code version that did not fail (a shortcut — the identity remains the content hash,
   checked on commit, where a new result replaces a ``failed`` estimate of that identity).
   A file whose (path, size, mtime) is unknown but whose size is that of such a recording is
   hashed: when the store holds that content with that estimate, it is not estimated again
   (moved, renamed, touched or copied) — the stored estimate's row with the file's new facts
   is committed instead, first, which records the new path (or the duplicate);
2. **compute** (workers): :func:`~drivelash.wear.estimate.estimate_recording` per file —
   serially, in local processes (``workers``) or on a Dask distributed cluster
   (``dask="local"`` starts a ``LocalCluster``; otherwise a scheduler address);
3. **commit** (writer): results are committed in batches of ``batch_size`` rows (or every
   ``batch_seconds``), each batch in one transaction. A crash (even SIGKILL) loses at most
   the uncommitted batch, which the next run recomputes; a repeated result is skipped by
   the store's unique keys, so every recording ends up stored exactly once.

A worker that dies loses no recording: Dask reschedules its tasks (the scheduler's
``allowed-failures``); the local pool is rebuilt and its pending tasks resubmitted, up to
:data:`MAX_ATTEMPTS` times, after which the recording is stored as failed with that reason.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

from drivelash.errors import DrivelashError
from drivelash.wear.estimate import RecordingTask, code_version, content_hash, estimate_recording
from drivelash.wear.fleet import Fleet
from drivelash.wear.store import EstimateRow, Store, utc_naive
from drivelash.wear.words import count

__all__ = ["DaskRunner", "IngestReport", "SchedulerError", "check_files", "ingest", "plan", "stored_row"]

#: Times a recording is tried when its worker process dies before it is stored as failed.
MAX_ATTEMPTS = 3
#: Rows per committed batch, and the longest time between commits [s].
BATCH_SIZE = 64
BATCH_SECONDS = 2.0
#: Dask setting left unset for the workers of ``--dask local`` (see :class:`DaskRunner`).
LOCAL_WORKER_ENV_KEY = "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_"


class SchedulerError(DrivelashError):
    """The Dask scheduler cannot be reached or the cluster cannot be started."""


@dataclass
class IngestReport:
    """What an ingest run did.

    Attributes
    ----------
    planned : int
        Recordings to estimate (no estimate of this method, configuration and code version).
    skipped : int
        Recordings already stored under their path, size and mtime (not read again).
    stored : int
        Estimates committed that were new or replaced a stored ``failed`` one.
    failed : int
        Estimates whose recording could not be read or validated (``status = "failed"``).
    batches : int
        Commit transactions.
    axes : list of str
        The fleet's axes (``machine/axis``).
    wall_s : float
        Wall time of the run [s].
    compute_s : float
        Sum of the workers' read + validate + estimate times [s].
    failures : list of str
        The reason of each failed estimate.
    warnings : list of str
        Planning warnings (e.g. an axis whose ``recordings`` glob matches no file).
    redated : int
        Stored recordings whose start time changed (a new ``time`` specification).
    duplicates : list of str
        One line per file whose content is a stored recording still at its own path.
    retried : int
        Stored ``failed`` estimates this run computed again (replaced by the new result) …
    still_failing : int
        … and how many of those failed again.
    replaced : int
        Stored recordings replaced by a new content of their file (same axis and path).
    rewritten_new : int
        Files rewritten with a new measurement (another start time, e.g. a fixed export file
        name): the new recording is stored, the old one stays in the history.
    new_axes : int
        Axes of the fleet that this ingest added to the store (registered before any estimate).
    moved : int
        Stored recordings found under a new path or file time (moved, renamed, touched): their
        new facts recorded, not estimated again (copies of a stored recording are ``duplicates``).
    renamed_dated : int
        Of ``moved``: recordings dated by their file name (``time = "filename"``) whose new name
        carries another time stamp — they take the new one (a rename that corrects a date).
    """

    planned: int = 0
    skipped: int = 0
    stored: int = 0
    failed: int = 0
    batches: int = 0
    axes: list[str] = field(default_factory=list)
    wall_s: float = 0.0
    compute_s: float = 0.0
    failures: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    redated: int = 0
    duplicates: list[str] = field(default_factory=list)
    retried: int = 0
    still_failing: int = 0
    replaced: int = 0
    rewritten_new: int = 0
    new_axes: int = 0
    moved: int = 0
    renamed_dated: int = 0


def plan(
    fleet: Fleet,
    store: Store,
    warnings: list[str] | None = None,
    known: list[EstimateRow] | None = None,
    hash_threads: int = 1,
    renamed_dated: list[str] | None = None,
) -> tuple[dict[str, int], list[RecordingTask], int]:
    """Register the axes and list the recordings still to estimate.

    Parameters
    ----------
    fleet : Fleet
        The inventory.
    store : Store
        The history store.
    warnings : list of str, optional
        Receives one line per axis whose ``recordings`` glob matches no file.
    known : list of EstimateRow, optional
        When given, a file whose (path, size, mtime) is unknown but whose content the store
        already holds with this estimate identity (a file moved, renamed, touched or copied)
        is no task: it is hashed (only when its size is that of such a recording) and
        receives here a row built from the stored estimate with the file's new facts
        (:func:`stored_row`), for :meth:`~drivelash.wear.store.Store.commit_batch` to record
        the new path (a move) or the copy (a duplicate). Without it such files are tasks.
    hash_threads : int
        Threads hashing those files (hashing and reading release the GIL): ``ingest`` gives
        its worker count, so the check keeps pace with the estimating it replaces.
    renamed_dated : list of str, optional
        Receives the path of each such known file dated by its name (``time = "filename"``)
        whose name gives another start time than the stored one and that is a move (the stored
        path is gone), not a copy: its row in ``known`` carries the new time (the user renamed
        it to correct the date). A name that no longer parses keeps the stored time.

    Returns
    -------
    axis_ids : dict
        ``machine/axis`` → id in the store.
    tasks : list of RecordingTask
        Recordings without an estimate of this method/config/code version, by axis and path.
    skipped : int
        Recordings already stored under their path, size and mtime.
    """
    ids = store.upsert_axes(fleet.axes)
    ver = code_version()
    tasks: list[RecordingTask] = []
    skipped = 0
    for a in fleet.axes:
        seen = store.known_files(ids[a.name], a.method, a.drive_hash, ver)
        sizes = {s for _, s, _ in seen}  # equal content has equal size: hash only those files
        entries = a.entries()
        if not entries and warnings is not None:
            warnings.append(f"{fleet.path}: axis {a.name!r}: 'recordings' = {a.recordings!r} matches no file")
        todo: list[tuple[Path, int, int]] = []
        for f in entries:
            if (str(f.path), f.size, f.mtime_ns) in seen:
                skipped += 1
            else:
                todo.append((f.path, f.size, f.mtime_ns))
        digests: dict[Path, str] = {}
        if known is not None:
            check = [p for p, size, _ in todo if size in sizes]
            for p, (digest, exc) in zip(check, _hash_all(check, hash_threads), strict=True):
                if exc is None:  # an unreadable file is a task: the worker stores why
                    digests[p] = digest
        stored: dict[str, dict[str, Any]] = {}
        if digests:
            stored = store.known_contents(ids[a.name], a.method, a.drive_hash, ver, digests.values())
        for p, size, mtime in todo:
            hit = stored.get(digests.get(p, ""))
            if hit is not None and known is not None:
                row = stored_row(a.name, str(p), size, mtime, digests[p], hit)
                start, was = _start_from_name(p, a.time), hit["start_time"]
                # a copy (the stored file still exists elsewhere) is a duplicate: the recording
                # keeps its path and time (Store.commit_batch); only a move takes the new name's
                moved = hit["path"] == str(p) or not Path(hit["path"]).is_file()
                if moved and start is not None and was is not None and start != utc_naive(was):
                    row = replace(row, start_time=start)
                    if renamed_dated is not None:
                        renamed_dated.append(str(p))
                known.append(row)
                continue
            tasks.append(
                RecordingTask(
                    a.name,
                    str(p),
                    size,
                    mtime,
                    a.drive,
                    a.time,
                    a.method,
                    a.drive_hash,
                    ver,
                    a.estimate_rate_hz,
                    getattr(a, "kind", "rotary"),
                )
            )
    return ids, tasks, skipped


def _start_from_name(path: Path, spec: Any) -> datetime | None:
    """The start time (naive UTC) the file name gives under a ``filename`` time specification;
    None for other sources or a name that does not parse."""
    from drivelash.wear.estimate import recording_start

    if getattr(spec, "source", None) != "filename":
        return None
    try:
        return recording_start(path, spec)
    except DrivelashError:
        return None


def _hash_all(paths: Sequence[Path], threads: int) -> list[tuple[str, OSError | None]]:
    """:func:`~drivelash.wear.estimate.content_hash` of each path, in ``threads`` threads."""
    if threads <= 1 or len(paths) <= 1:
        return [content_hash(p) for p in paths]
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(max_workers=min(threads, len(paths))) as pool:
        return list(pool.map(content_hash, paths))


def stored_row(axis: str, path: str, size: int, mtime: int, digest: str, rec: dict[str, Any]) -> EstimateRow:
    """The result row of a stored estimate (a row of
    :meth:`~drivelash.wear.store.Store.known_contents`) for its content seen at another file
    (``path``, ``size``, ``mtime``): what the estimator would return for that file, without
    estimating it again (``runtime_s`` 0).
    """
    return EstimateRow(
        axis=axis,
        path=path,
        size_bytes=size,
        mtime_ns=mtime,
        content_hash=digest,
        start_time=rec["start_time"],
        duration_s=rec["duration_s"],
        sample_rate_hz=rec["sample_rate_hz"],
        samples=rec["samples"],
        method=rec["method"],
        code_version=rec["code_version"],
        config_hash=rec["config_hash"],
        status=rec["status"],
        reason=rec["reason"] or "",
        delta=rec["delta"],
        delta1_estimate=rec["delta1_estimate"],
        delta_std=rec["delta_std"],
        excitation_ok=None if rec["excitation_ok"] is None else bool(rec["excitation_ok"]),
        converged=None if rec["converged"] is None else bool(rec["converged"]),
        runtime_s=0.0,
        estimate_rate_hz=rec["estimate_rate_hz"],
        time_spec_hash=rec["time_spec_hash"],
    )


def redate(fleet: Fleet, store: Store) -> list[tuple[int, object, str]]:
    """(recording id, start time, spec hash) for every stored recording (with an ``ok``
    estimate) of the fleet whose ``time`` specification changed since it was dated (or is
    unknown: stored before revision 0003). Reads only what the specification needs (nothing
    for ``filename``, a stat for ``mtime``, the file for ``column``/``metadata``); nothing is
    written here.

    Raises
    ------
    ConfigError
        A recording cannot be dated with the new specification (e.g. no such time column):
        one line naming the fleet file, the axis, the key and the file.
    """
    from drivelash.errors import ConfigError
    from drivelash.io.formats import read_raw
    from drivelash.wear.estimate import recording_start
    from drivelash.wear.fleet import time_spec_hash

    names = {a["name"]: a["id"] for a in store.axes()}
    out: list[tuple[int, object, str]] = []
    for k, a in enumerate(fleet.axes):
        if a.name not in names:
            continue
        h = time_spec_hash(a.time)
        dated = store.dated_files(names[a.name])
        done: set[int] = set()
        for f in a.entries():
            p = f.path
            hit = dated.get((str(p), f.size, f.mtime_ns))
            if hit is None or hit[1] == h or hit[0] in done:
                continue
            try:
                meta = read_raw(p).meta if a.time.source == "metadata" else None
                start = recording_start(p, a.time, meta)
            except DrivelashError as exc:
                what = a.time.column if a.time.source == "column" else a.time.key
                key = {"column": "time.column", "metadata": "time.key"}.get(a.time.source, "time")
                reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
                reason = reason.removeprefix(f"{p}, ").removeprefix(f"{p}: ")
                raise ConfigError(
                    f"{fleet.path}: table [[axis]] #{k + 1} (id {a.name!r}), key '{key}'"
                    f"{f' = {what!r}' if a.time.source in ('column', 'metadata') else ''}: "
                    f"cannot re-date {p} with the changed time specification ({reason}); nothing was written"
                ) from None
            done.add(hit[0])
            out.append((hit[0], start, h))
    return out


def check_files(fleet: Fleet) -> None:
    """Refuse what the fleet's files show to be a configuration slip, before anything is written.

    Raises
    ------
    ConfigError
        One line naming the fleet file and the axis: a file (resolved path) matched by the
        ``recordings`` of two axes (it would be estimated with both axes' drive parameters);
        a ``time`` taken from the file name that dates none of the axis's files (a ``format``
        or ``pattern`` that does not fit the names: every recording would be stored as failed);
        a ``time`` column whose first file starts before
        :data:`~drivelash.wear.estimate.EARLIEST_COLUMN_START` (a relative time, not POSIX
        time stamps: every recording would be dated 1970-01-01).
    """
    from drivelash.errors import ConfigError
    from drivelash.wear.estimate import recording_start

    owner: dict[tuple[int, int], int] = {}  # by identity: a symlink or hard link is the same file
    for k, a in enumerate(fleet.axes):
        entries = a.entries()
        files = [f.path for f in entries]
        for f in entries:
            p = f.path
            j = owner.setdefault(f.ident, k)
            if j != k:
                b = fleet.axes[j]
                raise ConfigError(
                    f"{fleet.path}: table [[axis]] #{k + 1} (id {a.name!r}), key 'recordings': {p} is "
                    f"matched by [[axis]] #{j + 1} (id {b.name!r}) too (a recording belongs to one axis: "
                    "it would be estimated with both axes' drives); nothing was written"
                )
        if a.time.source == "column" and files:
            # a relative time column (t from 0 s) dated every recording 1970-01-01 silently:
            # the first file shows it, before anything is written
            try:
                recording_start(files[0], a.time)
            except DrivelashError as exc:
                reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
                if "relative time" in reason:
                    raise ConfigError(
                        f"{fleet.path}: table [[axis]] #{k + 1} (id {a.name!r}), key 'time.column' = "
                        f"{a.time.column!r}: {reason} — date the recordings by 'filename', 'mtime' or "
                        "'metadata', or name a column of POSIX or ISO 8601 time stamps; nothing was written"
                    ) from None
        if a.time.source != "filename" or not files:
            continue
        first = None
        for p in files:
            try:
                recording_start(p, a.time)
                break
            except DrivelashError as exc:
                if first is None:
                    first = (p, str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
        else:
            assert first is not None
            p, reason = first
            reason = reason.removeprefix(f"{p}, ").removeprefix(f"{p}: ")
            raise ConfigError(
                f"{fleet.path}: table [[axis]] #{k + 1} (id {a.name!r}), key 'time': dates none of the "
                f"{count(len(files), 'recording')} (e.g. {p.name}: {reason}); nothing was written"
            )


# ------------------------------------------------------------------------------------ executors
def _serial(
    tasks: Sequence[RecordingTask], fn: Callable[[RecordingTask], EstimateRow]
) -> Iterator[EstimateRow]:
    for t in tasks:
        yield fn(t)


def _died(task: RecordingTask, why: str) -> EstimateRow:
    return EstimateRow(
        axis=task.axis,
        path=task.path,
        size_bytes=task.size_bytes,
        mtime_ns=task.mtime_ns,
        content_hash=content_hash(task.path)[0],
        start_time=None,
        duration_s=None,
        sample_rate_hz=None,
        samples=None,
        method=task.method,
        code_version=task.code_version,
        config_hash=task.config_hash,
        status="failed",
        reason=f"{task.path}: {why}",
    )


def _processes(
    tasks: Sequence[RecordingTask], fn: Callable[[RecordingTask], EstimateRow], workers: int
) -> Iterator[EstimateRow]:
    """Local process pool; a dead worker breaks the pool: rebuild it and resubmit what is pending."""
    from concurrent.futures import FIRST_COMPLETED, wait
    from concurrent.futures.process import BrokenProcessPool

    from drivelash._pool import process_pool

    attempts = dict.fromkeys(range(len(tasks)), 0)
    pending_idx = list(range(len(tasks)))
    while pending_idx:
        with process_pool(workers) as pool:  # Ctrl-C: cancelled and terminated at once
            futs = {}
            for i in pending_idx:
                attempts[i] += 1
                futs[pool.submit(fn, tasks[i])] = i
            pending_idx = []
            broken = False
            remaining = set(futs)
            while remaining:
                done, remaining = wait(remaining, return_when=FIRST_COMPLETED)
                for f in done:
                    i = futs[f]
                    try:
                        yield f.result()
                    except BrokenProcessPool:
                        broken = True
                        if attempts[i] >= MAX_ATTEMPTS:
                            yield _died(
                                tasks[i], f"worker process died {attempts[i]} times on this recording"
                            )
                        else:
                            pending_idx.append(i)
            if broken:
                pending_idx.sort()


class DaskRunner:
    """A connected Dask client (``"local"`` starts a ``LocalCluster``); connect before any write.

    Raises
    ------
    SchedulerError
        The scheduler cannot be reached (one line, after ``timeout`` seconds).
    """

    def __init__(self, address: str, workers: int = 2, timeout: float = 10.0) -> None:
        try:
            from distributed import Client, LocalCluster
        except ImportError:  # pragma: no cover - dask is a pinned dependency of [batch]
            raise SchedulerError("--dask: dask.distributed is not installed (drivelash[batch])") from None
        import logging

        for name in ("distributed", "distributed.nanny", "distributed.scheduler", "distributed.worker"):
            logging.getLogger(name).setLevel(logging.CRITICAL)
        self.address = address
        self.cluster = None
        try:
            if address == "local":
                import dask

                # the workers get the memory allocator the serial process has: Dask's default
                # MALLOC_TRIM_THRESHOLD_=65536 turns off glibc's dynamic mmap threshold, so every
                # large temporary is mapped and page-faulted afresh (measured: +60–75 % CPU per
                # recording, docs/scaling.md); None unsets it (and keeps it out of os.environ)
                with dask.config.set({LOCAL_WORKER_ENV_KEY: None}):
                    self.cluster = LocalCluster(
                        n_workers=max(1, workers),
                        threads_per_worker=1,
                        processes=True,
                        dashboard_address=None,
                        silence_logs=logging.CRITICAL,
                    )
                self.client = Client(self.cluster)
            else:
                self.client = Client(address, timeout=f"{timeout:g}s")
        except (OSError, TimeoutError, ValueError) as exc:
            if self.cluster is not None:
                self.cluster.close()
            msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise SchedulerError(f"--dask {address}: cannot reach the scheduler ({msg})") from None

    def run(
        self, tasks: Sequence[RecordingTask], fn: Callable[[RecordingTask], EstimateRow]
    ) -> Iterator[EstimateRow]:
        """Results as they complete; a task whose workers keep dying becomes a failed row."""
        from distributed import as_completed

        futs = self.client.map(fn, list(tasks), pure=False, retries=0)
        index = {f.key: i for i, f in enumerate(futs)}
        for f in as_completed(futs):
            i = index[f.key]
            try:
                yield f.result()
            except Exception as exc:  # noqa: BLE001 - KilledWorker after repeated worker deaths
                yield _died(tasks[i], f"worker died while estimating ({type(exc).__name__})")

    def close(self) -> None:
        """Close the client (and the local cluster)."""
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()

    def __enter__(self) -> DaskRunner:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# ------------------------------------------------------------------------------------ ingest
def ingest(
    fleet: Fleet,
    store: Store,
    *,
    workers: int = 1,
    dask: str | DaskRunner | None = None,
    batch_size: int = BATCH_SIZE,
    batch_seconds: float = BATCH_SECONDS,
    progress: Callable[[int, int], None] | None = None,
    compute: Callable[[RecordingTask], EstimateRow] = estimate_recording,
    update_alarms: bool = True,
    on_wait: Callable[[str], None] | None = None,
) -> IngestReport:
    """Estimate every new recording of ``fleet`` and commit the results to ``store``.

    One ingest of the same axes runs at a time (:meth:`~drivelash.wear.store.Store.ingest_lock`):
    a second one waits for the first and then skips what the first stored.

    Parameters
    ----------
    fleet : Fleet
        The inventory (:func:`~drivelash.wear.fleet.load_fleet`).
    store : Store
        The history store.
    workers : int
        Local worker processes (1 = in this process); with ``dask="local"`` the
        ``LocalCluster``'s worker count. Also the threads of :func:`plan` hashing the files
        whose (path, size, mtime) is unknown (a stored content is not estimated again).
    dask : str or DaskRunner, optional
        ``"local"`` or a scheduler address (``tcp://host:8786``), connected before anything
        is written; or an already connected :class:`DaskRunner` (kept open).
    batch_size, batch_seconds : int, float
        Commit when this many results are waiting or this long after the last commit.
    progress : callable, optional
        ``progress(done, total)`` after each result.
    compute : callable
        The worker function (default :func:`~drivelash.wear.estimate.estimate_recording`).
    update_alarms : bool
        Re-evaluate trend, forecast and alarms of the axes at the end.
    on_wait : callable, optional
        ``on_wait(message)`` once when another ingest of the same axes holds the store and
        this one waits.

    Returns
    -------
    IngestReport
    """
    t0 = time.perf_counter()
    runner = DaskRunner(dask, workers) if isinstance(dask, str) else dask  # connect before writing
    rep = IngestReport(axes=[a.name for a in fleet.axes])
    try:
        # a lock held too long by another writer, a full disk: one line saying what is stored
        with store.guard(lambda: _what_was_written(rep)), store.ingest_lock(rep.axes, on_wait):
            return _ingest(
                fleet,
                store,
                runner,
                workers,
                batch_size,
                batch_seconds,
                progress,
                compute,
                update_alarms,
                t0,
                rep,
            )
    finally:
        if isinstance(dask, str) and runner is not None:
            runner.close()


def _ingest(
    fleet: Fleet,
    store: Store,
    runner: DaskRunner | None,
    workers: int,
    batch_size: int,
    batch_seconds: float,
    progress: Callable[[int, int], None] | None,
    compute: Callable[[RecordingTask], EstimateRow],
    update_alarms: bool,
    t0: float,
    rep: IngestReport,
) -> IngestReport:
    # every step below sees one listing of each axis's files: one glob and one stat per file
    fleet = fleet.listed()
    check_files(fleet)  # a file of two axes, no file datable: error, nothing written
    changes = redate(fleet, store)  # a recording that cannot be re-dated: error, nothing written
    known: list[EstimateRow] = []  # files with the content of a stored estimate: not estimated
    had = {a["name"] for a in store.axes()}
    renamed: list[str] = []
    ids, tasks, skipped = plan(fleet, store, rep.warnings, known, hash_threads=workers, renamed_dated=renamed)
    rep.new_axes = len(set(ids) - had)
    rep.planned, rep.skipped = len(tasks), skipped
    if runner is not None:
        results = runner.run(tasks, compute)
    elif workers > 1 and len(tasks) > 1:
        results = _processes(tasks, compute, workers)
    else:
        results = _serial(tasks, compute)
    rep.redated = store.redate(changes)  # one transaction
    batch: list[EstimateRow] = []
    last = time.monotonic()
    done = 0

    def flush() -> None:
        nonlocal batch, last
        if batch:
            again: list[tuple[str, str]] = []
            gone: list[str] = []
            kept: list[str] = []
            rep.stored += store.commit_batch(batch, ids, rep.duplicates, again, gone, kept)
            rep.replaced += len(gone)
            rep.rewritten_new += len(set(kept) - set(gone))  # older ones kept by earlier runs again
            rep.retried += len(again)
            rep.still_failing += sum(status != "ok" for _, status in again)
            rep.batches += 1
        batch = []
        last = time.monotonic()

    # their new paths first, through the same commit as a result (a move or a duplicate)
    for k in range(0, len(known), batch_size):
        batch = known[k : k + batch_size]
        n, dups = len(batch), len(rep.duplicates)
        flush()
        rep.moved += n - (len(rep.duplicates) - dups)
    rep.renamed_dated = len(renamed)
    now = datetime.now(UTC).replace(tzinfo=None)
    future: list[EstimateRow] = [r for r in known if _future(r, now)]
    new_paths: set[str] = set()
    specs = {a.name: a for a in fleet.axes}
    try:
        for row in results:
            row = _dated(row, specs.get(row.axis))
            new_paths.add(row.path)
            if _future(row, now):
                future.append(row)
            done += 1
            rep.compute_s += row.runtime_s
            if row.status != "ok":
                rep.failed += 1
                rep.failures.append(row.reason)
            batch.append(row)
            if len(batch) >= batch_size or time.monotonic() - last >= batch_seconds:
                flush()
            if progress is not None:
                progress(done, len(tasks))
    finally:
        # Ctrl-C or a store failure in this loop: the process pool stops now (cancelled,
        # terminated), not when the garbage collector finds the suspended generator
        close = getattr(results, "close", None)
        if close is not None:
            close()
    flush()
    from drivelash.wear.alarms import FUTURE_TOLERANCE_DAYS

    for row in future:
        rep.warnings.append(
            f"{row.path}: dated {row.start_time:%Y-%m-%d %H:%M} UTC, more than "
            f"{FUTURE_TOLERANCE_DAYS:g} day after the time of this ingest ({now:%Y-%m-%d %H:%M} UTC): "
            "left out of the axis's trend, forecast and alarms — a wrong clock or file name?"
        )
    _warn_store_notes(fleet, store, new_paths, rep.warnings)
    if update_alarms:
        from drivelash.wear.alarms import refresh_alarms

        refresh_alarms(store, [a.name for a in fleet.axes], fleet)
    rep.wall_s = time.perf_counter() - t0
    return rep


def _warn_store_notes(fleet: Fleet, store: Store, new_paths: set[str], warnings: list[str]) -> None:
    """Per axis of ``fleet``, one warning line for its stored recordings that the fleet file no
    longer matches (their files exist: left out of its trend and alarms,
    :func:`~drivelash.wear.alarms.split_unmatched`), and one for its recordings estimated by this
    ingest that share start time, duration and sample count with another stored recording of
    the axis (the same measurement exported twice: :func:`~drivelash.wear.alarms.twin_groups`)."""
    from drivelash.wear.alarms import matched_files, split_unmatched, twin_groups, twin_note, unmatched_note

    specs = {x.name: x for x in fleet.axes}
    for a in store.axes():
        spec = specs.get(a["name"])
        if spec is None:
            continue
        seen = store.seen_paths(a["name"])
        rows, out = split_unmatched(store.current_estimates(a), matched_files(spec), seen)
        if out:
            warnings.append(unmatched_note(a["name"], out, fleet.path.name))
        if new_paths:
            groups = [g for g in twin_groups(rows) if any(r["path"] in new_paths for r in g)]
            note = twin_note(a["name"], groups)
            if note is not None:
                warnings.append(note)


def _dated(row: EstimateRow, spec: Any) -> EstimateRow:
    """A failed result with its start time when the axis's ``time`` source still gives one (the
    estimator stops at the first bad column, before dating the file): a failed recording is then
    placed in the axis's history, so status can say that the latest recordings failed (session
    30 tester B, B-06: ten failed recordings of a lost load encoder were undated and invisible).
    Unchanged when it is dated, ok, unreadable or the source gives no time."""
    if (
        row.status == "ok"
        or row.start_time is not None
        or spec is None
        or row.content_hash.startswith("unreadable:")
    ):
        return row
    from drivelash.io.formats import read_raw
    from drivelash.wear.estimate import recording_start

    try:
        meta = read_raw(Path(row.path)).meta if spec.time.source == "metadata" else None
        return replace(row, start_time=recording_start(Path(row.path), spec.time, meta))
    except Exception:  # noqa: BLE001 - a file that cannot be dated stays undated, as before
        return row


def _future(row: EstimateRow, now: datetime) -> bool:
    """Whether a result is dated more than ``alarms.FUTURE_TOLERANCE_DAYS`` after ``now``
    (naive UTC)."""
    from drivelash.wear.alarms import FUTURE_TOLERANCE_DAYS

    t = row.start_time
    if t is None:
        return False
    t = utc_naive(t)
    return t > now + timedelta(days=FUTURE_TOLERANCE_DAYS)


def _what_was_written(rep: IngestReport) -> str:
    """What an ingest that stopped on a store failure leaves stored (for the one-line error)."""
    if rep.batches == 0:
        done = []
        if rep.new_axes:  # plan registers the fleet's axes in a transaction of its own
            done.append(
                f"its {count(rep.new_axes, 'new axis', 'new axes')} "
                + ("was" if rep.new_axes == 1 else "were")
                + " registered"
            )
        if rep.redated:
            done.append(
                f"its {count(rep.redated, 'new recording date')} "
                + ("was" if rep.redated == 1 else "were")
                + " written"
            )
        if done:
            return f"no estimate of this ingest was written ({'; '.join(done)})"
        return "nothing of this ingest was written"
    moved = f" (and {rep.moved} new paths of stored recordings)" if rep.moved else ""
    return (
        f"the {count(rep.stored, 'estimate')}{moved} of its first {count(rep.batches, 'transaction')} "
        f"{'stays' if rep.stored == 1 and not rep.moved else 'stay'} stored, the rest "
        "was not written"
    )


def files_of(fleet: Fleet) -> list[Path]:
    """Every recording file of the fleet (all axes), for reports and tests."""
    return [p for a in fleet.axes for p in a.files()]
