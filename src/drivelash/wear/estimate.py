"""One recording → one :class:`~drivelash.wear.store.EstimateRow` (the worker's whole job).

:func:`estimate_recording` is the single adapter between the wear tracker and the backlash
estimator: it hashes the file, reads and validates it with the axis's drive configuration
(:func:`drivelash.io.load_trace`), finds its start time, and runs the same estimator with the
same tuning as ``drivelash estimate`` (:func:`drivelash.estimation.pipeline.estimate_trace`).
A recording that cannot be read or validated becomes a ``failed`` row with its one-line reason;
nothing raises out of a worker.

The uncertainty of δ̂ is stored only when the estimator reports one (``delta_std`` in the
result); otherwise it stays NULL and the trend treats it as unknown.
"""

from __future__ import annotations

import hashlib
import math
import re
import time
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from drivelash.errors import DataError, DrivelashError
from drivelash.io.config import DriveConfig
from drivelash.units import gap_unit
from drivelash.wear.fleet import TimeSpec, time_spec_hash
from drivelash.wear.store import EstimateRow, utc_naive
from drivelash.wear.words import UNCONVERGED_MARK

__all__ = ["RecordingTask", "code_version", "estimate_recording", "recording_start", "unconverged_cause"]


def code_version() -> str:
    """Version of the estimating code stored with every estimate (``drivelash`` version)."""
    from drivelash import __version__

    return f"drivelash {__version__}"


@dataclass(frozen=True)
class RecordingTask:
    """Everything a worker needs for one recording (picklable, small)."""

    axis: str
    path: str
    size_bytes: int
    mtime_ns: int
    drive: DriveConfig
    time: TimeSpec
    method: str
    config_hash: str
    code_version: str
    estimate_rate_hz: float | None = None
    #: the axis's kind as its fleet file resolves it ("rotary" or "prismatic", ``AxisSpec.kind``)
    kind: str = "rotary"


#: Earliest start time a ``time = {from = "column"}`` stamp may give (naive UTC): an earlier
#: value is a relative time (seconds since the recording started, as every drive trace's ``t``
#: column), not a POSIX time stamp. 2000-01-01 is 946 684 800 s: a relative time reaches it only
#: after 30 years of recording, and no drive recording tracked here predates 2000
#: (docs/assumptions.md, "Wear tracking").
EARLIEST_COLUMN_START = datetime(2000, 1, 1)


def _in_zone(t: datetime, spec: TimeSpec) -> datetime:
    """``t`` as naive UTC; a stamp without an offset is read in the spec's ``zone`` (default UTC;
    session 30 tester B, B-09: local wall-clock stamps were taken as UTC, 1 h off in CET)."""
    from zoneinfo import ZoneInfo

    return utc_naive(t if t.tzinfo else t.replace(tzinfo=ZoneInfo(spec.zone)))  # type: ignore[return-value]


def recording_start(path: Path, spec: TimeSpec, meta: dict[str, Any] | None = None) -> datetime:
    """Start time of a recording (naive UTC) as the fleet's ``time`` table says.

    Raises
    ------
    DataError
        The file name does not match, the column or metadata key is missing or unparsable, or
        the column's first value lies before :data:`EARLIEST_COLUMN_START` (a relative time).
    """
    if spec.source == "filename":
        assert spec.pattern is not None and spec.format is not None
        m = re.search(spec.pattern, path.name) or re.search(spec.pattern, str(path))
        if m is None:
            raise DataError(f"file name does not match the time pattern {spec.pattern!r}", path=str(path))
        text = m.group("time") if "time" in m.re.groupindex else m.group(1)
        try:
            t = datetime.strptime(text, spec.format)
        except ValueError:
            raise DataError(
                f"time stamp {text!r} in the file name does not match format {spec.format!r}", path=str(path)
            ) from None
        return _in_zone(t, spec)
    if spec.source == "mtime":
        return datetime.fromtimestamp(path.stat().st_mtime, UTC).replace(tzinfo=None)
    if spec.source == "metadata":
        value = (meta or {}).get(spec.key)
        if value is None:
            raise DataError(f"no time stamp '{spec.key}' in the file's metadata", path=str(path))
        try:
            t = datetime.fromisoformat(str(value))
        except ValueError:
            raise DataError(
                f"metadata '{spec.key}' = {value!r} is not an ISO 8601 time", path=str(path)
            ) from None
        return _in_zone(t, spec)
    # column: POSIX time stamps in the file
    import math

    from drivelash.io.formats import read_raw

    raw = read_raw(path)
    col = raw.columns.get(spec.column or "")
    if col is None or col.size == 0:
        raise DataError("no such column for the start time", path=str(path), column=spec.column)
    stamp = raw.meta.get("time_origin", {}).get(spec.column)
    if stamp is not None:  # ISO 8601 stamps: the reader kept the first (the column is seconds from it)
        return _in_zone(datetime.fromisoformat(stamp), spec)
    v = float(col[0]) * {"s": 1.0, "ms": 1e-3, "us": 1e-6}[spec.unit]
    if not math.isfinite(v):
        raise DataError(
            "start time stamp is not finite", path=str(path), column=spec.column, row=0, rows=raw.rows
        )
    try:
        t = datetime.fromtimestamp(v, UTC).replace(tzinfo=None)
    except (OverflowError, OSError, ValueError):
        raise DataError(
            f"{v!r} is not a POSIX time stamp", path=str(path), column=spec.column, row=0, rows=raw.rows
        ) from None
    if t < EARLIEST_COLUMN_START:
        raise DataError(
            f"starts at {v:g} s, before {EARLIEST_COLUMN_START:%Y-%m-%d}: a relative time (seconds since "
            "the recording started), not a POSIX time stamp",
            path=str(path),
            column=spec.column,
            row=0,
            rows=raw.rows,
        )
    return t


