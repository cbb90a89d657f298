"""Streamed zero-phase filtering equals scipy's whole-array filtfilt / sosfiltfilt bit for bit."""

from __future__ import annotations

import os

import numpy as np
import pytest
from scipy import signal

from drivelash.estimation.zero_phase import ZeroPhase, filtfilt_to_spill, gradient_rows
from drivelash.io.spill import Spill


def _signal(n: int, k: int = 1) -> np.ndarray:
    rng = np.random.default_rng(7)
    return np.cumsum(rng.normal(size=(n, k)), axis=0) * 1e-3


def _chunks(x: np.ndarray, rows: int):
    return (x[a : a + rows] for a in range(0, len(x), rows))


@pytest.mark.parametrize("rows", [3, 17, 4999, 30011])
def test_butterworth_filtfilt_bit_identical(rows, tmp_path):
    x = _signal(30011)
    f = ZeroPhase.butter(4, 100.0, 8000.0)
    with Spill(len(x), 1, tmp_path) as sp:
        got = filtfilt_to_spill(f, _chunks(x, rows), len(x), sp, back_rows=rows + 5).read(0, len(x))[:, 0]
    b, a = signal.butter(4, 100.0 / 4000.0)
    assert np.array_equal(got, signal.filtfilt(b, a, x[:, 0]))
    assert list(tmp_path.iterdir()) == []  # the spill file is gone


@pytest.mark.parametrize("q", [2, 10])
def test_decimation_filter_bit_identical_on_columns(q, tmp_path):
    """The anti-alias filter of scipy.signal.decimate (sos), several columns at once."""
    x = _signal(20000, 3)
    f = ZeroPhase.decimator(q)
    with Spill(len(x), 3, tmp_path) as sp:
        got = filtfilt_to_spill(f, _chunks(x, 1234), len(x), sp, back_rows=777).read(0, len(x))
    for j in range(3):
        ref = signal.decimate(x[:, j], q, ftype="iir", zero_phase=True)
        assert np.array_equal(got[::q, j], ref)


def test_negative_control_one_sample(tmp_path):
    x = _signal(5000)
    y = x.copy()
    y[2500] += 1e-12
    f = ZeroPhase.butter(4, 100.0, 8000.0)
    with Spill(5000, 1, tmp_path) as a, Spill(5000, 1, tmp_path) as b:
        ra = filtfilt_to_spill(f, _chunks(x, 999), 5000, a).read(0, 5000)
        rb = filtfilt_to_spill(f, _chunks(y, 999), 5000, b).read(0, 5000)
    assert not np.array_equal(ra, rb)


def test_gradient_rows_bit_identical():
    x = _signal(1000)[:, 0]
    d1 = np.gradient(x, 1e-3, edge_order=1)
    d2 = np.gradient(d1, 1e-3, edge_order=1)
    for a, b in [(0, 1000), (0, 7), (1, 2), (500, 777), (998, 1000), (999, 1000)]:
        g = gradient_rows(lambda s, e: x[s:e], 1000, a, b, 1e-3, order=2)
        assert np.array_equal(g[0], x[a:b]) and np.array_equal(g[1], d1[a:b])
        assert np.array_equal(g[2], d2[a:b])


def test_spill_full_disk_is_one_line_and_leaves_nothing(tmp_path, monkeypatch):
    """A full disk while spilling is a ResourceError naming DRIVELASH_SPILL_DIR; the file goes."""
    import errno
    import os

    from drivelash.errors import ResourceError

    def full(*a, **k):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr("drivelash.io.spill.os.pwrite", full)
    with pytest.raises(ResourceError, match="DRIVELASH_SPILL_DIR"), Spill(1000, 1, tmp_path) as sp:
        sp.write(0, np.ones(10))
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ResourceError, match="DRIVELASH_SPILL_DIR"):
        Spill(10, 1, tmp_path / "missing")


def test_spill_of_a_killed_process_is_swept_by_the_next_spill(tmp_path):
    """SIGKILL during ``observe`` left ``.drivelash-spill-RAND.f64`` (40 B per sample) in the
    output directory for good; now the name has the PID and the next spill removes it.
    A live process's spill file and a file of the user's stay."""
    import signal
    import subprocess
    import sys

    code = (
        "import sys, time\n"
        "from drivelash.io.spill import Spill\n"
        "sp = Spill(1000, 2, sys.argv[1])\n"
        "print(sp.path.name, flush=True)\n"
        "time.sleep(60)\n"
    )
    procs = [
        subprocess.Popen([sys.executable, "-c", code, str(tmp_path)], stdout=subprocess.PIPE, text=True)
        for _ in range(2)
    ]
    try:
        killed, alive = (p.stdout.readline().strip() for p in procs)
        procs[0].send_signal(signal.SIGKILL)
        procs[0].wait(timeout=30)
        user = tmp_path / ".drivelash-spill-notes.f64"  # not a PID-RAND name: not ours
        user.write_bytes(b"mine")
        assert (tmp_path / killed).exists()
        with Spill(10, 1, tmp_path) as sp:
            assert sp.path.name.startswith(f".drivelash-spill-{os.getpid()}-")
            assert sorted(p.name for p in tmp_path.iterdir()) == sorted([alive, user.name, sp.path.name])
        assert user.read_bytes() == b"mine"
    finally:
        for p in procs:
            p.kill()
            p.wait(timeout=30)


@pytest.mark.parametrize("n", [0, 5, 128, 129, 1000, 65537, 300_001])
def test_pairwise_sum_over_chunks_is_numpy_mean(n):
    """The observer's streamed mean equals np.mean of the whole array bit for bit."""
    from drivelash.estimation.identify import PairwiseSum

    x = np.random.default_rng(n).normal(size=n) * 1e-3 + 0.004
    for rows in (7, 4999, max(n, 1)):
        ps = PairwiseSum(n)
        for a in range(0, n, rows):
            ps.add(x[a : a + rows])
        assert (ps.mean() == float(x.mean())) if n else np.isnan(ps.mean())
