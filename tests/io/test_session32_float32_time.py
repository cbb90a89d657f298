"""Float32 time stamps that collide are named as the cause (session 31 tester C, C14 b: a logger's
uptime of 3000 s stored as float32 resolves 0.24 ms, coarser than the 0.125 ms period; the
refusal named the duplicate but not why). Negative control: a float64 duplicate gets no hint."""

from __future__ import annotations

import pytest

import drivelash as dl
from drivelash.io.load import float32_time_hint
from drivelash.io.stream import TraceStream
from drivelash.sim.scenarios import get_scenario

HINT = "the stamps look like float32, which resolves only 0.00024 s at t = 3000 s: store the time as float64"


@pytest.fixture(scope="module")
def df():
    return get_scenario("bench-0B").simulate(duration=1.0, seed=1).to_pandas()


def test_float32_stamps_frame_file_and_stream(df, tmp_path):
    d = df.copy()
    d["t"] = (d["t"] + 3000).astype("float32")
    pq = tmp_path / "f32.parquet"
    d.to_parquet(pq)
    for load in (
        lambda: dl.Trace.from_frame(d),
        lambda: dl.load_trace(pq),
        lambda: TraceStream(pq, None, chunk_rows=97),
    ):
        with pytest.raises(dl.DataError) as exc:
            load()
        msg = str(exc.value)
        assert "duplicated time stamp: t=3000.000244140625" in msg and HINT in msg and "\n" not in msg, msg


def test_negative_control_a_float64_duplicate(df):
    g = df.copy()
    g.loc[5, "t"] = g.loc[4, "t"]
    with pytest.raises(dl.DataError) as exc:
        dl.Trace.from_frame(g)
    assert "duplicated time stamp: t=0.0005 after t=0.0005" in str(exc.value)
    assert "float32" not in str(exc.value)
    assert float32_time_hint(1.5, 1.5) == ""  # float32-exact, but resolved to 0.12 µs: no hint