#: Largest recording [bytes] read into memory once, hashed and decoded from the same bytes
#: (docs/assumptions.md); a larger file is hashed in a streamed pass and read again by the loader.
HASH_IN_MEMORY_BYTES = 256 << 20


def read_and_hash(path: Path) -> tuple[str, bytes | None, OSError | None]:
    """SHA-256 (hex) of a file and, when it is at most :data:`HASH_IN_MEMORY_BYTES`, its bytes
    (the loader decodes those: the file is read once and the hash is of the bytes estimated)."""
    try:
        if path.stat().st_size <= HASH_IN_MEMORY_BYTES:
            data = path.read_bytes()
            return hashlib.sha256(data).hexdigest(), data, None
    except OSError:
        pass  # the streamed hash below names the error
    digest, exc = content_hash(path)
    return digest, None, exc


def content_hash(path: str | Path) -> tuple[str, OSError | None]:
    """SHA-256 (hex) of a file's bytes; for an unreadable file a marker
    ``unreadable:<hash of the path>`` and the error."""
    try:
        with Path(path).open("rb") as fh:
            return hashlib.file_digest(fh, "sha256").hexdigest(), None
    except OSError as exc:
        return "unreadable:" + hashlib.sha256(str(path).encode()).hexdigest()[:52], exc


