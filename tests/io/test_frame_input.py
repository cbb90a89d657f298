"""A DataFrame is read like a file (one loader): time stamps, the time index, non-numeric and
duplicate columns, string column mappings, unread columns with NaN.

Each case was a wrong "missing required column", a raw pydantic/TypeError traceback, or a
refused recording before; the negative controls keep the real errors errors.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import drivelash as dl
from drivelash.sim.scenarios import get_scenario

FRAME = "<DataFrame>"


@pytest.fixture(scope="module")
def df() -> pd.DataFrame:
    return get_scenario("bench-0C").simulate(duration=0.5, seed=1).to_pandas()


def _stamped(df: pd.DataFrame) -> pd.DataFrame:
    d = df.copy()
    d["t"] = pd.Timestamp("2026-11-27 13:00:00") + pd.to_timedelta(d["t"], unit="s")
    return d


def test_datetime_t_column_reads_as_seconds_from_the_first_stamp_like_parquet(df, tmp_path):
    d = _stamped(df)
    pq = tmp_path / "dt.parquet"
    d.to_parquet(pq)
    from_file = dl.load_trace(pq)
    from_frame = dl.Trace.from_frame(d)
    np.testing.assert_array_equal(from_frame["t"], from_file["t"])  # one rule, bit-identical
    assert from_frame["t"][0] == 0.0 and from_frame.T_s == pytest.approx(1.25e-4, rel=1e-6)
    assert from_frame.meta["time_origin"]["t"] == "2026-11-27T13:00:00"
    # a zone is kept in the origin; the seconds are the same
    z = d.copy()
    z["t"] = z["t"].dt.tz_localize("Europe/Berlin")
    tz = dl.Trace.from_frame(z)
    np.testing.assert_array_equal(tz["t"], from_file["t"])
    assert tz.meta["time_origin"]["t"] == "2026-11-27T13:00:00+01:00"


def test_timedelta_t_column_frame_and_parquet(df, tmp_path):
    d = df.copy()
    d["t"] = pd.to_timedelta(d["t"], unit="s")
    pq = tmp_path / "td.parquet"
    d.to_parquet(pq)
    a, b = dl.Trace.from_frame(d), dl.load_trace(pq)
    np.testing.assert_array_equal(a["t"], b["t"])
    assert np.max(np.abs(a["t"] - df["t"].to_numpy())) <= 1.5e-9  # timedelta64 holds whole ns


def test_time_as_the_index_is_the_time_column(df):
    tr = dl.Trace.from_frame(df.set_index("t"))
    np.testing.assert_array_equal(tr["t"], df["t"].to_numpy())
    # negative control: an unnamed index is not taken for the time
    with pytest.raises(dl.DataError, match="missing required column 't'"):
        dl.Trace.from_frame(df.drop(columns="t"))


def test_non_numeric_duplicate_and_multiindex_columns_are_named(df):
    d = df.copy()
    d["omega_l"] = d["omega_l"].astype(object)
    with pytest.raises(dl.DataError) as e:
        dl.Trace.from_frame(d)
    assert str(e.value).startswith(f"{FRAME}, column 'omega_l': not numeric (dtype object)")
    # an unread non-numeric column is ignored, as before (negative control)
    d = df.copy()
    d["label"] = "x"
    assert "label" not in dl.Trace.from_frame(d).names
    d = pd.concat([df, df[["theta_m"]]], axis=1)
    with pytest.raises(dl.DataError, match=r"column 'theta_m': duplicate column name"):
        dl.Trace.from_frame(d)
    m = df.copy()
    m.columns = pd.MultiIndex.from_tuples([(c, "x") for c in df.columns])
    with pytest.raises(dl.DataError, match="MultiIndex column names") as e:
        dl.Trace.from_frame(m)
    assert "\n" not in str(e.value)


def test_string_mapping_is_source_to_trace_column(df):
    d = df.rename(columns={"theta_l": "pos_load"})
    tr = dl.Trace.from_frame(d, {"pos_load": "theta_l", "t": "t"})
    np.testing.assert_array_equal(tr["theta_l"], df["theta_l"].to_numpy())
    assert tr.meta["mapping"]["pos_load"] == {"column": "theta_l", "unit": "rad"}
    # the other direction (Trace column → source) names the missing source column
    with pytest.raises(dl.DataError, match="column 'theta_l': missing required column"):
        dl.Trace.from_frame(d, {"theta_l": "pos_load"})


@pytest.mark.parametrize(
    ("mapping", "match"),
    [
        ({"theta_l": {"column": "theta_l", "unit": "degg"}}, r"columns\.theta_l\.unit: unknown unit 'degg'"),
        ({"theta_l": 3}, r"columns\.theta_l: must be a Trace column name"),
        ({"theta_l": {"unit": "deg"}}, r"columns\.theta_l\.column: Field required"),
    ],
)
def test_invalid_mapping_entry_is_one_line_naming_the_key(df, mapping, match):
    with pytest.raises(dl.ParameterError, match=match) as e:
        dl.Trace.from_frame(df, mapping)
    assert "\n" not in str(e.value)


def test_load_trace_takes_a_config_path_and_refuses_other_mappings(df, tmp_path):
    pq = tmp_path / "r.parquet"
    df.to_parquet(pq)
    cfg = tmp_path / "c.toml"
    cfg.write_text(  # the load's position and velocity scaled alike (the loader checks one against the other)
        '[columns.theta_l]\ncolumn = "theta_l"\nunit = "rad"\nscale = 2.0\n'
        '[columns.omega_l]\ncolumn = "omega_l"\nunit = "rad/s"\nscale = 2.0\n'
    )
    tr = dl.load_trace(pq, str(cfg))
    np.testing.assert_array_equal(tr["theta_l"], 2.0 * df["theta_l"].to_numpy())
    np.testing.assert_array_equal(tr["omega_l"], 2.0 * df["omega_l"].to_numpy())
    with pytest.raises(dl.ParameterError, match="mapping.int: must be a DriveConfig, a configuration path"):
        dl.load_trace(pq, 3)


def test_nan_in_an_unread_column_leaves_it_out_file_stream_and_frame(df, tmp_path):
    from drivelash.io.stream import TraceStream

    d = df.copy()
    d["flag"] = np.nan
    d.loc[3, "theta_ref"] = np.nan
    pq = tmp_path / "flag.parquet"
    d.to_parquet(pq)
    for tr in (dl.Trace.from_frame(d), dl.load_trace(pq)):
        assert "flag" not in tr.names and "theta_ref" not in tr.names
        np.testing.assert_array_equal(tr["theta_m"], df["theta_m"].to_numpy())
        notes = [w for w in tr.meta["warnings"] if "does not read" in w]
        assert len(notes) == 2
        assert any("column 'theta_ref', data row 4 (1-based): NaN (1 bad sample(s))" in n for n in notes)
    with TraceStream(pq, None) as st:
        assert "flag" not in st.names and "theta_ref" not in st.names
        assert sum("does not read" in w for w in st.meta["warnings"]) == 2
    # negative control: a NaN in a column that is read stays an error (frame, file, stream)
    d.loc[5, "omega_l"] = np.nan
    d.to_parquet(pq)
    for load in (lambda: dl.Trace.from_frame(d), lambda: dl.load_trace(pq), lambda: TraceStream(pq, None)):
        with pytest.raises(dl.DataError, match=r"column 'omega_l', data row 6 \(1-based\): NaN"):
            load()
