"""The streamed CSV reader switching to the strict reader mid-file does not repeat rows.

pyarrow's streaming reader refuses some cells Python's ``float`` accepts (``1_000``); the
reader then falls back to the strict reader, which re-reads the file from its first row. Until
session 22 the rows already yielded were yielded a second time: a file read in chunks came back
longer than it is, its first rows twice (found while fixing A16 in session 21). The negative
control: the same file without the odd cell streams through pyarrow alone, with the same rows.
"""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.io import formats
from drivelash.io.formats import open_source
from drivelash.io.stream import iter_trace_chunks

N = 5000


def _write(path, odd: bool) -> np.ndarray:
    x = np.round(np.sin(np.arange(N) / 50.0), 6)
    lines = ["t,theta_m,theta_l,torque_m"]
    for i in range(N):
        cell = "1_000" if (odd and i == N - 10) else repr(float(i))
        lines.append(f"{i * 1e-3!r},{float(x[i])!r},{float(x[i])!r},{cell}")
    path.write_text("\n".join(lines) + "\n")
    tq = np.arange(N, dtype=float)
    if odd:
        tq[N - 10] = 1000.0
    return tq


@pytest.mark.parametrize("odd", [True, False], ids=["cell-pyarrow-refuses", "control"])
def test_chunks_after_a_midfile_fallback_are_the_file_once(tmp_path, monkeypatch, odd):
    """Small pyarrow blocks so that many chunks are out before the odd cell near the end."""
    monkeypatch.setattr(formats, "CSV_BLOCK_BYTES", 4096)
    p = tmp_path / "f.csv"
    tq = _write(p, odd)
    src = open_source(p)
    got = list(src.chunks(["t", "torque_m"], chunk_rows=300))
    t = np.concatenate([c["t"] for c in got])
    u = np.concatenate([c["torque_m"] for c in got])
    assert t.size == N
    np.testing.assert_array_equal(t, np.arange(N) * 1e-3)
    np.testing.assert_array_equal(u, tq)
    assert src.unread == {}


def test_streamed_trace_after_a_midfile_fallback(tmp_path, monkeypatch):
    """Through the streamed trace reader (what ``estimate`` uses on a long file)."""
    monkeypatch.setattr(formats, "CSV_BLOCK_BYTES", 4096)
    p = tmp_path / "f.csv"
    tq = _write(p, True)
    chunks = list(iter_trace_chunks(p, None, chunk_rows=300))
    u = np.concatenate([c["torque_m"] for c in chunks])
    t = np.concatenate([c["t"] for c in chunks])
    assert u.size == N
    np.testing.assert_array_equal(u, tq)
    assert np.all(np.diff(t) > 0)
