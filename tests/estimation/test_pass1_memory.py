"""Pass 1 keeps compact copies of its decimated series, never views of the chunks.

Found by the slow acceptance test ``test_one_hour_8khz_estimate_peak_rss_below_1_gib`` (issue
15: 1 h at 8 kHz below 1 GiB peak RSS) failing at 1044 MiB after session 20: the gear-ratio
check (B6) kept ``theta_l[start::B]`` as a strided *view*, which holds the whole chunk — and so
the whole θ_l column of the recording — alive; the torque series did the same since earlier.
``benchmarks/bench_memory.py``-style measurement of ``drivelash estimate`` on the 1 h Parquet
recording: 743 MiB (379f4d4), 1021 MiB (102ed7c), 585 MiB with compact copies. This fast test
guards the cause: no stored series shares memory with a chunk it was fed.
"""

from __future__ import annotations

import numpy as np

from drivelash.estimation.motion import MotionScanner


def test_stored_series_do_not_keep_the_chunks_alive():
    T_s = 1.0 / 8000.0  # 8 kHz: pass 1 keeps every 8th sample (>= 1 kHz)
    sc = MotionScanner(N=1.0)
    chunks = []
    for k in range(4):
        t = (np.arange(4096) + 4096 * k) * T_s
        th_m = np.sin(2 * np.pi * 0.5 * t)
        th_l = 0.99 * th_m
        u = np.cos(2 * np.pi * 0.5 * t)
        sc.feed(t, th_m, th_l, u)
        chunks.append((th_m, th_l, u))
    stored = [*sc._th, *sc._thl, *sc._u]
    assert len(stored) == 12 and all(a.size == 4096 // 8 for a in stored)
    for a in stored:
        assert a.base is None or a.base.size == a.size  # compact: owns (at most) its own samples
        for ch in chunks:
            assert not any(np.shares_memory(a, c) for c in ch)
    s = sc.summary()
    assert s.n == 4 * 4096