def estimate_recording(task: RecordingTask) -> EstimateRow:
    """Hash, read, validate and estimate one recording; never raises for a bad file.

    Parameters
    ----------
    task : RecordingTask
        The recording and its axis's configuration.

    Returns
    -------
    EstimateRow
        ``status="ok"`` with δ̂ and the estimator's verdicts, or ``status="failed"`` with
        the one-line reason (the recording is still identified by its content hash).
    """
    from drivelash.estimation.estimator import INPUT_COLUMNS
    from drivelash.estimation.pipeline import estimate_trace
    from drivelash.io import load_trace

    t0 = time.perf_counter()
    path = Path(task.path)
    base: dict[str, Any] = dict(
        axis=task.axis,
        path=task.path,
        size_bytes=task.size_bytes,
        mtime_ns=task.mtime_ns,
        method=task.method,
        config_hash=task.config_hash,
        code_version=task.code_version,
        time_spec_hash=time_spec_hash(task.time),
    )
    digest, data, exc = read_and_hash(path)
    if exc is not None:
        return EstimateRow(
            **base,
            content_hash=digest,
            start_time=None,
            duration_s=None,
            sample_rate_hz=None,
            samples=None,
            status="failed",
            reason=f"{path}: cannot read ({exc.strerror or exc})",
            runtime_s=time.perf_counter() - t0,
        )
    start = duration = rate = n = None
    try:
        cfg = task.drive
        trace = load_trace(path, cfg, required=INPUT_COLUMNS, data=data, max_rate_hz=task.estimate_rate_hz)
        data = None  # the decoded columns do not refer to the file's bytes
        T_est = trace.T_s  # sample period the estimator sees (a median over the kept samples: once)
        down = trace.meta.get("sampled_down")  # the recording's own figures, not the kept samples'
        n = int(down["samples"]) if down else len(trace)
        T_s = float(down["T_s"]) if down else T_est
        duration = n * T_s
        rate = 1.0 / T_s
        start = recording_start(path, task.time, trace.meta)
        got = "prismatic" if trace.meta.get("axis") == "prismatic" else "rotary"
        if got != task.kind:
            # its δ would be a length on an axis trended and shown in rad, or an angle in m
            raise DataError(
                f"the recording is {_KIND_WORDS[got]}, but axis {task.axis} is {_KIND_WORDS[task.kind]}"
                " by its drive file's [columns]; give the position columns' unit there"
                " (a length unit — m, mm, um — makes the axis linear)",
                path=str(path),
            )
        # only the figures are stored: the output series is not kept (same verdict and figures)
        res, _ = estimate_trace(cfg, trace, task.method, keep="decimated")
        d1 = res.extra.get("delta1_estimate", res.extra.get("delta1_check"))
        std = getattr(res, "delta_std", None)
        if std is None:
            std = res.extra.get("delta_std")
        reason = res.reason
        if res.excitation_ok and not res.converged:
            cause, std = unconverged_cause(res, std, trace.meta.get("axis"))
            reason = f"{reason}{UNCONVERGED_MARK}{cause}"
        return EstimateRow(
            **base,
            content_hash=digest,
            start_time=start,
            duration_s=duration,
            sample_rate_hz=rate,
            samples=n,
            status="ok",
            reason=reason,
            delta=res.delta,
            delta1_estimate=None if d1 is None else float(d1),
            delta_std=_std_or_none(std),
            excitation_ok=bool(res.excitation_ok),
            converged=bool(res.converged),
            runtime_s=time.perf_counter() - t0,
            estimate_rate_hz=1.0 / T_est,
        )
    except DrivelashError as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    except Exception as exc:  # noqa: BLE001 - a worker never raises: the batch continues
        reason = f"{path}: unexpected {type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
    if not reason.startswith(str(path)):
        reason = f"{path}: {reason}"
    return EstimateRow(
        **base,
        content_hash=digest,
        start_time=start,
        duration_s=duration,
        sample_rate_hz=rate,
        samples=n,
        status="failed",
        reason=reason,
        runtime_s=time.perf_counter() - t0,
    )


#: How a reason names an axis kind.
_KIND_WORDS = {"prismatic": "linear (positions in a length unit)", "rotary": "rotary (positions in rad)"}


def unconverged_cause(res: Any, std: Any, axis: str | None = None) -> tuple[str, Any]:
    """Why an excited estimate did not converge, and the uncertainty a wear trend may use.

    Parameters
    ----------
    res : EstimationResult
        The estimator's result (excited, not converged).
    std : float or None
        Its stated standard uncertainty of δ̂ [rad, or m on a linear axis].
    axis : str, optional
        The recording's axis kind (``Trace.meta["axis"]``): the movement is written in µm on a
        "prismatic" one, else in mrad.

    Returns
    -------
    cause : str
        One line: the first blocking warning, else "not settled …" or the uncertainty warning.
    std : float or None
        ``std`` when its interval states the doubt itself — the only blocking warning is "the
        estimate is uncertain by …" — or, when δ̂ had not settled over the last window, ``std``
        widened to that window's movement (hypot(σ, movement/1.96)) — else None: a blocking warning (contact
        stiffness at its limit, δ1 inconsistent, excitation information unresolved at the rate,
        swapped channels, …) makes the stated σ conditional on parameters the data contradict,
        so the estimate must not enter a trend weighted by it, nor raise an alarm (session 32
        tester F, F5: 188.37 ± 0.08 mrad stored for a true 186, a false threshold alarm).
    """
    claim = res.extra.get("uncertainty_warning")
    blocking = [w for w in res.warnings if not w.startswith("note:") and w != claim]
    if blocking:
        return blocking[0], None
    if not res.extra.get("settled", True):
        move = res.extra.get("window_movement")
        if move is None or not math.isfinite(move) or std is None or not math.isfinite(std):
            return "not settled", None
        # the trend's σ spans the last window's movement (quadrature: one more standard
        # uncertainty of where δ̂ ends): KR300 rec_C axis 1 moved 1.41 mrad with a stated ±0.27
        return (
            f"not settled: δ̂ moved {gap_unit(axis).f(move, '.2f')} over its last window"
            " (σ widened to include it)",
            math.hypot(std, move / 1.96),
        )
    return claim or "not settled", std


def _std_or_none(std: Any) -> float | None:
    """The estimator's uncertainty as stored: a positive finite float, else NULL (a NaN would
    be NULL in SQLite but NaN in PostgreSQL)."""
    if std is None:
        return None
    v = float(std)
    return v if math.isfinite(v) and v > 0 else None
