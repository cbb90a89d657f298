"""Session 31 (tester C, C14): "missing required column 't'" names what looks like the time —
a column 'Time' (case or suffix) or a DataFrame's unnamed float index — and the advice it gives
works when followed. Negative controls: no such column or index, no hint."""

from __future__ import annotations

import pandas as pd
import pytest

import drivelash as dl
from drivelash.sim.scenarios import get_scenario


@pytest.fixture(scope="module")
def frame() -> pd.DataFrame:
    return get_scenario("bench-0B").simulate(duration=0.5, seed=1).to_pandas()


def test_a_time_column_by_another_name_is_named_and_the_mapping_works(frame, tmp_path):
    p = tmp_path / "rec.csv"
    frame.rename(columns={"t": "Time"}).to_csv(p, index=False)
    with pytest.raises(dl.DataError) as e:
        dl.load_trace(p)
    msg = str(e.value)
    assert "missing required column 't'" in msg and "a column 'Time' is there" in msg, msg
    assert '[columns."Time"] column = "t", unit = "s"' in msg and "columns={'Time': 't'}" in msg
    cfg = tmp_path / "m.toml"
    cfg.write_text('[columns."Time"]\ncolumn = "t"\nunit = "s"\n')
    a = dl.load_trace(p, cfg)  # the TOML advice, followed
    b = dl.load_trace(p, {"Time": "t"})  # the Python advice, followed
    assert a["t"][-1] == pytest.approx(frame["t"].iloc[-1]) and (a["t"] == b["t"]).all()
    # negative control: no time-like column, no hint
    frame.drop(columns="t").to_csv(p, index=False)
    with pytest.raises(dl.DataError) as e:
        dl.load_trace(p)
    assert "is there" not in str(e.value) and "index" not in str(e.value)


def test_an_unnamed_float_index_is_named_and_the_advice_works(frame):
    df = frame.set_index("t").rename_axis(None)
    with pytest.raises(dl.DataError) as e:
        dl.Trace.from_frame(df)
    assert "the DataFrame's unnamed index looks like time: df.rename_axis('t').reset_index()" in str(e.value)
    tr = dl.Trace.from_frame(df.rename_axis("t").reset_index())  # the advice, followed
    assert tr["t"][-1] == pytest.approx(frame["t"].iloc[-1])
    # negative control: a default RangeIndex is not called time
    with pytest.raises(dl.DataError) as e:
        dl.Trace.from_frame(frame.drop(columns="t"))
    assert "index" not in str(e.value)
