"""The local process pool of every command that fans work out (``track ingest --workers``,
``simulate fleet --workers``, ``reproduce --workers``): Ctrl-C stops it at once, however often
it is pressed.

A terminal's Ctrl-C reaches the whole process group, pool workers included. With Python's
default handler each worker raised ``KeyboardInterrupt`` wherever it was; a second Ctrl-C caught
one inside the pool's queue machinery (reading the call queue, holding its lock), the other
worker then waited on that lock for ever, and the command — which had already printed its
"interrupted" line — hung in the interpreter's exit, joining a worker that never ended (session
19's tester, found with gdb). Here the workers ignore SIGINT: the command's own process handles
Ctrl-C (``drivelash.cli``), and when anything ends the ``with`` block by an exception (Ctrl-C,
SIGTERM, an error) the queued work is cancelled and the workers are terminated and joined before
the exception goes on — nothing is left to wait for.
"""

from __future__ import annotations

import signal
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager

__all__ = ["process_pool"]

#: Seconds to wait for a terminated worker before it is killed [s].
TERMINATE_GRACE_S = 5.0


def _ignore_sigint() -> None:
    """Pool worker initializer: Ctrl-C is the parent's business (see the module docstring)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextmanager
def process_pool(workers: int) -> Iterator[ProcessPoolExecutor]:
    """A :class:`~concurrent.futures.ProcessPoolExecutor` of ``workers`` processes whose workers
    ignore SIGINT, shut down normally when the block ends, and cancelled and terminated when an
    exception ends it.

    Parameters
    ----------
    workers : int
        Worker processes.

    Yields
    ------
    ProcessPoolExecutor
        The pool.
    """
    pool = ProcessPoolExecutor(max_workers=workers, initializer=_ignore_sigint)
    try:
        yield pool
    except BaseException:
        procs = list((getattr(pool, "_processes", None) or {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        for p in procs:
            if p.is_alive():
                p.terminate()
        for p in procs:
            p.join(TERMINATE_GRACE_S)
            if p.is_alive():
                p.kill()
                p.join()
        raise
    else:
        pool.shutdown(wait=True)
