"""Session 34, tester G, G14: a DataFrame with an unnamed DatetimeIndex (a resampled or logged
frame) got no "the index looks like time" hint, an unnamed float index did. Negative control: a
default RangeIndex is not called time.
"""

from __future__ import annotations

import pandas as pd
import pytest

import drivelash as dl


@pytest.fixture(scope="module")
def frame() -> pd.DataFrame:
    from drivelash.sim.scenarios import get_scenario

    return get_scenario("bench-0B").simulate(duration=0.2, seed=1).to_pandas()


def test_an_unnamed_datetime_index_is_named_and_the_advice_works(frame):
    stamps = pd.Timestamp("2026-11-27 13:00") + pd.to_timedelta(frame["t"], unit="s")
    df = frame.set_index(pd.DatetimeIndex(stamps)).drop(columns="t").rename_axis(None)
    with pytest.raises(dl.DataError) as e:
        dl.Trace.from_frame(df)
    hint = "the DataFrame's unnamed index looks like time (time stamps): df.rename_axis('t').reset_index()"
    assert hint in str(e.value)
    tr = dl.Trace.from_frame(df.rename_axis("t").reset_index())  # the advice, followed
    assert tr["t"][-1] == pytest.approx(frame["t"].iloc[-1] - frame["t"].iloc[0], abs=1e-9)
    # a float index keeps its hint; a default RangeIndex (negative control) gets none
    with pytest.raises(dl.DataError, match=r"unnamed index looks like time: df\.rename_axis"):
        dl.Trace.from_frame(frame.set_index("t").rename_axis(None))
    with pytest.raises(dl.DataError) as e:
        dl.Trace.from_frame(frame.drop(columns="t"))
    assert "index" not in str(e.value)
