"""A torque held at standstill is a dwell, not a clipped recording (session 36, tester H, TH12).

A pass that ends at the stroke end with the drive holding the load records one quantised
current for a second or more; that value is the column's extreme, and ``_check_signals``
refused it as "saturated signal: … (clipped recording?)". Clipping is an extreme held while the
axis moves: a run at the extreme over which no position moves (``DWELL_SPEED``) is a dwell. The
loader and the chunked stream apply one rule (:class:`drivelash.io.load.ExtremeRuns`).
"""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.errors import DataError
from drivelash.io import Trace, load_trace, write_trace
from drivelash.io.load import DWELL_SPEED, ExtremeRuns
from drivelash.io.stream import TraceStream

T_S = 1e-3
N_MOVE, N_HOLD = 4000, 1000  # 4 s of motion, then 1 s held at standstill (20 % of the samples)
HELD = 1.6  # N·m: above every torque of the motion, the recording's maximum


def _recording(moving_while_held: bool) -> dict[str, np.ndarray]:
    t = np.arange(N_MOVE + N_HOLD) * T_S
    tm = t[:N_MOVE]
    th = 0.3 * np.sin(2 * np.pi * 2 * tm) + 0.2 * tm
    om = 0.3 * 2 * np.pi * 2 * np.cos(2 * np.pi * 2 * tm) + 0.2
    tq = 1.5 * np.sin(2 * np.pi * 2 * tm + 0.3) + 0.05 * np.cos(2 * np.pi * 7 * tm)
    if moving_while_held:  # the same torque while the motion goes on: a clipped recording
        th_h = th[-1] + 0.2 * (t[N_MOVE:] - tm[-1])
        om_h = np.full(N_HOLD, 0.2)
    else:  # the axis stands still holding the load
        th_h, om_h = np.full(N_HOLD, th[-1]), np.zeros(N_HOLD)
    return {
        "t": t,
        "theta_m": np.concatenate((th, th_h)),
        "omega_m": np.concatenate((om, om_h)),
        "torque_m": np.concatenate((tq, np.full(N_HOLD, HELD))),
    }


def _write(tmp_path, moving_while_held: bool):
    p = tmp_path / ("clipped.csv" if moving_while_held else "dwell.csv")
    write_trace(Trace(_recording(moving_while_held)), p)
    return p


@pytest.mark.parametrize("chunk_rows", [None, 13, 777])
def test_a_torque_held_at_standstill_is_read(tmp_path, chunk_rows):
    p = _write(tmp_path, moving_while_held=False)
    if chunk_rows is None:
        tr = load_trace(p, required=["theta_m", "torque_m"])
        assert np.sum(tr["torque_m"] == HELD) == N_HOLD
        return
    with TraceStream(p, required=["theta_m", "torque_m"], chunk_rows=chunk_rows) as s:
        assert s.n_samples == N_MOVE + N_HOLD


@pytest.mark.parametrize("chunk_rows", [None, 13, 777])
def test_the_same_torque_held_while_moving_is_still_refused(tmp_path, chunk_rows):
    p = _write(tmp_path, moving_while_held=True)
    with pytest.raises(DataError) as ei:
        if chunk_rows is None:
            load_trace(p, required=["theta_m", "torque_m"])
        else:
            TraceStream(p, required=["theta_m", "torque_m"], chunk_rows=chunk_rows)
    msg = str(ei.value)
    assert "\n" not in msg and str(p) in msg and "column 'torque_m'" in msg
    # the message as before: the held samples' share, the value, and the first of them
    assert "saturated signal: 20.0% of samples sit at the maximum 1.6 (clipped recording?)" in msg, msg
    assert f"line {N_MOVE + 3}" in msg, msg  # the drivelash meta line and the header above the data


def test_without_a_moving_position_a_held_extreme_stays_clipping(tmp_path):
    """No position column (or none that moves): nothing tells a dwell, the old rule holds."""
    c = _recording(moving_while_held=False)
    del c["theta_m"], c["omega_m"]
    c["theta_l"] = np.zeros(c["t"].size)  # a still load (allowed), no evidence of motion
    p = tmp_path / "torque_only.csv"
    write_trace(Trace(c), p)
    with pytest.raises(DataError, match=r"saturated signal: 20\.0% of samples sit at the maximum 1\.6"):
        load_trace(p, required=["torque_m"])


def test_runs_fed_in_chunks_are_classified_as_fed_whole():
    """ExtremeRuns over chunk boundaries equals a brute-force scan of the whole column."""
    rng = np.random.default_rng(3)
    n = 3000
    hit = rng.random(n) < 0.3
    hit[500:900] = True  # a long run, crossing chunk boundaries
    hit[-40:] = True  # and one that ends with the recording
    x = np.cumsum(rng.random(n) * (rng.random(n) < 0.5))  # moves, stands still now and then
    x[500:900] = x[499]  # the long run stands still: a dwell
    lim = DWELL_SPEED * np.ptp(x) / (n - 1)
    # brute force
    count, best, first = 0, 0, None
    i = 0
    while i < n:
        if not hit[i]:
            i += 1
            continue
        j = i
        while j < n and hit[j]:
            j += 1
        if np.ptp(x[i:j]) > lim * (j - i):
            count, best, first = count + j - i, max(best, j - i), i if first is None else first
        i = j
    assert count and best < 400  # the long still run is a dwell, the others move
    for cuts in ([n], [13] * (n // 13 + 1), list(rng.integers(1, 200, size=200))):
        runs, row = ExtremeRuns(["x_T"]), 0
        for m in cuts:
            if row >= n:
                break
            runs.feed(hit[row : row + m], {"x_T": x[row : row + m]}, row)
            row += m
        assert runs.clipped() == (count, best, first)
