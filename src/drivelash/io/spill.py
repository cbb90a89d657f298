"""Spill files: a float64 matrix on disk, read and written by row ranges.

The streamed offline commands (``observe``, ``identify``) need whole-signal intermediate
results (a forward filter pass that the backward pass reads in reverse) that do not fit in
memory for a multi-hour recording. :class:`Spill` keeps such a matrix in a hidden file
(``.drivelash-spill-PID-RAND.f64``) and moves rows with ``pread``/``pwrite``: unlike a
``numpy.memmap``, the pages stay in the page cache and never count in the process's
resident memory. The file is removed when the block ends — normally, on an exception,
or on SIGTERM (which :mod:`drivelash.cli` turns into an exception). A process killed
outright (SIGKILL, OOM killer) cannot remove it: the next spill in the same directory
removes the spill files of processes that no longer exist (the PID in the name).
"""

from __future__ import annotations

import os
import re
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["Spill", "spill_directory"]

#: Environment variable: directory of the spill files (default: the first output's
#: directory, else the system's temporary directory).
ENV_SPILL_DIR = "DRIVELASH_SPILL_DIR"

_PREFIX = ".drivelash-spill-"
_NAME_RE = re.compile(r"^\.drivelash-spill-(?P<pid>\d+)-[A-Za-z0-9_]+\.f64$")


def _sweep_stale(directory: Path) -> None:
    """Remove the spill files in ``directory`` left by processes that no longer exist."""
    from drivelash.io.outputs import _pid_alive

    try:
        names = os.listdir(directory)
    except OSError:
        return
    for n in names:
        m = _NAME_RE.match(n)
        if m and not _pid_alive(int(m["pid"])):
            try:
                (directory / n).unlink()
            except OSError:
                pass  # another process swept it first, or it is not ours to remove


def spill_directory(*outputs: str | Path | None) -> Path:
    """Where spill files go: ``DRIVELASH_SPILL_DIR``, else the directory of the first given
    output (validated writable by :class:`~drivelash.io.outputs.Outputs`), else the system's
    temporary directory."""
    env = os.environ.get(ENV_SPILL_DIR, "").strip()
    if env:
        return Path(env)
    for o in outputs:
        if o is not None:
            return Path(o).resolve().parent
    return Path(tempfile.gettempdir())


class Spill:
    """An ``(n, k)`` float64 matrix in a hidden file, removed on :meth:`close`.

    Parameters
    ----------
    n, k : int
        Rows and columns.
    directory : str or Path, optional
        Where the file goes (default :func:`spill_directory`).
    """

    def __init__(self, n: int, k: int, directory: str | Path | None = None) -> None:
        from drivelash.errors import ResourceError

        self.n, self.k = int(n), int(k)
        d = Path(directory) if directory is not None else spill_directory()
        _sweep_stale(d)
        try:
            fd, name = tempfile.mkstemp(prefix=f"{_PREFIX}{os.getpid()}-", suffix=".f64", dir=d)
        except OSError as e:
            raise ResourceError(
                f"{d}: cannot create a spill file ({e.strerror}); set {ENV_SPILL_DIR} to a writable directory"
            ) from None
        self.path = Path(name)
        self._fd = fd
        try:
            os.ftruncate(fd, self.n * self.k * 8)
        except OSError as e:
            self.close()
            raise ResourceError(
                f"{d}: cannot size a spill file of {self.n * self.k * 8 / 2**20:.0f} MiB ({e.strerror});"
                f" set {ENV_SPILL_DIR} to a directory with room"
            ) from None

    def write(self, start: int, rows: np.ndarray) -> None:
        """Write ``rows`` (``(m, k)`` or ``(m,)`` when k = 1) at row ``start``."""
        a = np.ascontiguousarray(rows, dtype=np.float64)
        view = memoryview(a).cast("B")
        off = int(start) * self.k * 8
        done = 0
        try:
            while done < len(view):
                done += os.pwrite(self._fd, view[done:], off + done)
        except OSError as e:
            from drivelash.errors import ResourceError

            raise ResourceError(
                f"{self.path.parent}: cannot write the spill file ({e.strerror}, "
                f"{self.n * self.k * 8 / 2**20:.0f} MiB needed); set {ENV_SPILL_DIR} to a directory with room"
            ) from None

    def read(self, start: int, stop: int) -> np.ndarray:
        """Rows ``start:stop`` as a new ``(m, k)`` array."""
        start, stop = max(0, int(start)), min(self.n, int(stop))
        m = max(0, stop - start)
        out = np.empty((m, self.k), dtype=np.float64)
        view = memoryview(out).cast("B")
        off = start * self.k * 8
        done = 0
        while done < len(view):
            got = os.preadv(self._fd, [view[done:]], off + done)
            if got <= 0:
                raise OSError(f"{self.path}: short read")
            done += got
        return out

    def close(self) -> None:
        """Close and remove the file (idempotent)."""
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1
        try:
            self.path.unlink()
        except FileNotFoundError:
            pass

    def __enter__(self) -> Spill:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __del__(self) -> None:  # a forgotten spill never outlives its object
        try:
            self.close()
        except Exception:  # noqa: BLE001 - interpreter shutdown
            pass
