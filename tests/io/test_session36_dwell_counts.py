"""A hold whose position dithers by an encoder count is a dwell (session 36, tester J, J2).

A position-controlled axis at standstill toggles between adjacent encoder counts. The dwell
rule allowed a run at a torque extreme ``DWELL_SPEED`` × the recording's mean speed × the run's
length only: 2.2 mrad for a 1 s hold after 4 s of motion, below one count of a 2048-count
encoder (3.07 mrad) — the hold was refused as "saturated signal: 20.0% of samples sit at the
maximum 1.6 (clipped recording?)". The limit is now at least ``DWELL_COUNTS`` of the column's
encoder counts (its smallest non-zero step, measured from the data), in the loader and the
chunked stream alike. Holds that move (creeping, a clipped oscillation) stay refused.
"""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.errors import DataError
from drivelash.io import Trace, load_trace, write_trace
from drivelash.io.stream import TraceStream

T_S = 1e-3
N_MOVE, N_HOLD = 4000, 1000  # 4 s of motion, then 1 s held (20 % of the samples)
HELD = 1.6  # N·m: above every torque of the motion, the recording's maximum
Q = 2 * np.pi / 2048  # one count of a 2048-count encoder [rad]
REQ = ["theta_m", "torque_m"]


def _motion() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(N_MOVE + N_HOLD) * T_S
    tm = t[:N_MOVE]
    th = np.floor((0.3 * np.sin(2 * np.pi * 2 * tm) + 0.2 * tm) / Q) * Q  # quantised to counts
    om = 0.3 * 2 * np.pi * 2 * np.cos(2 * np.pi * 2 * tm) + 0.2
    tq = 1.5 * np.sin(2 * np.pi * 2 * tm + 0.3) + 0.05 * np.cos(2 * np.pi * 7 * tm)
    return t, th, om, tq


def _held(hold: np.ndarray, column: str = "theta_m") -> dict[str, np.ndarray]:
    """4 s of motion, then the torque held at HELD while ``column`` reads ``hold``."""
    t, th, om, tq = _motion()
    c = {
        "t": t,
        "theta_m": np.concatenate((th, np.full(N_HOLD, th[-1]))),
        "omega_m": np.concatenate((om, np.zeros(N_HOLD))),
        "torque_m": np.concatenate((tq, np.full(N_HOLD, HELD))),
    }
    if column != "theta_m":
        c[column] = np.concatenate((th, np.full(N_HOLD, th[-1])))
    c[column][N_MOVE:] = hold
    return c


def _dither(base: float) -> np.ndarray:
    """The position toggling between two adjacent counts at random."""
    return base + Q * (np.random.default_rng(1).random(N_HOLD) < 0.5)


def _load(p, chunk_rows: int | None) -> None:
    if chunk_rows is None:
        load_trace(p, required=REQ)
    else:
        with TraceStream(p, required=REQ, chunk_rows=chunk_rows):
            pass


@pytest.mark.parametrize("chunk_rows", [None, 13, 777])
@pytest.mark.parametrize("column", ["theta_m", "theta_l"])
def test_a_hold_dithering_by_one_count_is_a_dwell(tmp_path, chunk_rows, column):
    _, th, _, _ = _motion()
    p = tmp_path / f"dither_{column}.csv"
    write_trace(Trace(_held(_dither(th[-1]), column)), p)
    _load(p, chunk_rows)  # read: no "saturated signal"


def _creep(quantised: bool, share: float) -> np.ndarray:
    """The position creeping on at ``share`` of the 0.2 rad/s drift while the torque is held."""
    _, th, _, _ = _motion()
    x = th[-1] + 0.2 * share * np.arange(1, N_HOLD + 1) * T_S
    return np.floor(x / Q) * Q if quantised else x


@pytest.mark.parametrize("chunk_rows", [None, 13, 777])
@pytest.mark.parametrize(
    ("name", "hold"),
    [
        # the tester's case: recorded finer than a count (smallest step 4 µrad), 2 % of the speed
        ("creep_2pct", lambda: _creep(quantised=False, share=0.02)),
        # on counts, 5 % of the speed: 10 mrad, three counts over the hold
        ("creep_5pct_counts", lambda: _creep(quantised=True, share=0.05)),
    ],
)
def test_a_hold_that_creeps_stays_clipping(tmp_path, chunk_rows, name, hold):
    p = tmp_path / f"{name}.csv"
    write_trace(Trace(_held(hold())), p)
    with pytest.raises(DataError) as ei:
        _load(p, chunk_rows)
    msg = str(ei.value)
    assert "\n" not in msg and str(p) in msg and "column 'torque_m'" in msg
    assert "saturated signal: 20.0% of samples sit at the maximum 1.6 (clipped recording?)" in msg, msg


@pytest.mark.parametrize("chunk_rows", [None, 13, 777])
def test_a_clipped_small_oscillation_after_a_traverse_stays_clipping(tmp_path, chunk_rows):
    """A long traverse makes the speed rule generous; the clip of a 0.02 rad (6.5 count)
    oscillation still moves the position by more than two counts."""
    n = 4000
    t = np.arange(2 * n) * T_S
    ts = t[n:] - t[n]
    big = np.linspace(0.0, 20.0, n)
    osc = big[-1] + 0.02 * np.sin(2 * np.pi * 2 * ts)
    _, _, _, tq = _motion()
    c = {
        "t": t,
        "theta_m": np.floor(np.concatenate((big, osc)) / Q) * Q,
        "omega_m": np.concatenate((np.full(n, 5.0), 0.02 * 2 * np.pi * 2 * np.cos(2 * np.pi * 2 * ts))),
        "torque_m": np.concatenate(
            (np.clip(tq[:n], -1.5, 1.5), np.clip(3.0 * np.sin(2 * np.pi * 2 * ts + 1.0), -HELD, HELD))
        ),
    }
    p = tmp_path / "osc.csv"
    write_trace(Trace(c), p)
    with pytest.raises(DataError, match=r"saturated signal: 1\d\.\d% of samples sit at the m"):
        _load(p, chunk_rows)
