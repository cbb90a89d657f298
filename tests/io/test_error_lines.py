"""Errors that point at a data row name the place the user finds it: the 1-based line of a text
file as an editor numbers it (preamble, header, units row, comment and blank lines counted), and
``data row N (1-based)`` in a file without lines (Parquet, HDF5). The whole-file loader and the
streamed reader give the same message (one map, ``DataRows``, kept by the reader).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from drivelash.errors import DataError, DataRows
from drivelash.io import Trace, load_trace, write_trace
from drivelash.io.formats import CsvLines, open_source
from drivelash.io.stream import TraceStream

N = 600
NAMES = ("t", "theta_m", "omega_m", "torque_m")

#: text layouts: separator, lines above the header, units row, blank lines before data row k,
#: decimal commas, line end
LAYOUTS: dict[str, dict] = {
    "plain": {"sep": ","},
    "preamble_units": {
        "sep": ";",
        "above": ["Drive trace export", "Date;27.11.2026", "Axis: X1", ""],
        "units": "s;rad;rad/s;Nm",
    },
    "comments_blank": {
        "sep": ",",
        "above": ["# drivelash.meta {}", "# exported by hand", ""],
        "blanks": {0: ["", "   "], 7: [""], 100: ["", "\t"], 399: [" "]},
    },
    "decimal_comma": {"sep": ";", "comma": True, "blanks": {50: [""]}, "above": ["Achse;X", ""]},
    "tab_crlf": {"sep": "\t", "eol": "\r\n", "blanks": {5: ["", " "]}},
    "whitespace": {"sep": " ", "blanks": {3: [""]}, "units": "s rad rad/s Nm"},
}


def _signals() -> dict[str, list[str]]:
    t = np.arange(N) / 1000.0
    cols = [t, np.sin(t), np.cos(t), 0.3 * np.sin(3 * t) + 0.05]
    return {n: [repr(float(v)) for v in c] for n, c in zip(NAMES, cols, strict=True)}


def _write(
    path: Path, layout: str, cells: dict[tuple[int, str], str] | None = None, extra: str = ""
) -> list[int]:
    """Write ``layout`` with ``cells`` (data row, column) → text replaced and ``extra`` appended
    to data row 10; returns the 1-based file line of every data row (counted while writing)."""
    lay = LAYOUTS[layout]
    sep, eol = lay["sep"], lay.get("eol", "\n")
    vals = _signals()
    for (row, col), text in (cells or {}).items():
        vals[col][row] = text
    lines = [*lay.get("above", []), sep.join(NAMES)]
    if lay.get("units"):
        lines.append(lay["units"])
    where: list[int] = []
    for k in range(N):
        lines.extend(lay.get("blanks", {}).get(k, []))
        row = [vals[n][k] for n in NAMES]
        if lay.get("comma"):
            row = [c.replace(".", ",") for c in row]
        lines.append(sep.join(row) + (sep + extra if extra and k == 10 else ""))
        where.append(len(lines))  # 1-based line of this data row
    path.write_bytes((eol.join(lines) + eol).encode())
    return where


def _both(path: Path, **kw) -> str:
    """The one-line message of the whole-file loader; the stream (small chunks, so the row
    crosses chunk boundaries) must give the same one."""
    with pytest.raises(DataError) as whole:
        load_trace(path, **kw)
    with pytest.raises(DataError) as streamed:
        TraceStream(path, chunk_rows=64, **kw).close()
    msg = str(whole.value)
    assert str(streamed.value) == msg
    assert "\n" not in msg
    return msg


@pytest.mark.parametrize("layout", list(LAYOUTS))
@pytest.mark.parametrize("row", [0, 1, 57, 399, N - 1])
def test_a_bad_cell_names_its_line(tmp_path, layout, row):
    if row == 0 and any(not a.startswith("#") for a in LAYOUTS[layout].get("above", []) if a):
        pytest.skip("below a preamble the header is the line above a numeric row (not the bad one)")
    p = tmp_path / f"{layout}.csv"
    lines = _write(p, layout, {(row, "omega_m"): "abc"})
    msg = _both(p)
    assert msg == f"{p}, column 'omega_m', line {lines[row]}: not a number: 'abc'"
    # negative control: the 0-based data row index (the old "row N") is not the line
    assert lines[row] != row and f"row {row}" not in msg
    # the line really holds the bad cell, as an editor shows it
    assert "abc" in p.read_bytes().decode().replace("\r\n", "\n").split("\n")[lines[row] - 1]


KINDS = {
    # kind: (cells at data row r, fragment of the message, column named)
    "nan": (lambda r, v: {(r, "theta_m"): "nan"}, "NaN (1 bad sample(s))", "theta_m"),
    "empty": (lambda r, v: {(r, "torque_m"): ""}, "empty field", "torque_m"),
    "duplicated_time": (lambda r, v: {(r, "t"): v["t"][r - 1]}, "duplicated time stamp", "t"),
    "backwards_time": (lambda r, v: {(r, "t"): v["t"][r - 2]}, "time goes backwards", "t"),
    "gap": (
        lambda r, v: {(k, "t"): repr(float(v["t"][k]) + 0.0005) for k in range(r, N)},
        "non-uniform sampling",
        "t",
    ),
}


@pytest.mark.parametrize("layout", list(LAYOUTS))
@pytest.mark.parametrize("kind", list(KINDS))
@pytest.mark.parametrize("row", [2, 64, 401])
def test_validation_errors_name_the_line_whole_and_streamed(tmp_path, layout, kind, row):
    if kind == "empty" and layout == "whitespace":
        pytest.skip("no empty field between spaces")
    cells, fragment, column = KINDS[kind]
    p = tmp_path / f"{kind}.csv"
    lines = _write(p, layout, cells(row, _signals()))
    msg = _both(p)
    assert f"{p}, column '{column}', line {lines[row]}: {fragment}" in msg, msg
    assert lines[row] != row and f"row {row}" not in msg  # not the data row index


@pytest.mark.parametrize("layout", list(LAYOUTS))
def test_constant_signal_and_wide_row_name_the_line(tmp_path, layout):
    p = tmp_path / "const.csv"
    lines = _write(p, layout, {(k, "torque_m"): "0.5" for k in range(N)})
    assert f"column 'torque_m', line {lines[0]}: constant signal" in _both(p)
    if layout == "whitespace":
        return  # a trailing field of whitespace-separated text: not the wide-row check
    q = tmp_path / "wide.csv"
    lines = _write(q, layout, extra="7")
    assert f"{q}, line {lines[10]}: 5 fields where the header names 4 columns" in _both(q)


def test_a_comment_line_inside_the_data_is_a_row_named_by_its_line(tmp_path):
    """Only the lines above the header may be ``#`` comments; one inside the data is read as a
    row, and its error names its own line (not the line of the row counted without it)."""
    p = tmp_path / "c.csv"
    lines = _write(p, "comments_blank", {(20, "t"): "# paused here"})
    assert _both(p) == f"{p}, column 't', line {lines[20]}: not a number: '# paused here'"


def test_truncated_last_row_names_its_line(tmp_path):
    p = tmp_path / "cut.csv"
    lines = _write(p, "comments_blank")
    text = p.read_text()
    p.write_text(text[: text.rstrip().rfind(",")])  # the last row loses its last field, no newline
    msg = _both(p)
    assert f"{p}, line {lines[-1]}: last row is incomplete" in msg, msg


def test_warnings_name_the_line_whole_and_streamed(tmp_path):
    """Notes on a valid file (a NaN in a column no computation reads, an encoder wrap-around)
    name the line too, the same whole and streamed."""
    p = tmp_path / "w.csv"
    vals = _signals()
    flag = ["1.0"] * N
    flag[123] = "nan"
    theta = np.mod(np.arange(N) / 1000.0 * 40.0, 2 * np.pi)  # wraps at one revolution
    text = ["# exported by hand", "", "t,theta_m,flag"]
    where = []
    for k in range(N):
        if k % 50 == 0:
            text.append("")
        text.append(f"{vals['t'][k]},{float(theta[k])!r},{flag[k]}")
        where.append(len(text))
    p.write_text("\n".join(text) + "\n")
    first_wrap = int(np.flatnonzero(np.diff(theta) < 0)[0] + 1)
    tr = load_trace(p)
    with TraceStream(p, chunk_rows=64) as st:  # the same notes (found in another order)
        assert sorted(st.meta["warnings"]) == sorted(tr.meta["warnings"])
    assert f"{p}, column 'flag', line {where[123]}: NaN (1 bad sample(s)) in a column" in " ".join(
        tr.meta["warnings"]
    )
    assert f"{p}, column 'theta_m', line {where[first_wrap]}: encoder wrap-around" in " ".join(
        tr.meta["warnings"]
    )


def test_a_resampled_or_sampled_down_row_is_named_by_the_files_line(tmp_path):
    """Sampled down (every 2nd sample kept) the gap before data row 300 is found between kept
    samples 149 and 150: named by the line of the file's row 300, not of row 150."""
    p = tmp_path / "gap.csv"
    v = _signals()
    lines = _write(p, "comments_blank", {(k, "t"): repr(float(v["t"][k]) + 0.0005) for k in range(300, N)})
    msg = _both(p)  # at the full rate
    assert f"line {lines[300]}: non-uniform sampling" in msg
    with pytest.raises(DataError, match=rf"line {lines[300]}: non-uniform sampling"):
        load_trace(p, max_rate_hz=500.0)
    tr = load_trace(p, resample=True, max_rate_hz=500.0)
    assert any(f"line {lines[300]}: non-uniform sampling; resampled" in w for w in tr.meta["warnings"])


