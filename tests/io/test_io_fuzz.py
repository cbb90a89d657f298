"""Fuzzing the CSV reader: arbitrary bytes and near-valid CSV raise DataError or load."""

from __future__ import annotations

import tempfile
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drivelash.errors import DrivelashError
from drivelash.io import load_trace

_TMP = Path(tempfile.mkdtemp(prefix="drivelash-fuzz-"))

_cell = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-(10**6), 10**6).map(str),
    st.sampled_from(["", " ", "nan", "inf", "-inf", "abc", "1e400", "0x10", "1_000", '"1"', "1,2"]),
)


@st.composite
def near_csv(draw) -> str:
    header = draw(
        st.lists(st.sampled_from(["t", "theta_m", "omega_m", "torque_m", "x", "t"]), min_size=0, max_size=5)
    )
    n_rows = draw(st.integers(0, 12))
    sep = draw(st.sampled_from([",", ";", "\t", " "]))
    rows = [sep.join(draw(st.lists(_cell, min_size=0, max_size=6))) for _ in range(n_rows)]
    tail = draw(st.sampled_from(["", "\n", "\r\n"]))
    return "\n".join([sep.join(header), *rows]) + tail


def _check(data: bytes, name: str) -> None:
    p = _TMP / name
    p.write_bytes(data)
    try:
        load_trace(p, required=["theta_m"])
    except DrivelashError as exc:
        assert "\n" not in str(exc), str(exc)


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(near_csv())
def test_fuzz_near_valid_csv(text):
    _check(text.encode("utf-8"), "near.csv")


@settings(max_examples=150, deadline=None)
@given(st.binary(max_size=300))
def test_fuzz_arbitrary_bytes_as_csv(data):
    _check(data, "bytes.csv")


@settings(max_examples=100, deadline=None)
@given(st.binary(max_size=300), st.sampled_from(["x.parquet", "x.h5", "x.mat"]))
def test_fuzz_arbitrary_bytes_as_binary_formats(data, name):
    _check(data, name)


def test_empty_header_name_with_a_cell_pyarrow_refuses(tmp_path):
    """Found by the fuzzer (seed 7): a header ending in a separator (an empty name) and a cell
    pyarrow refuses (``1_000``) sent the streamed reader to the strict one mid-file, which named
    the column ``Unnamed: 5`` — a raw ``KeyError: ''``. Now one line."""
    p = tmp_path / "k.csv"
    p.write_text("\n0.0,1.0,2.0,3.0,4.0,\n0.0,0.0,0.0,0.0,0.0,1_000")
    try:
        load_trace(p, required=["theta_m"])
    except DrivelashError as exc:
        assert "\n" not in str(exc) and "k.csv" in str(exc)
    else:  # pragma: no cover - the file has no time column
        raise AssertionError("loaded a file without a time column")
