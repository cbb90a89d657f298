"""A text column nothing reads (a CNC's status or comment column) does not refuse a CSV file.

Found by an exploratory tester (session 20, A16): an unmapped ``Comment = "ok"`` column made a
CSV trace unreadable ("column 'Comment', line 2: not a number: 'ok'") while the same column in a
Parquet file was dropped without a word. Now the CSV reader leaves text columns unread and
raises their first bad cell only when the mapping uses them — whole-file and streamed. The
negative controls keep every refusal a used column had: a mapped text column, an unmapped one
carrying a Trace name, a bad cell in a numeric column.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from drivelash.errors import DataError
from drivelash.io.load import load_trace
from drivelash.io.stream import iter_trace_chunks

MAPPING = {
    "Time [ms]": {"column": "t", "unit": "ms"},
    "Pos motor": {"column": "theta_m", "unit": "rad"},
    "Pos load": {"column": "theta_l", "unit": "rad"},
    "Torque": {"column": "torque_m", "unit": "N*m"},
}


def _frame(n: int = 400) -> pd.DataFrame:
    t = np.arange(n) * 1.0  # ms
    return pd.DataFrame(
        {
            "Time [ms]": t,
            "Pos motor": np.sin(2 * np.pi * t / 200.0),
            "Pos load": 0.9 * np.sin(2 * np.pi * t / 200.0),
            "Torque": np.cos(2 * np.pi * t / 200.0),
        }
    )


def _streamed(path, mapping, name):
    return np.concatenate([c[name] for c in iter_trace_chunks(path, mapping, chunk_rows=128)])


@pytest.mark.parametrize("sep", [",", ";"])
def test_an_unmapped_text_column_is_dropped_as_in_parquet(tmp_path, sep):
    """The numbers equal those of the file without the column (whole and streamed), for a
    comma- and a semicolon-separated file, with the column first (pyarrow's row count reads
    the first column) and last."""
    df = _frame()
    plain = tmp_path / "plain.csv"
    df.to_csv(plain, index=False, sep=sep)
    ref = load_trace(plain, MAPPING)
    for where in ("first", "last"):
        extra = df.assign(Status="RUN", Comment="ok")
        if where == "first":
            extra = extra[["Status", *df.columns, "Comment"]]
        p = tmp_path / f"text_{where}.csv"
        extra.to_csv(p, index=False, sep=sep)
        tr = load_trace(p, MAPPING)
        for c in ("t", "theta_m", "theta_l", "torque_m"):
            np.testing.assert_array_equal(tr[c], ref[c])
            np.testing.assert_array_equal(_streamed(p, MAPPING, c), ref[c])
        pq = tmp_path / f"text_{where}.parquet"
        extra.to_parquet(pq)
        np.testing.assert_array_equal(load_trace(pq, MAPPING)["theta_m"], ref["theta_m"])


def test_without_a_mapping_the_trace_columns_are_read_and_the_text_one_dropped(tmp_path):
    """No ``[columns]``: every column passes through, a text column that is no Trace column
    is dropped (whole and streamed)."""
    df = pd.DataFrame({"t": np.arange(300) / 1000.0, "theta_m": np.linspace(0, 1, 300)})
    p = tmp_path / "plain_names.csv"
    df.assign(Mode="AUTO").to_csv(p, index=False)
    tr = load_trace(p)
    assert "Mode" not in tr.columns
    np.testing.assert_array_equal(tr["theta_m"], df["theta_m"].to_numpy())
    chunks = list(iter_trace_chunks(p, chunk_rows=64))
    assert all("Mode" not in c.columns for c in chunks)
    np.testing.assert_array_equal(np.concatenate([c["theta_m"] for c in chunks]), df["theta_m"].to_numpy())


def test_a_mapped_text_column_is_still_refused_at_its_first_bad_cell(tmp_path):
    """Negative control: a column the mapping uses keeps the one-line error naming file,
    column and line — whole and streamed."""
    df = _frame().astype({"Torque": object})
    df.loc[4, "Torque"] = "n/a"
    p = tmp_path / "bad_torque.csv"
    df.assign(Comment="ok").to_csv(p, index=False)
    msg = rf"{p.name}, column 'Torque', line 6: not a number: 'n/a'"
    with pytest.raises(DataError, match=msg):
        load_trace(p, MAPPING)
    with pytest.raises(DataError, match=msg):
        list(iter_trace_chunks(p, MAPPING, chunk_rows=128))


def test_an_unmapped_trace_named_text_column_is_still_refused(tmp_path):
    """Negative control: an unmapped column named like a Trace column passes through and is
    used, so its bad cell is named (with and without a mapping)."""
    df = _frame().assign(omega_m=np.zeros(400)).astype({"omega_m": object})
    df.loc[2, "omega_m"] = "abc"
    p = tmp_path / "bad_omega.csv"
    df.to_csv(p, index=False)
    with pytest.raises(DataError, match=r"column 'omega_m', line 4: not a number: 'abc'"):
        load_trace(p, MAPPING)
    with pytest.raises(DataError, match=r"column 'omega_m', line 4: not a number: 'abc'"):
        list(iter_trace_chunks(p, MAPPING, chunk_rows=128))
    bare = pd.DataFrame({"t": np.arange(10) / 1e3, "theta_m": np.arange(10.0)}).astype({"theta_m": object})
    bare.loc[3, "theta_m"] = "x"
    q = tmp_path / "bare.csv"
    bare.to_csv(q, index=False)
    with pytest.raises(DataError, match=r"column 'theta_m', line 5: not a number: 'x'"):
        load_trace(q)


def test_a_comma_in_a_text_column_does_not_switch_on_decimal_commas(tmp_path):
    """A semicolon file whose numbers have decimal points and whose comment holds a comma
    ("ok, idle"): the comma says nothing about the numbers (before the text columns were
    dropped it would have made every point a "mixed decimal marks" error). Negative control:
    a decimal-comma file still reads its commas."""
    df = _frame()
    p = tmp_path / "points.csv"
    df.assign(Comment="ok, idle").to_csv(p, index=False, sep=";")
    np.testing.assert_array_equal(load_trace(p, MAPPING)["theta_m"], df["Pos motor"].to_numpy())
    q = tmp_path / "commas.csv"
    df.assign(Comment="ok, idle").to_csv(q, index=False, sep=";", decimal=",")
    np.testing.assert_array_equal(load_trace(q, MAPPING)["theta_m"], df["Pos motor"].to_numpy())