@pytest.mark.parametrize("ext", ["parquet", "h5"])
def test_files_without_lines_name_the_1_based_data_row(tmp_path, ext):
    t = np.arange(N) / 1000.0
    th = np.sin(t)
    th[57] = np.nan
    p = write_trace(Trace({"t": t, "theta_m": th, "omega_m": np.cos(t)}), tmp_path / f"x.{ext}")
    msg = _both(p)
    assert msg == f"{p}, column 'theta_m', data row 58 (1-based): NaN (1 bad sample(s))"


def test_the_map_of_a_text_file_and_its_fallback(tmp_path):
    p = tmp_path / "m.csv"
    lines = _write(p, "preamble_units")
    with open_source(p) as src:
        rows = src.rows
        assert isinstance(rows, CsvLines)
        assert [rows.line(k) for k in (0, 1, N - 1)] == [lines[0], lines[1], lines[-1]]
        assert rows.count() == N
        assert rows.line(N) is None and rows.where(N) == f"data row {N + 1} (1-based)"
    assert DataRows().where(0) == "data row 1 (1-based)"
    assert DataRows().taken([4, 8]).where(1) == "data row 9 (1-based)"
    assert str(DataError("bad", path="f", column="c", row=3)) == "f, column 'c', data row 4 (1-based): bad"
