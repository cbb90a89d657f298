"""File formats: CSV, Parquet, HDF5 (plain datasets or pandas-style tables), MATLAB ``.mat``.

Readers return a :class:`RawTable` — source columns as float64 arrays plus the
scalars stored next to them (e.g. ``gtau`` in the EMPS ``.mat`` files) — before
any unit conversion or validation; :func:`drivelash.io.load_trace` does those.
Writers take a :class:`~drivelash.io.trace.Trace`; commands write through
:class:`drivelash.io.outputs.Outputs` (temporary names, renamed together at the end).

The format is chosen by extension and then checked against the content (magic
bytes): a ``.parquet`` file that is really CSV is a "wrong file type" error, a
Parquet file without its footer is "truncated". Nothing is ever unpickled.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import NO_LINES, DataError, DataRows
from drivelash.io.trace import Trace, meta_json

#: extension → format name
EXTENSIONS: dict[str, str] = {
    ".csv": "csv",
    ".txt": "csv",
    ".parquet": "parquet",
    ".pq": "parquet",
    ".h5": "hdf5",
    ".hdf5": "hdf5",
    ".hdf": "hdf5",
    ".mat": "mat",
}
FORMATS = ("csv", "parquet", "hdf5", "mat", "mat73")

_HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
_META_KEY = "drivelash_meta"
_ORDER_KEY = "drivelash_columns"


def stamps_to_seconds(ns: np.ndarray, origin_ns: int) -> np.ndarray:
    """Time stamps or durations [ns] as seconds [s] from ``origin_ns`` [ns].

    ``ns``: int64 (exact subtraction before the division), or float64 with NaN where a stamp is
    missing. One rule for the Parquet reader and :meth:`drivelash.io.trace.Trace.from_frame`.
    """
    return (ns - origin_ns) / 1e9 if ns.dtype.kind == "i" else (ns - float(origin_ns)) / 1e9


@dataclass
class RawTable:
    """Source columns of a file, before mapping and validation.

    Attributes
    ----------
    columns : dict[str, numpy.ndarray]
        Source name → 1-D float64 array (all of equal length).
    scalars : dict[str, float]
        Scalar values stored in the file (e.g. gains), by name.
    meta : dict
        Provenance read from the file (drivelash writes its ``meta`` there).
    path : str
        The file.
    fmt : str
        Detected format.
    rows : DataRows
        Where the data rows are in the file, for messages (:class:`CsvLines` of a text file).
    unread : dict[str, DataError]
        Text columns of a CSV file that are not numbers (a CNC's status or comment column):
        left out of ``columns``; the error naming the first bad cell is raised only when the
        mapping uses the column (:func:`drivelash.io.load.trace_from_table`), as a Parquet
        file's string columns are not numeric columns either.
    """

    columns: dict[str, np.ndarray]
    scalars: dict[str, float] = field(default_factory=dict)
    meta: dict[str, Any] = field(default_factory=dict)
    path: str = ""
    fmt: str = ""
    rows: DataRows = field(default=NO_LINES, repr=False, compare=False)
    unread: dict[str, DataError] = field(default_factory=dict, repr=False, compare=False)


# --------------------------------------------------------------------------- sniffing
def _sniff(head: bytes) -> str:
    """Format suggested by the first bytes of a file: a name from FORMATS or 'text', 'utf16' or 'binary'."""
    if head.startswith(b"PAR1"):
        return "parquet"
    if head.startswith(_HDF5_MAGIC):
        return "hdf5"
    if head.startswith(b"MATLAB 7.3"):
        return "mat73"
    if head.startswith(b"MATLAB 5.0") or head[:116].startswith(b"MATLAB"):
        return "mat"
    if len(head) >= 520 and head[512:520] == _HDF5_MAGIC:
        return "hdf5"
    if head.startswith((b"\xff\xfe", b"\xfe\xff")):
        return "utf16"
    if b"\x00" in head:
        return "binary"
    try:
        head.decode("utf-8")
    except UnicodeDecodeError as exc:
        if exc.start < len(head) - 4:  # not just a multi-byte char cut at the end
            return "cp1252" if _windows_text(head) else "binary"
    return "text"


def _windows_text(head: bytes) -> bool:
    """Whether ``head`` reads as Windows-1252 text: every byte defined there, no control
    character but tab, CR and LF (binary data has them; a spreadsheet's "CSV" does not)."""
    try:
        text = head.decode("cp1252")
    except UnicodeDecodeError:
        return False
    return not any(ord(ch) < 32 and ch not in "\t\r\n" for ch in text)


def not_utf8_problem(head: bytes) -> str:
    """What is wrong with text that is not UTF-8: the first offending byte, its line and column
    (1-based) and the character it is in Windows-1252 (a spreadsheet's "CSV" on Windows)."""
    try:
        head.decode("utf-8")
        return "not UTF-8 text: save it as CSV UTF-8"
    except UnicodeDecodeError as exc:
        at = exc.start
    line = head.count(b"\n", 0, at) + 1
    col = at - (head.rfind(b"\n", 0, at) + 1) + 1
    byte = head[at]
    try:
        ch = f" — Windows-1252 '{bytes([byte]).decode('cp1252')}'?"
    except UnicodeDecodeError:
        ch = ""
    return f"not UTF-8 text (byte 0x{byte:02X} at line {line}, position {col}{ch}): save it as CSV UTF-8"


def detect_format(path: str | Path) -> str:
    """Check that ``path`` exists, is non-empty and its content matches its extension.

    Returns
    -------
    str
        ``"csv"``, ``"parquet"``, ``"hdf5"``, ``"mat"`` (v5) or ``"mat73"``.

    Raises
    ------
    DataError
        Missing or empty file, unsupported extension, content of another type.
    """
    p = Path(path)
    if not p.exists():
        raise DataError("no such file", path=str(p))
    if p.is_dir():
        raise DataError("is a directory, expected a recording file", path=str(p))
    ext = p.suffix.lower()
    if ext not in EXTENSIONS:
        hint = "; save the sheet as CSV" if ext in (".xlsx", ".xls", ".xlsm", ".ods") else ""
        raise DataError(
            f"unsupported file type '{ext or '(no extension)'}' (supported: .csv, .parquet, .h5/.hdf5,"
            f" .mat){hint}",
            path=str(p),
        )
    if p.stat().st_size == 0:
        raise DataError("file is empty", path=str(p))
    with p.open("rb") as fh:
        head = fh.read(1024)
    kind = _sniff(head)
    expected = EXTENSIONS[ext]
    described = {
        "text": "text (CSV?)",
        "binary": "unrecognised binary data",
        "cp1252": "text (not UTF-8)",
        "utf16": 'UTF-16 text (a spreadsheet\'s "Unicode Text"): save it as CSV UTF-8',
        "parquet": "Parquet",
        "hdf5": "HDF5",
        "mat": "MATLAB v5",
        "mat73": "MATLAB v7.3",
    }
    if expected == "csv":
        if kind == "cp1252":
            raise DataError(not_utf8_problem(head), path=str(p))
        if kind != "text":
            raise DataError(
                f"wrong file type: extension {ext} but the content is {described[kind]}", path=str(p)
            )
        return "csv"
    if expected == "mat":
        if kind in ("mat", "mat73"):
            return kind
    elif kind == expected:
        return expected
    raise DataError(f"wrong file type: extension {ext} but the content is {described[kind]}", path=str(p))


# --------------------------------------------------------------------------- helpers
def _as_column(a: Any) -> np.ndarray | None:
    """A 1-D float64 view of a numeric vector (n, (n,1), (1,n)); None if not a vector."""
    arr = np.asarray(a)
    if arr.dtype.kind not in "biuf":
        return None
    if arr.ndim == 2 and 1 in arr.shape:
        arr = arr.reshape(-1)
    if arr.ndim != 1:
        return None
    return arr.astype(np.float64)


def _sniff_sep(header: str) -> str:
    """The column separator of a CSV header line: ``,``, else ``;`` or tab, else whitespace."""
    if "," in header:
        return ","
    for cand in (";", "\t"):
        if cand in header:
            return cand
    return r"\s+" if " " in header.strip() else ","


#: lines searched for the column header below a tool's preamble (``Name: Scope``, ``Date;…``)
PREAMBLE_MAX_LINES = 50


def _fields(line: str, sep: str) -> list[str]:
    return line.split() if sep == r"\s+" else line.split(sep)


def _numeric_row(line: str, sep: str, *, stamps: bool = False) -> bool:
    """Every field of ``line`` is a number (decimal commas where ``sep`` is not a comma) or,
    with ``stamps``, a time stamp (ISO 8601 or dotted day-first): a row of a table."""
    fields = [f.strip().strip('"').strip() for f in _fields(line, sep)]
    values = [f for f in fields if not (stamps and (_ISO_TIME.match(f) or _DOTTED_TIME.match(f)))]
    if sep != ",":
        values = [f.replace(",", ".") for f in values]
    try:
        [float(f) for f in values]  # noqa: B018 - only whether each field parses
    except ValueError:
        return False
    return bool(fields)


def _same_width(header: str, row: str) -> bool:
    """``row`` has as many fields as ``header`` names columns (split by the header's separator)."""
    sep = _sniff_sep(header)
    return len(_header_tokens(header, sep)) == len(_fields(row, sep))


def _width(line: str) -> int:
    """Fields of ``line`` split by its own separator."""
    return len(_header_tokens(line, _sniff_sep(line)))


def _usual_start(header: str, row: str) -> bool:
    """``header`` over ``row`` is how a table starts: ``row`` as wide, and a row of numbers and
    time stamps or at least one number in it (a data row with a bad cell is still data)."""
    if not _same_width(header, row):
        return False
    sep = _sniff_sep(header)
    if _numeric_row(row, sep, stamps=True):
        return True
    return any(_numeric_row(f, sep) for f in _fields(row, sep) if f.strip())


def _header_index(lines: list[str]) -> int:
    """Index of the column header among the first non-blank lines of a CSV file.

    The first line, where the line below it starts a table (:func:`_usual_start`) or is its
    units row (:func:`units_row`) and every line below it in ``lines`` is as wide. Otherwise a
    tool wrote a preamble above the table — lines of other widths, or ``key;value`` lines (then
    the header is sought among lines of another width or separator than the first; a title
    line such as ``Renishaw XL-80`` splits like ``Machine;DMU 65`` at its space, and a
    ``Temp;20,3`` below ``Date;…`` looks like a header over a data row) — and the header is the
    first line that has as many fields as the row of numbers and time stamps below it (or below
    its units row) and is not itself numeric. Where no line fits, the first line (the reader
    then names the problem as before).

    Parameters
    ----------
    lines : list of str
        The first non-blank lines of the file (up to ``PREAMBLE_MAX_LINES + 3``; all of a
        shorter file).

    Returns
    -------
    int
        Index of the header in ``lines``.
    """
    if len(lines) < 2:
        return 0
    skip = None
    sep0 = _sniff_sep(lines[0])
    if _same_width(lines[0], lines[1]):
        starts = _usual_start(lines[0], lines[1]) or _unit_cells(
            _header_tokens(lines[0], sep0), lines[1], sep0
        )
        # a table keeps its width: a preamble line over a look-alike row does not (s19 F3)
        if starts and all(_same_width(lines[0], ln) for ln in lines[2:]):
            return 0
        skip = (sep0, _width(lines[0]))  # key;value lines above the table
    for i in range(1, len(lines) - 1):
        sep = _sniff_sep(lines[i])
        if (sep, _width(lines[i])) == skip:
            continue
        if not _same_width(lines[i], lines[i + 1]) or _mostly_numeric_row(lines[i], sep):
            continue  # a header is no row of numbers (one with a trailing separator neither)
        below = i + 1
        if _unit_cells(_header_tokens(lines[i], sep), lines[i + 1], sep) and i + 2 < len(lines):
            below = i + 2  # names, units, then the numbers (a DAQ's export)
        if _same_width(lines[i], lines[below]) and _mostly_numeric_row(lines[below], sep):
            return i
    return 0


def _mostly_numeric_row(line: str, sep: str) -> bool:
    """More than half of the fields of ``line`` are numbers or time stamps: a data row, which
    may carry a text column (a CNC's status or comment) that the reader drops. A ``key;value``
    preamble line (``Temp;20,3``: one of two) is not (session 30 tester A, M1: a preamble over
    a table with a ``Status`` column was taken for the header)."""
    fields = [f.strip().strip('"').strip() for f in _fields(line, sep)]
    n = sum(_numeric_row(f, sep, stamps=True) for f in fields if f)
    return 2 * n > len(fields)


#: How drive tools and DAQ exports write the units a ``[columns]`` unit names (a cell of a
#: units row may also be bracketed: ``[rad]``, ``(deg)``); see docs/assumptions.md "Units row".
UNIT_ALIASES = {
    "N.m": "N·m",
    "N*m": "N·m",
    "Nm": "N·m",
    "°": "deg",
    "°/s": "deg/s",
    "1/min": "rpm",
    "U/min": "rpm",
    "µs": "us",
    "µm": "um",
    "inc": "counts",
    "sec": "s",
    "msec": "ms",
    "rad/sec": "rad/s",
    "deg/sec": "deg/s",
    "-": "1",
    "%": "1",
}


def unit_name(text: str, *, number: bool = False) -> str | None:
    """The ``[columns]`` unit a cell names (``rad``, ``[rad]``, ``(Nm)``, ``°``), else None.
    A number (``1``) names none unless ``number``: in a row that may be data it is a value."""
    from drivelash.io.config import UNIT_KIND

    u = text.strip().strip('"').strip()
    if len(u) >= 2 and u[0] + u[-1] in ("[]", "()", "{}"):
        u = u[1:-1].strip()
    if not number:
        try:
            float(u)  # the cell as written: '-' (dimensionless) is no number, '1' is
            return None
        except ValueError:
            pass
    u = UNIT_ALIASES.get(u, u)
    return u if u in UNIT_KIND else None


def _unit_cells(tokens: list[str], line: str, sep: str) -> dict[str, str]:
    """The non-empty cells of a units row by column, as written (``[rad]``, ``%``). Empty when
    ``line`` is not a units row: another width than the header, numeric, or fewer than half of
    its non-empty cells naming a unit (:func:`unit_name`)."""
    cells = [c.strip().strip('"').strip() for c in _fields(line, sep)]
    if len(cells) != len(tokens) or _numeric_row(line, sep):
        return {}
    out = {name: c for name, c in zip(tokens, cells, strict=True) if name and c}
    known = sum(unit_name(c) is not None for c in out.values())
    return out if known and 2 * known >= len(out) else {}


def units_row(tokens: list[str], line: str, sep: str) -> dict[str, str] | None:
    """The units a row below the CSV header states (``s;rad;rad/s;Nm``, a DAQ's export), by
    column, or None when ``line`` is a data row.

    A units row has the header's width, is not numeric, and at least half of its non-empty
    cells name a unit ``[columns]`` knows (bracketed or in a spelling of :data:`UNIT_ALIASES`).
    Cells are kept as written; one that names no unit we know (``°C`` of a temperature channel,
    ``kNm``) matters only if that column is read (:func:`drivelash.io.load.stated_unit`).
    """
    return _unit_cells(tokens, line, sep) or None


#: Attribute / field-metadata keys holding a column's unit (HDF5 datasets, Parquet fields).
UNIT_ATTRS = ("unit", "units", "Unit", "Units")


def stated_unit_attr(attrs: dict[Any, Any]) -> str | None:
    """The unit a column's attribute states (``unit``/``units``, text or bytes), as written;
    None without one."""
    for key in UNIT_ATTRS:
        for k in (key, key.encode()):
            if k in attrs:
                v = attrs[k]
                v = v.decode("utf-8", "replace") if isinstance(v, bytes | np.bytes_) else v
                if isinstance(v, str | np.str_) and str(v).strip():
                    return str(v).strip()
    return None


def _preamble_warning(meta: dict[str, Any], preamble: list[str]) -> None:
    """Record the skipped preamble in ``meta["warnings"]`` (printed by every command)."""
    first = preamble[0].strip()
    first = first if len(first) <= 40 else first[:40] + "…"
    meta["warnings"] = [
        *meta.get("warnings", []),
        f"skipped {len(preamble)} line(s) above the column header (a preamble starting {first!r})",
    ]


#: an ISO 8601 date and time at the start of a cell (``2026-11-27 13:00:00.125``, ``…T…Z``)
_ISO_TIME = re.compile(r"^\d{4}-\d{2}-\d{2}[ T]\d{2}:\d{2}")
#: a dotted day.month.year date and time (``27.11.2026 13:00:00,125``: German-locale tools)
_DOTTED_TIME = re.compile(r"^(\d{1,2})\.(\d{1,2})\.(\d{4})([ T]\d{1,2}:\d{2}(?::\d{2})?)(?:[.,](\d+))?")
#: a date with slashes: month/day or day/month (not read: the order is not known)
_SLASHED_DATE = re.compile(r"^\d{1,2}/\d{1,2}/\d{2,4}\b")


def _as_iso(text: str) -> str:
    """A dotted ``DD.MM.YYYY hh:mm:ss[,.]fff`` stamp rewritten as ISO 8601; other text as it is."""
    m = _DOTTED_TIME.match(text)
    if m is None:
        return text
    d, mo, y, hms, frac = m.groups()
    return f"{y}-{int(mo):02d}-{int(d):02d}{hms}" + (f".{frac}" if frac else "") + text[m.end() :]


def _timestamp_columns(tokens: list[str], first_row: str, sep: str) -> list[str]:
    """Columns whose first data cell is an ISO 8601 date and time (a logger's time stamps)."""
    if sep == r"\s+":  # a space inside the time stamp would split it
        return []
    cells = [f.strip().strip('"') for f in _fields(first_row, sep)]
    if len(cells) != len(tokens):
        return []
    return [
        name
        for name, cell in zip(tokens, cells, strict=True)
        if _ISO_TIME.match(cell) or _DOTTED_TIME.match(cell)
    ]


def _seconds_from_timestamps(s: Any, p: Path, name: str, meta: dict[str, Any], rows: DataRows) -> np.ndarray:
    """ISO 8601 time stamps → seconds from the first (exact to the nanosecond); the first is
    kept in ``meta["time_origin"]``. Dotted day-first stamps (``27.11.2026 13:00:00,125``) are
    read as the same ISO 8601 time. One line naming the line (``rows``) of a cell that is not one."""
    import pandas as pd

    cells = s
    if len(s) and _DOTTED_TIME.match(str(s.iloc[0])):
        s = s.map(_as_iso)
    try:
        dt = pd.to_datetime(s, format="ISO8601", utc=True)
    except (ValueError, TypeError, OverflowError):
        dt = None
    if dt is None or dt.isna().any():
        for row, (text, cell) in enumerate(zip(s, cells, strict=True)):
            try:
                ok = not pd.isna(pd.to_datetime(text, format="ISO8601", utc=True))
            except (ValueError, TypeError, OverflowError):
                ok = False
            if not ok:
                what = "empty field" if text == "" else f"not an ISO 8601 time: {str(cell)[:40]!r}"
                raise DataError(
                    f"{what} (the column's first cell is a time stamp)",
                    path=str(p),
                    column=name,
                    row=row,
                    rows=rows,
                )
    ns = (dt - dt.iloc[0]).to_numpy().astype("timedelta64[ns]").astype(np.int64)
    # the first stamp as the file states it: in UTC where the file gives a zone, else without
    # one (as a naive Parquet time stamp is kept; the wear store takes a naive stamp as UTC)
    zoned = pd.to_datetime(s.iloc[0], format="ISO8601").tzinfo is not None
    first = dt.iloc[0] if zoned else dt.iloc[0].tz_convert(None)
    meta.setdefault("time_origin", {})[name] = first.isoformat()
    return ns / 1e9


def _check_row_widths(body: list[str], sep: str, n: int, p: Path, rows: DataRows) -> None:
    """A data row wider than the header is an error unless the extra fields are empty (a
    separator at the end of each row); one line naming the first such row (its line: ``rows``).
    ``body``: the header and the data rows below it."""
    for row, line in enumerate(body[1:]):
        fields = _fields(line, sep)
        if len(fields) > n and "".join(fields[n:]).strip():
            raise DataError(
                f"{len(fields)} fields where the header names {n} columns (a column without a"
                " name, or a separator inside a value?)",
                path=str(p),
                row=row,
                rows=rows,
            )


def _decimal_mark(sep: str, line: str) -> str:
    """The decimal mark of a CSV data line: ``,`` where the separator is not a comma and the
    line has one (the European layout, ``0,05;1,2``), else ``.``."""
    return "," if sep != "," and "," in line else "."


def _header_tokens(header: str, sep: str) -> list[str]:
    """Column names of a CSV header line; quoted names (``"t","theta_m"``, as pyarrow and
    Excel write them) are unquoted."""
    import csv

    if sep == r"\s+":
        fields = header.split()
    else:
        try:
            fields = next(csv.reader([header], delimiter=sep), [])
        except csv.Error:  # NUL bytes, stray quotes: the plain split (the reader names the problem)
            fields = header.split(sep)
    return [h.strip().strip('"').strip() for h in fields]


def _split(items: dict[str, Any]) -> tuple[dict[str, np.ndarray], dict[str, float]]:
    """Separate vectors (longest common length) from scalars."""
    cols: dict[str, np.ndarray] = {}
    scalars: dict[str, float] = {}
    for name, value in items.items():
        arr = np.asarray(value)
        if arr.dtype.kind not in "biuf":
            continue
        if arr.size == 1:
            scalars[name] = float(arr.reshape(-1)[0])
            continue
        col = _as_column(arr)
        if col is not None:
            cols[name] = col
    if cols:
        n = max(c.size for c in cols.values())
        cols = {k: v for k, v in cols.items() if v.size == n}
    return cols, scalars


def _parse_meta(text: Any) -> dict[str, Any]:
    if isinstance(text, bytes | np.bytes_):
        text = bytes(text).decode("utf-8", "replace")
    if isinstance(text, np.ndarray):
        text = "".join(str(x) for x in text.reshape(-1))
    try:
        meta = json.loads(str(text))
    except (ValueError, TypeError):
        return {}
    if not isinstance(meta, dict):
        return {}
    # what a reader found in the file itself (its units row, unit attributes), never what an
    # earlier load of another file wrote into the metadata: a trace written back in SI keeps
    # the source's stated units in its meta, which must not be checked against it again
    # nor who wrote the file (``generator``, read by drivelash.io.outputs.output_command)
    return {k: v for k, v in meta.items() if k not in ("column_units", "column_units_from", "generator")}


# --------------------------------------------------------------------------- readers
def _read_csv(p: Path, rows: DataRows = NO_LINES) -> RawTable:
    """The strict reader: every cell with Python ``float``; ``rows`` (the :class:`CsvLines` of
    the file's layout) names the line of a bad cell."""
    import pandas as pd

    raw = p.read_bytes()
    try:
        text = raw.decode("utf-8").removeprefix("\ufeff")  # Excel's "CSV UTF-8" starts with a BOM
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    meta: dict[str, Any] = {}
    lines = text.splitlines()
    skip = 0
    while skip < len(lines) and lines[skip].startswith("#"):
        if lines[skip].startswith("# drivelash.meta "):
            meta = _parse_meta(lines[skip][len("# drivelash.meta ") :])
        skip += 1
    body = lines[skip:]
    body_nonblank = [ln for ln in body if ln.strip()]
    if not body_nonblank:
        raise DataError("file is empty (no header and no data rows)", path=str(p))
    h = _header_index(body_nonblank[: PREAMBLE_MAX_LINES + 3])
    if h:
        _preamble_warning(meta, body_nonblank[:h])
        body = body[[i for i, ln in enumerate(body) if ln.strip()][h] :]
        body_nonblank = body_nonblank[h:]
    header = body_nonblank[0]
    sep = _sniff_sep(header)
    tokens = _header_tokens(header, sep)
    n_fields = len(tokens)
    # rows of separators only (``;;;;`` — a spreadsheet's formatted but empty rows) at the end
    # hold no value: blank lines
    while len(body_nonblank) > 1 and not "".join(_fields(body_nonblank[-1], sep)).strip():
        body_nonblank.pop()
        while body and not "".join(_fields(body[-1], sep)).strip():
            body.pop()
    dup = next((h for i, h in enumerate(tokens) if h and h in tokens[:i]), None)
    if dup is not None:
        raise DataError("duplicated column name in the header", path=str(p), column=dup)
    units = units_row(tokens, body_nonblank[1], sep) if len(body_nonblank) > 1 else None
    if units is not None:  # the file states its units: checked against the mapping when loaded
        meta["column_units"], meta["column_units_from"] = units, "units row"
        del body[next(i for i in range(1, len(body)) if body[i].strip())]
        del body_nonblank[1]
    if len(body_nonblank) < 2:
        raise DataError("no data rows below the header", path=str(p))
    # truncation: last data line with fewer fields than the header, file not ending in newline
    last = body_nonblank[-1]
    last_fields = len(last.split(sep)) if sep != r"\s+" else len(last.split())
    # A cut that leaves all fields of the last row (only digits lost) cannot be told from
    # a valid file without a final newline; a missing field can.
    if last_fields < n_fields and not text.endswith(("\n", "\r")):
        raise DataError(
            f"last row is incomplete ({last_fields} of {n_fields} fields, {len(last)} characters)"
            " and the file ends mid-line (truncated file?)",
            path=str(p),
            row=len(body_nonblank) - 2,
            rows=rows,
        )
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", pd.errors.ParserWarning)
            df = pd.read_csv(
                io.StringIO("\n".join(body)),
                sep=sep,
                engine="c" if sep != r"\s+" else "python",
                skipinitialspace=True,
                dtype=str,
                keep_default_na=False,
                index_col=False,  # never the first column as an index when rows are wider
            )
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError, csv_error()) as exc:
        # a row wider than the header below the first: named by its line of the file (pandas'
        # "Expected 4 fields in line 14" counts the lines it was given, from the header)
        _check_row_widths(body_nonblank, sep, n_fields, p, rows)
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise DataError(f"malformed CSV: {msg}", path=str(p)) from None
    if any(issubclass(w.category, pd.errors.ParserWarning) for w in caught):
        _check_row_widths(body_nonblank, sep, n_fields, p, rows)
    stamps = _timestamp_columns(tokens, body_nonblank[1], sep)
    if stamps:
        meta["timestamp_columns"] = stamps
    cols: dict[str, np.ndarray] = {}
    unread: dict[str, DataError] = {}
    seen: set[str] = set()
    # the header's own names, as the streamed reader has them (pandas renames an empty one
    # "Unnamed: k", and the streamed reader falls back to this one mid-file)
    names = tokens if len(tokens) == len(df.columns) else [str(c).strip() for c in df.columns]
    # Decimal commas (``0,05;1,2``, a European spreadsheet's export): a comma in a number of a
    # file that is not comma-separated; a point anywhere in such a file is then ambiguous. A
    # text column's commas ("ok, idle") say nothing about the numbers.
    comma = sep != "," and any(
        _comma_number(df[c]) for c, name in zip(df.columns, names, strict=True) if name not in stamps
    )
    for c, name in zip(df.columns, names, strict=True):
        if not name:  # no name in the header (a trailing separator): nothing can map it
            continue
        if name in seen:
            raise DataError("duplicated column name in the header", path=str(p), column=name)
        seen.add(name)
        s = df[c].fillna("").astype(str).str.strip()
        if name in stamps:
            cols[name] = _seconds_from_timestamps(s.str.strip('"'), p, name, meta, rows)
            continue
        obj = s.to_numpy(dtype=object)
        if comma:
            dotted = np.flatnonzero(s.str.contains(".", regex=False).to_numpy())
            if dotted.size:
                unread[name] = DataError(
                    f"decimal point in {str(obj[dotted[0]])[:40]!r} where the file's numbers have"
                    " decimal commas (mixed decimal marks; thousands separators are not read)",
                    path=str(p),
                    column=name,
                    row=int(dotted[0]),
                    rows=rows,
                )
                continue
        num = s.str.replace(",", ".", regex=False).to_numpy(dtype=object) if comma else obj
        try:
            vals = np.array(num, dtype=np.float64)  # Python float(): exact, accepts nan/inf
        except (ValueError, TypeError, OverflowError):
            for row, text in enumerate(obj):
                try:
                    float(num[row])
                except (ValueError, TypeError, OverflowError):
                    what = "empty field" if text == "" else f"not a number: {str(text)[:40]!r}"
                    if _SLASHED_DATE.match(str(text)):
                        what = (
                            f"a date with slashes ({str(text)[:40]!r}) is not read: month/day or"
                            " day/month is not known; write ISO 8601 (2026-11-27 13:00:00) or"
                            " DD.MM.YYYY, or a time column in seconds"
                        )
                    # raised when the column is used (A16: a CNC's status column, unmapped,
                    # is dropped as a Parquet file's string column is)
                    unread[name] = DataError(what, path=str(p), column=name, row=row, rows=rows)
                    break
            else:
                unread[name] = DataError("unparseable values", path=str(p), column=name)
            continue
        cols[name] = vals
    if not cols and unread:
        raise next(iter(unread.values()))
    if not cols or len(next(iter(cols.values()))) == 0:
        raise DataError("no data rows below the header", path=str(p))
    return RawTable(cols, {}, meta, str(p), "csv", rows, unread)


def _comma_number(col: Any) -> bool:
    """Whether a CSV column (strings) holds a number written with a decimal comma."""
    with_comma = col[col.str.contains(",", regex=False, na=False)]
    if with_comma.empty:
        return False
    try:
        float(str(with_comma.iloc[0]).strip().replace(",", "."))
    except ValueError:
        return False
    return True


def csv_error() -> type[Exception]:
    """The stdlib CSV error class (pandas' python engine can raise it)."""
    import csv

    return csv.Error


# --------------------------------------------------------------------------- chunked sources
#: Rows per chunk of the streaming readers (2**18 = 262 144 rows: 32 s at 8 kHz, 2 MiB per column).
DEFAULT_CHUNK_ROWS = 1 << 18

#: Read buffer of the Parquet reader (pages are read through it, not whole column chunks).
PARQUET_BUFFER_BYTES = 1 << 20
#: Block size of pyarrow's streaming CSV reader [bytes]. It reads ahead in the background a
#: number of blocks, so its memory scales with the block: 36 MiB blocks (the former rule,
#: 24 B × fields × chunk rows) peaked at ≈ 630 MiB RSS; with 4 MiB blocks ``estimate``
#: peaked at 408 / 489 MiB on a 2- / 8-minute 8 kHz file, with 1 MiB blocks at 369 / 377 MiB.
CSV_BLOCK_BYTES = 1 << 20
#: Peak memory of reading a file whole, per decoded float64 value (Arrow buffers, the
#: float64 copy, the mapped SI copy and the validation temporaries): measured ≈ 5 (see
#: docs/assumptions.md), rounded up.
WHOLE_READ_FACTOR = 8.0
#: The strict CSV reader (pandas with string cells, used to locate a bad cell): measured
#: 1.2–1.9 KB per sample of 6 columns ≈ 12× the file size.
STRICT_CSV_FACTOR = 12.0


class ColumnSource:
    """The numeric vector columns of a recording, read whole or in row chunks.

    Attributes
    ----------
    path : str
        The file.
    fmt : str
        Detected format.
    names : list of str
        Numeric vector columns (all of length ``n_rows``), in file order.
    n_rows : int
        Number of rows.
    scalars : dict
        Scalar values stored in the file (e.g. gains).
    meta : dict
        Provenance read from the file.
    rows : DataRows
        Where the data rows are in the file, for messages (:class:`CsvLines` of a text file).
    """

    rows: DataRows = NO_LINES

    @property
    def unread(self) -> dict[str, DataError]:
        """Text columns (name → the error naming their first bad cell); see :class:`RawTable`."""
        return {}

    def __init__(
        self, path: str, fmt: str, names: list[str], n_rows: int, scalars: dict[str, float], meta: dict
    ) -> None:
        self.path, self.fmt, self.names, self.n_rows = path, fmt, names, n_rows
        self.scalars, self.meta = scalars, meta

    def chunks(
        self, names: list[str], chunk_rows: int = DEFAULT_CHUNK_ROWS
    ) -> Iterator[dict[str, np.ndarray]]:
        """Consecutive row chunks of ``names`` as float64 arrays (the last one may be shorter)."""
        raise NotImplementedError

    def read(self, names: list[str] | None = None) -> dict[str, np.ndarray]:
        """``names`` (default: all) whole, after checking the memory budget."""
        names = list(self.names if names is None else names)
        self.check_whole(names)
        parts: dict[str, list[np.ndarray]] = {n: [] for n in names}
        for ch in self.chunks(names, max(1, self.n_rows)):
            for n in names:
                parts[n].append(ch[n])
        return {n: (p[0] if len(p) == 1 else np.concatenate(p)) for n, p in parts.items()}

    def check_whole(self, names: list[str], factor: float = WHOLE_READ_FACTOR) -> None:
        """Refuse reading ``names`` whole when it would exceed the memory budget."""
        from drivelash.io.budget import check_budget

        check_budget(
            float(self.n_rows) * max(1, len(names)) * 8.0 * factor,
            what=f"{self.path}: reading {self.n_rows} rows × {len(names)} columns whole",
            option="commands that stream (estimate, observe) read it in chunks",
        )

    def close(self) -> None:
        """Release the file."""

    def __enter__(self) -> ColumnSource:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


class ArraySource(ColumnSource):
    """Columns already in memory (a DataFrame, a MAT v5 file)."""

    def __init__(
        self,
        columns: dict[str, np.ndarray],
        path: str = "",
        fmt: str = "",
        scalars: dict[str, float] | None = None,
        meta: dict | None = None,
    ) -> None:
        n = len(next(iter(columns.values()))) if columns else 0
        super().__init__(path, fmt, list(columns), n, dict(scalars or {}), dict(meta or {}))
        self._cols = columns

    def chunks(
        self, names: list[str], chunk_rows: int = DEFAULT_CHUNK_ROWS
    ) -> Iterator[dict[str, np.ndarray]]:
        for a in range(0, self.n_rows, max(1, chunk_rows)):
            yield {n: self._cols[n][a : a + chunk_rows] for n in names}

    def read(self, names: list[str] | None = None) -> dict[str, np.ndarray]:
        return {n: self._cols[n] for n in (self.names if names is None else names)}


def _arrow_error(exc: Exception) -> str:
    return str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__


class ParquetSource(ColumnSource):
    """A Parquet file read with ``pyarrow.parquet.ParquetFile.iter_batches``."""

    def __init__(self, p: Path, data: bytes | None = None) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        tail = b""
        if data is not None:
            tail = data[-4:] if len(data) >= 8 else b""
        elif p.stat().st_size >= 8:
            with p.open("rb") as fh:
                fh.seek(-4, os.SEEK_END)
                tail = fh.read(4)
        if tail != b"PAR1":
            raise DataError("Parquet footer missing (truncated file?)", path=str(p))
        try:
            # pre_buffer=False: the pre-buffer cache keeps every row group read so far (the
            # reader grew ≈ 30 B/sample); a 1 MiB buffered stream reads page by page.
            # ``data``: the file's bytes, already read by the caller (hashed while read once)
            src = pa.BufferReader(data) if data is not None else p
            self._pf = pq.ParquetFile(src, pre_buffer=False, buffer_size=PARQUET_BUFFER_BYTES)
            schema = self._pf.schema_arrow
        except (pa.ArrowException, OSError, ValueError) as exc:
            raise DataError(
                f"unreadable Parquet file (truncated or corrupt?): {_arrow_error(exc)}", path=str(p)
            ) from None
        meta: dict[str, Any] = {}
        md = schema.metadata or {}
        if b"drivelash.meta" in md:
            meta = _parse_meta(md[b"drivelash.meta"])
        names = [
            str(f.name)
            for f in schema
            if pa.types.is_integer(f.type)
            or pa.types.is_floating(f.type)
            or pa.types.is_boolean(f.type)
            or pa.types.is_timestamp(f.type)
            or pa.types.is_duration(f.type)
        ]
        stated = {str(f.name): stated_unit_attr(dict(f.metadata or {})) for f in schema}
        units = {k: u for k, u in stated.items() if u is not None}
        if units:  # a field's "unit" metadata: checked against the mapping when loaded
            meta["column_units"] = units
            meta["column_units_from"] = "unit metadata"
        # time-stamp columns (pandas datetime64, a logger's clock): seconds from the first stamp,
        # as the CSV reader reads ISO 8601 stamps; the first is kept in meta["time_origin"]
        self._origin_ns: dict[str, int] = {}
        for f in schema:
            if pa.types.is_duration(f.type):  # elapsed time (pandas timedelta64): seconds as they are
                self._origin_ns[str(f.name)] = 0
            if pa.types.is_timestamp(f.type) and int(self._pf.metadata.num_rows) > 0:
                first = next(self._pf.iter_batches(batch_size=1, columns=[f.name])).column(0)
                if first.null_count:
                    raise DataError("empty time stamp", path=str(p), column=str(f.name), row=0)
                self._origin_ns[str(f.name)] = int(first.cast(pa.timestamp("ns", f.type.tz))[0].value)
                meta.setdefault("timestamp_columns", []).append(str(f.name))
                meta.setdefault("time_origin", {})[str(f.name)] = first[0].as_py().isoformat()
        super().__init__(str(p), "parquet", names, int(self._pf.metadata.num_rows), {}, meta)

    def _column(self, col: Any, name: str) -> np.ndarray:
        """One Arrow column as float64 [file units]; time stamps as seconds from the first."""
        import pyarrow as pa

        origin = self._origin_ns.get(name)
        if origin is None:
            # float64 columns stay the (read-only) Arrow buffers: no copy (≈ 40 % of the read)
            return col.to_numpy(zero_copy_only=False).astype(np.float64, copy=False)
        if pa.types.is_duration(col.type):
            ns = col.cast(pa.duration("ns")).cast(pa.int64())
        else:
            ns = col.cast(pa.timestamp("ns", col.type.tz)).cast(pa.int64())
        # int64, or float64 with NaN where a stamp is missing
        return stamps_to_seconds(ns.to_numpy(zero_copy_only=False), origin)

    def chunks(
        self, names: list[str], chunk_rows: int = DEFAULT_CHUNK_ROWS
    ) -> Iterator[dict[str, np.ndarray]]:
        import pyarrow as pa

        try:
            for batch in self._pf.iter_batches(batch_size=max(1, chunk_rows), columns=list(names)):
                yield {n: self._column(batch.column(i), n) for i, n in enumerate(names)}
        except (pa.ArrowException, OSError, ValueError) as exc:
            raise DataError(
                f"unreadable Parquet file (truncated or corrupt?): {_arrow_error(exc)}", path=self.path
            ) from None

    def close(self) -> None:
        self._pf.close()


@dataclass
class _CsvLayout:
    """Where the data of a CSV file start and how its rows are split."""

    header_end: int  # byte offset just after the header line (or its units row)
    tokens: list[str]
    sep: str
    meta: dict[str, Any]
    decimal: str = "."  # the first data row's decimal mark (``,`` in ``0,05;1,2``)
    stamps: list[str] = field(default_factory=list)  # columns of ISO 8601 time stamps
    first_line: int = 2  # 1-based line of the file that starts at ``header_end``


def _csv_layout(p: Path) -> _CsvLayout:
    """Comment lines (``#``, incl. ``# drivelash.meta``), header, separator; truncation check."""
    size = p.stat().st_size
    meta: dict[str, Any] = {}
    offset = 0
    n_line = 0  # 1-based number of the line just read
    # the first non-blank lines, the offsets after them and their line numbers
    cands: list[tuple[str, int, int]] = []
    with p.open("rb") as fh:
        while len(cands) < PREAMBLE_MAX_LINES + 3:
            raw = fh.readline()
            if not raw:
                break
            offset += len(raw)
            n_line += 1
            line = raw.decode("utf-8", "replace").rstrip("\r\n")
            if offset == len(raw):  # first line: a byte-order mark (Excel's "CSV UTF-8") is no text
                line = line.removeprefix("\ufeff")
            if not cands and line.startswith("#"):
                if line.startswith("# drivelash.meta "):
                    meta = _parse_meta(line[len("# drivelash.meta ") :])
                continue
            if line.strip():  # as many lines as the whole-file reader looks at (_header_index)
                cands.append((line, offset, n_line))
        if not cands:
            raise DataError("file is empty (no header and no data rows)", path=str(p))
        h = _header_index([c[0] for c in cands])
        if h:
            _preamble_warning(meta, [c[0] for c in cands[:h]])
        header, offset, n_line = cands[h]
        sep = _sniff_sep(header)
        below = cands[h + 1][0] if h + 1 < len(cands) else ""
        units = units_row(_header_tokens(header, sep), below, sep) if below else None
        if units is not None:  # the data start below the units row
            meta["column_units"], meta["column_units_from"] = units, "units row"
            _, offset, n_line = cands[h + 1]
            h += 1
        first = cands[h + 1][0] if h + 1 < len(cands) else ""
        fh.seek(max(offset, size - 65536))
        tail = fh.read().decode("utf-8", "replace")
    tokens = _header_tokens(header, sep)
    dup = next((h for i, h in enumerate(tokens) if h and h in tokens[:i]), None)
    if dup is not None:
        raise DataError("duplicated column name in the header", path=str(p), column=dup)
    lines = [ln for ln in tail.splitlines() if ln.strip()]
    if lines and not tail.endswith(("\n", "\r")) and offset < size:
        last = lines[-1]
        n_last = len(last.split(sep)) if sep != r"\s+" else len(last.split())
        if n_last < len(tokens):
            rows = CsvLines(p, offset, n_line + 1)
            raise DataError(
                f"last row is incomplete ({n_last} of {len(tokens)} fields, {len(last)} characters)"
                " and the file ends mid-line (truncated file?)",
                path=str(p),
                row=rows.count() - 1,
                rows=rows,
            )
    return _CsvLayout(
        offset,
        tokens,
        sep,
        meta,
        _decimal_mark(sep, first),
        _timestamp_columns(tokens, first, sep),
        n_line + 1,
    )


class CsvLines(DataRows):
    """The lines of a text file's data rows: the one data-row → file-line map of both CSV
    readers (pyarrow's streaming reader and the strict reader, :func:`_read_csv`).

    Data row ``r`` (0-based) is the ``r + 1``-th non-blank line below the header (or below its
    units row): the readers skip blank and whitespace-only lines (and a preamble, comment lines
    and the header above it); any other line below the header is a row (a ``#`` line there is
    read as one, and its error names its line). Lines are counted as an editor numbers them:
    1-based, ending at ``\n`` (``\r\n`` included). A message is rare, so nothing is kept
    while reading: each question reads the file from the header up to the row asked for.

    Parameters
    ----------
    path : Path
        The file.
    start : int
        Byte offset of the first line below the header (or its units row).
    first_line : int
        1-based number of that line.
    """

    def __init__(self, path: Path, start: int, first_line: int) -> None:
        self._path, self._start, self._first = Path(path), int(start), int(first_line)

    def _rows(self) -> Iterator[int]:
        """The 1-based line of each data row, in order."""
        with self._path.open("rb") as fh:
            fh.seek(self._start)
            for k, raw in enumerate(fh):
                if raw.strip():
                    yield self._first + k

    def line(self, row: int) -> int | None:
        if row < 0:
            return None
        for r, line in enumerate(self._rows()):
            if r == row:
                return line
        return None

    def count(self) -> int:
        """Number of data rows (non-blank lines below the header)."""
        return sum(1 for _ in self._rows())


class CsvSource(ColumnSource):
    """A CSV file read with pyarrow's streaming reader (correctly rounded, like Python ``float``).

    Anything pyarrow refuses (an empty field, ``1_000``, Latin-1 text, …) is re-read by the
    strict reader (:func:`_read_csv`, Python ``float`` per cell) to name the bad cell, or to
    read it when Python accepts it; whitespace-separated files are read whole by the strict
    reader (within the memory budget).
    """

    def __init__(self, p: Path) -> None:
        self._p = p
        self._layout = _csv_layout(p)
        self._strict: RawTable | None = None
        lay = self._layout
        self.rows = CsvLines(p, lay.header_end, lay.first_line)
        if lay.sep == r"\s+" or lay.stamps:  # pyarrow splits on one character / reads no time
            # stamps as float: the strict reader (whole file, within the memory budget)
            n = len(next(iter(self._strict_table().columns.values())))
        else:
            n = self._count_arrow()
        if n == 0:
            raise DataError("no data rows below the header", path=str(p))
        if self._strict is not None:  # a text column stays a name: using it raises its error
            st = self._strict
            names = [*st.columns, *(u for u in st.unread if u not in st.columns)]
        else:
            names = [t for t in lay.tokens if t]
        meta = self._strict.meta if self._strict is not None else lay.meta
        super().__init__(str(p), "csv", names, n, {}, meta)

    @property
    def unread(self) -> dict[str, DataError]:
        """Text columns the strict reader found (none before it ran); see :class:`RawTable`."""
        return self._strict.unread if self._strict is not None else {}

    def read(self, names: list[str] | None = None) -> dict[str, np.ndarray]:
        """``names`` whole; by default every column but the text ones (:attr:`unread`)."""
        if names is not None:
            return super().read(names)
        try:
            return super().read([n for n in self.names if n not in self.unread])
        except DataError as exc:
            if exc.column is None or exc.column not in self.unread:
                raise
        # pyarrow met a text column: the strict reader now knows them all
        return super().read([n for n in self.names if n not in self.unread])

    def _strict_table(self) -> RawTable:
        if self._strict is None:
            from drivelash.io.budget import check_budget

            lay = self._layout
            why = (
                f"time stamps in column {lay.stamps[0]!r}"
                if lay.stamps
                else "whitespace-separated"
                if lay.sep == r"\s+"
                else "pyarrow refused the file"
            )
            check_budget(
                self._p.stat().st_size * STRICT_CSV_FACTOR,
                what=f"{self._p}: the CSV reader's strict pass ({why})",
                option="convert the file to Parquet, fix it (pyarrow's error names the column)"
                " or raise the budget",
            )
            self._strict = _read_csv(self._p, self.rows)
        return self._strict

    def _check_read(self, names: list[str]) -> None:
        """Raise the error of the first text column among ``names`` (its first bad cell)."""
        for n in names:
            if n in self.unread:
                raise self.unread[n]

    def _reader(self, names: list[str], block: int) -> Any:
        import pyarrow as pa
        import pyarrow.csv as pcsv

        fh = self._p.open("rb")
        fh.seek(self._layout.header_end)
        try:
            return fh, pcsv.open_csv(
                fh,
                read_options=pcsv.ReadOptions(column_names=self._layout.tokens, block_size=block),
                parse_options=pcsv.ParseOptions(delimiter=self._layout.sep),
                convert_options=pcsv.ConvertOptions(
                    column_types={n: pa.float64() for n in self._layout.tokens},
                    decimal_point=self._layout.decimal,
                    include_columns=names,
                    strings_can_be_null=False,
                    quoted_strings_can_be_null=False,
                    null_values=[],
                ),
            )
        except BaseException:
            fh.close()
            raise

    def _count_arrow(self) -> int:
        """Row count from a pass over the first column (pyarrow); the strict reader if it refuses."""
        import pyarrow as pa

        try:
            n = 0
            fh, rd = self._reader(self._layout.tokens[:1], CSV_BLOCK_BYTES)
            with fh:
                for b in rd:
                    n += b.num_rows
            return n
        except (pa.ArrowException, UnicodeDecodeError, ValueError):
            return len(next(iter(self._strict_table().columns.values())))

    def chunks(
        self, names: list[str], chunk_rows: int = DEFAULT_CHUNK_ROWS
    ) -> Iterator[dict[str, np.ndarray]]:
        if self._strict is not None:
            self._check_read(names)
            yield from ArraySource(self._strict.columns).chunks(names, chunk_rows)
            return
        import pyarrow as pa

        block = CSV_BLOCK_BYTES
        pending: dict[str, list[np.ndarray]] = {n: [] for n in names}
        have = 0
        done = 0  # rows already yielded
        try:
            fh, rd = self._reader(names, block)
            with fh:
                for b in rd:
                    for n in names:
                        pending[n].append(b.column(n).to_numpy(zero_copy_only=False).astype(np.float64))
                    have += b.num_rows
                    while have >= chunk_rows:
                        out, pending, have = _take(pending, chunk_rows, have)
                        done += chunk_rows
                        yield out
        except (pa.ArrowException, UnicodeDecodeError, ValueError) as exc:
            strict = self._strict_table()  # names the bad cell (DataError), or reads what Python accepts
            del exc
            self._check_read(names)
            # pyarrow may refuse a cell Python accepts (``1_000``) after chunks went out: the strict
            # reader re-read the file from its first row, so go on from the first row not yet yielded
            rest = {n: strict.columns[n][done:] for n in names}
            yield from ArraySource(rest).chunks(names, chunk_rows)
            return
        if have:
            yield {n: np.concatenate(v) if len(v) > 1 else v[0] for n, v in pending.items()}


def _take(
    pending: dict[str, list[np.ndarray]], k: int, have: int
) -> tuple[dict[str, np.ndarray], dict[str, list[np.ndarray]], int]:
    """The first ``k`` rows of ``pending`` and the rest."""
    out, rest = {}, {}
    for n, parts in pending.items():
        a = np.concatenate(parts) if len(parts) > 1 else parts[0]
        out[n], rest[n] = a[:k], ([a[k:]] if a.size > k else [])
    return out, rest, have - k


def _h5_open(p: Path):  # noqa: ANN202
    import h5py

    try:
        return h5py.File(p, "r")
    except OSError as exc:
        msg = str(exc).splitlines()[0] if str(exc) else "unreadable"
        hint = "truncated file?" if "truncated" in msg.lower() or "eof" in msg.lower() else "corrupt file?"
        raise DataError(f"unreadable HDF5 file ({hint}): {msg}", path=str(p)) from None


@dataclass
class _H5Column:
    """Where one column lives in an HDF5 file and how to slice it."""

    dataset: str
    how: str  # "1d", "row" (1×N), "col" (N×1), "field", "block-col" (values[:, j]), "block-row" (values[j])
    length: int
    field: str | None = None
    j: int | None = None

    def read(self, ds: Any, a: int, b: int) -> np.ndarray:
        if self.how == "1d":
            v = ds[a:b]
        elif self.how == "row":
            v = ds[0, a:b]
        elif self.how == "col":
            v = ds[a:b, 0]
        elif self.how == "field":
            v = ds[a:b][self.field]
            if self.j is not None:
                v = v.reshape(v.shape[0], -1)[:, self.j]
        elif self.how == "block-col":
            v = ds[a:b, self.j]
        else:
            v = ds[self.j, a:b]
        return np.asarray(v, dtype=np.float64).reshape(-1)


class Hdf5Source(ColumnSource):
    """HDF5 (plain datasets, pandas fixed/table format) and MATLAB v7.3, sliced with h5py.

    Any length is read (in chunks when streaming); nothing is skipped for its size.
    """

    def __init__(self, p: Path, fmt: str = "hdf5") -> None:
        import h5py

        self._f = _h5_open(p)
        f = self._f
        meta: dict[str, Any] = {}
        order: list[str] = []
        scalars: dict[str, float] = {}
        found: dict[str, _H5Column] = {}
        units: dict[str, str] = {}  # a dataset's "unit"/"units" attribute
        try:
            if _META_KEY in f.attrs:
                meta = _parse_meta(f.attrs[_META_KEY])
            if _ORDER_KEY in f.attrs:
                got = json.loads(str(f.attrs[_ORDER_KEY]))
                order = [str(x) for x in got] if isinstance(got, list) else []
            for k, v in f.attrs.items():
                a = np.asarray(v)
                if k not in (_META_KEY, _ORDER_KEY) and a.dtype.kind in "biuf" and a.size == 1:
                    scalars[str(k)] = float(a.reshape(-1)[0])

            def visit(name: str, obj: Any) -> None:
                if isinstance(obj, h5py.Group) and "block0_items" in obj and "block0_values" in obj:
                    self._pandas_fixed(name, obj, found)
                    return
                if not isinstance(obj, h5py.Dataset):
                    return
                if "/block" in f"/{name}" or name.endswith(("axis0", "axis1")) or "#refs#" in name:
                    return
                dt = obj.dtype
                if dt.names:  # compound table (e.g. pandas 'table' format)
                    if obj.ndim != 1:
                        return
                    for fld in dt.names:
                        sub = dt.fields[fld][0]
                        if sub.base.kind not in "biuf":
                            continue
                        if sub.shape:
                            for j in range(int(np.prod(sub.shape))):
                                found[f"{fld}_{j}"] = _H5Column(name, "field", obj.shape[0], fld, j)
                        else:
                            key = fld if fld != "index" else f"{name}/index"
                            found[key] = _H5Column(name, "field", obj.shape[0], fld)
                    return
                if dt.kind not in "biuf":
                    return
                if obj.size == 1:
                    scalars[name] = float(np.asarray(obj[()]).reshape(-1)[0])
                    return
                elif obj.ndim == 1:
                    found[name] = _H5Column(name, "1d", obj.shape[0])
                elif obj.ndim == 2 and obj.shape[0] == 1:
                    found[name] = _H5Column(name, "row", obj.shape[1])
                elif obj.ndim == 2 and obj.shape[1] == 1:
                    found[name] = _H5Column(name, "col", obj.shape[0])
                u = stated_unit_attr(dict(obj.attrs))
                if u is not None and name in found:
                    units[name] = u

            f.visititems(visit)
        except (OSError, KeyError, ValueError, RuntimeError) as exc:
            self._f.close()
            msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise DataError(f"unreadable HDF5 content (truncated or corrupt?): {msg}", path=str(p)) from None
        n = max((c.length for c in found.values()), default=0)
        found = {k: c for k, c in found.items() if c.length == n}
        base = [k.rsplit("/", 1)[-1] for k in found]
        if len(set(base)) == len(base):  # shorter names when unambiguous: 'trace/theta_m' → 'theta_m'
            units = {b: units[k] for b, k in zip(base, found, strict=True) if k in units}
            found = {b: c for b, c in zip(base, found.values(), strict=True)}
        if units:  # checked against the mapping when loaded, as a CSV units row
            meta["column_units"] = units
            meta["column_units_from"] = "unit attribute"
        if order:  # column order as written by drivelash
            found = {k: found[k] for k in order if k in found} | {
                k: v for k, v in found.items() if k not in order
            }
        self._cols = found
        super().__init__(str(p), fmt, list(found), n, scalars, meta)

    @staticmethod
    def _pandas_fixed(name: str, group: Any, found: dict[str, _H5Column]) -> None:
        """A pandas ``HDFStore`` fixed-format frame (``blockN_items``, ``blockN_values``)."""
        i = 0
        while f"block{i}_items" in group and f"block{i}_values" in group:
            items = [x.decode() if isinstance(x, bytes) else str(x) for x in group[f"block{i}_items"][()]]
            ds = group[f"block{i}_values"]
            if ds.ndim == 2 and ds.dtype.kind in "biuf":
                transposed = bool(ds.attrs.get("transposed", False))
                path = f"{name}/block{i}_values"
                by_col = transposed or (ds.shape[1] == len(items) and ds.shape[0] != len(items))
                for j, item in enumerate(items):
                    if by_col:
                        found[item] = _H5Column(path, "block-col", ds.shape[0], j=j)
                    else:
                        found[item] = _H5Column(path, "block-row", ds.shape[1], j=j)
            i += 1

    def chunks(
        self, names: list[str], chunk_rows: int = DEFAULT_CHUNK_ROWS
    ) -> Iterator[dict[str, np.ndarray]]:
        step = max(1, chunk_rows)
        try:
            for a in range(0, self.n_rows, step):
                b = min(self.n_rows, a + step)
                yield {n: self._cols[n].read(self._f[self._cols[n].dataset], a, b) for n in names}
        except (OSError, KeyError, RuntimeError) as exc:
            msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise DataError(
                f"unreadable HDF5 content (truncated or corrupt?): {msg}", path=self.path
            ) from None

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self._f.close()


def _mat5_source(p: Path) -> ArraySource:
    """A MATLAB v5 file: cannot be streamed (compressed variables); read whole within the budget."""
    import scipy.io

    from drivelash.io.budget import check_budget

    try:
        info = scipy.io.whosmat(p)
    except Exception:  # noqa: BLE001 - the full read below names the problem
        info = []
    n_values = sum(int(np.prod(shape)) for _, shape, _ in info)
    check_budget(
        n_values * 8.0 * WHOLE_READ_FACTOR,
        what=f"{p}: reading a MATLAB v5 file ({n_values} values) whole",
        option="save it as MATLAB v7.3 (HDF5), Parquet or CSV, which are read in chunks",
    )
    try:
        data = scipy.io.loadmat(p, squeeze_me=False, mat_dtype=False)
    except (ValueError, OSError, TypeError, NotImplementedError, EOFError, IndexError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise DataError(f"unreadable MATLAB file (truncated or corrupt?): {msg}", path=str(p)) from None
    except Exception as exc:  # scipy raises assorted low-level errors on corrupt streams
        if type(exc).__module__.startswith(("scipy", "zlib")) or "zlib" in type(exc).__name__.lower():
            raise DataError(
                f"unreadable MATLAB file (truncated or corrupt?): {type(exc).__name__}", path=str(p)
            ) from None
        raise
    meta = _parse_meta(data.get(_META_KEY, "")) if _META_KEY in data else {}
    items = {k: v for k, v in data.items() if not k.startswith("__") and k != _META_KEY}
    cols, scalars = _split(_flatten_mat(items))
    return ArraySource(cols, str(p), "mat", scalars, meta)


def open_source(path: str | Path, data: bytes | None = None) -> ColumnSource:
    """Open a recording for reading (whole or in chunks); nothing but its layout is read yet.

    ``data``: the file's bytes when the caller has already read them (a Parquet file is then
    decoded from memory instead of being read again; other formats read ``path``).

    Raises
    ------
    DataError
        Missing, empty, truncated or wrong-type file; no numeric columns; no rows.
    """
    p = Path(path)
    kind = detect_format(p)
    if kind == "csv":
        src: ColumnSource = CsvSource(p)
    elif kind == "parquet":
        src = ParquetSource(p, data)
    elif kind in ("hdf5", "mat73"):
        src = Hdf5Source(p, kind)
    else:
        src = _mat5_source(p)
    if not src.names:
        src.close()
        raise DataError("no numeric columns found", path=str(p))
    if src.n_rows == 0:
        src.close()
        raise DataError("file has no data rows", path=str(p))
    return src


def _flatten_mat(items: dict[str, Any], prefix: str = "", depth: int = 0) -> dict[str, Any]:
    """MATLAB structs and matrices as named vectors, MATLAB-style.

    A struct field becomes ``struct.field``; a numeric matrix of shape (k, n) with k < n
    becomes k rows ``name(i,:)``, one of shape (n, k) with k < n becomes k columns
    ``name(:,j)`` (1-based, as in MATLAB) — e.g. ``rec.act_pos_mot_deg(2,:)`` is axis 2 of a
    robot recording. The elements of short vectors (≤ 16) are also scalars ``name(i)``
    (e.g. a gear ratio ``para.u(2)``). Nesting is followed two levels deep.
    """
    out: dict[str, Any] = {}
    for name, value in items.items():
        full = prefix + name
        arr = np.asarray(value)
        if arr.dtype.names and depth < 2 and arr.size == 1:
            rec = arr.reshape(-1)[0]
            out.update(_flatten_mat({f: rec[f] for f in arr.dtype.names}, full + ".", depth + 1))
            continue
        if arr.dtype.kind not in "biuf":
            continue
        if arr.ndim == 2 and min(arr.shape) > 1:
            k, n = arr.shape
            if k < n:
                out.update({f"{full}({i + 1},:)": arr[i] for i in range(k)})
            elif n < k:
                out.update({f"{full}(:,{j + 1})": arr[:, j] for j in range(n)})
            continue
        out[full] = arr
        if 1 < arr.size <= 16:
            out.update({f"{full}({i + 1})": v for i, v in enumerate(arr.reshape(-1))})
    return out


def read_raw(path: str | Path, data: bytes | None = None) -> RawTable:
    """Read the source columns of a recording whole (no mapping, no validation).

    Parameters
    ----------
    path : str or Path
        ``.csv``/``.txt``, ``.parquet``/``.pq``, ``.h5``/``.hdf5``, ``.mat`` (v5 or v7.3).
    data : bytes, optional
        The content of ``path`` when the caller has already read it (:func:`open_source`).

    Raises
    ------
    DataError
        Missing, empty, truncated or wrong-type file; malformed content.
    ResourceError
        Reading it whole would exceed the memory budget (:mod:`drivelash.io.budget`).
    """
    with open_source(path, data) as src:
        cols = src.read()
        unread = dict(src.unread)
        return RawTable(cols, dict(src.scalars), dict(src.meta), src.path, src.fmt, src.rows, unread)


# --------------------------------------------------------------------------- writers
def _write_hdf5(trace: Trace, path: Path, userblock: int = 0) -> None:
    import h5py

    with h5py.File(path, "w", userblock_size=userblock) if userblock else h5py.File(path, "w") as f:
        for name, arr in trace.columns.items():
            if userblock:  # MATLAB stores a column vector N×1 as a 1×N HDF5 dataset
                ds = f.create_dataset(name, data=arr.reshape(1, -1))
                ds.attrs["MATLAB_class"] = np.bytes_("double")
            else:
                f.create_dataset(name, data=arr)
        f.attrs[_META_KEY] = meta_json(trace.meta)
        f.attrs[_ORDER_KEY] = json.dumps(trace.names)
    if userblock:
        _mat73_header(path, userblock)


def _mat73_header(path: Path, userblock: int = 512) -> None:
    """Write the MATLAB v7.3 header into the HDF5 user block of ``path``."""
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created by: drivelash HDF5 schema 1.00 ."
    block = header.ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02" + b"IM"
    with path.open("r+b") as fh:
        fh.write(block.ljust(userblock, b"\x00")[:userblock])


class TraceWriter:
    """Write a recording of known length chunk by chunk (bounded memory).

    The files equal :func:`write_trace`'s: CSV byte for byte (meta line, header, ``%.17g``);
    Parquet with the same schema and metadata (row groups per chunk); HDF5 / MAT v7.3 with
    datasets of the final length written by slices. MAT v5 has no appendable layout: its
    columns are gathered and written at :meth:`close`, within the memory budget.

    Parameters
    ----------
    path : str or Path
        The output (a staging path of :class:`drivelash.io.outputs.Outputs`).
    names : list of str
        Columns, in order.
    n : int
        Total rows.
    meta : dict
        The recording's ``meta``.
    fmt : str, optional
        As for :func:`write_trace`.
    """

    def __init__(self, path: str | Path, names: list[str], n: int, meta: dict[str, Any],
                 fmt: str | None = None) -> None:  # fmt: skip
        from drivelash.io.outputs import final_suffix, signature

        self.path, self.names, self.n = Path(path), list(names), int(n)
        self.meta = {**meta, "generator": signature(self.path)}  # as write_trace
        fmt = fmt or EXTENSIONS.get(final_suffix(self.path))
        if fmt not in FORMATS:
            raise DataError(
                f"unsupported extension '{final_suffix(self.path)}' (use .csv, .parquet, .h5, .mat)",
                path=str(self.path),
            )
        self.fmt = fmt
        self.row = 0
        self._fh: Any = None
        self._buf: dict[str, list[np.ndarray]] = {c: [] for c in self.names}
        if fmt == "csv":
            self._fh = self.path.open("w", encoding="utf-8", newline="\n")
            self._fh.write("# drivelash.meta " + meta_json(self.meta) + "\n" + ",".join(self.names) + "\n")
        elif fmt == "parquet":
            import pyarrow as pa
            import pyarrow.parquet as pq

            schema = pa.schema([(c, pa.float64()) for c in self.names])
            schema = schema.with_metadata({b"drivelash.meta": meta_json(self.meta).encode()})
            self._schema = schema
            self._fh = pq.ParquetWriter(self.path, schema)
        elif fmt in ("hdf5", "mat73"):
            import h5py

            ub = 512 if fmt == "mat73" else 0
            f = h5py.File(self.path, "w", userblock_size=ub) if ub else h5py.File(self.path, "w")
            self._fh = f
            for c in self.names:
                if ub:
                    ds = f.create_dataset(c, shape=(1, self.n), dtype="f8")
                    ds.attrs["MATLAB_class"] = np.bytes_("double")
                else:
                    f.create_dataset(c, shape=(self.n,), dtype="f8")
            f.attrs[_META_KEY] = meta_json(self.meta)
            f.attrs[_ORDER_KEY] = json.dumps(self.names)
        else:
            from drivelash.io.budget import check_budget

            check_budget(
                16.0 * self.n * len(self.names),
                what=f"{self.path}: a MAT v5 file of {self.n} rows is written whole",
                option="write .parquet, .csv or .h5 instead",
            )

    def write(self, cols: dict[str, np.ndarray]) -> None:
        """Append rows (every column, equal lengths)."""
        m = len(cols[self.names[0]])
        if self.fmt == "csv":
            np.savetxt(self._fh, np.column_stack([cols[c] for c in self.names]), delimiter=",", fmt="%.17g")
        elif self.fmt == "parquet":
            import pyarrow as pa

            self._fh.write_table(pa.table({c: cols[c] for c in self.names}, schema=self._schema))
        elif self.fmt == "hdf5":
            for c in self.names:
                self._fh[c][self.row : self.row + m] = cols[c]
        elif self.fmt == "mat73":
            for c in self.names:
                self._fh[c][0, self.row : self.row + m] = cols[c]
        else:
            for c in self.names:
                self._buf[c].append(np.array(cols[c], dtype=np.float64))
        self.row += m

    def close(self) -> None:
        """Finish the file (idempotent); every row must have been written."""
        if self.fmt == "mat":
            if self._buf is not None:
                cols = {c: np.concatenate(v) if v else np.empty(0) for c, v in self._buf.items()}
                self._buf = None  # type: ignore[assignment]
                _write(Trace(cols, self.meta), self.path, "mat")
            return
        if self._fh is None:
            return
        fh, self._fh = self._fh, None
        fh.close()
        if self.fmt == "mat73":
            _mat73_header(self.path)

    def __enter__(self) -> TraceWriter:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def write_trace(trace: Trace, path: str | Path, fmt: str | None = None) -> Path:
    """Write ``trace`` to ``path``.

    Parameters
    ----------
    trace : Trace
        The recording (SI columns).
    path : str or Path
        Output file: a staging path from :meth:`drivelash.io.outputs.Outputs.staging`
        (written in place; the command renames it with the rest of its outputs) or any
        other path (written under a temporary name and renamed, so a failed write leaves
        nothing behind).
    fmt : {"csv", "parquet", "hdf5", "mat", "mat73"}, optional
        Format; by the (final) extension when omitted (``.mat`` → v5). ``"mat73"`` writes
        an HDF5-based MATLAB v7.3 file.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    DataError
        An unknown ``fmt`` or extension.
    """
    from drivelash.io.outputs import final_suffix, signature, write_target

    p = Path(path)
    # the command that wrote it (for a command's staging path), so that another command
    # does not replace it without --force (drivelash.io.outputs.output_command)
    trace = Trace(trace.columns, meta={**trace.meta, "generator": signature(p)})
    if fmt is None:
        fmt = EXTENSIONS.get(final_suffix(p))
        if fmt is None:
            raise DataError(
                f"unsupported extension '{final_suffix(p)}' (use .csv, .parquet, .h5, .mat)", path=str(p)
            )
    if fmt not in FORMATS:
        raise DataError(f"unknown format '{fmt}' (one of {', '.join(FORMATS)})", path=str(p))
    with write_target(p) as w:
        _write(trace, w, fmt)
    return p


def _write(trace: Trace, path: Path, fmt: str) -> None:
    if fmt == "csv":
        trace.to_csv(path)
    elif fmt == "parquet":
        trace.to_parquet(path)
    elif fmt == "hdf5":
        _write_hdf5(trace, path)
    elif fmt == "mat73":
        _write_hdf5(trace, path, userblock=512)
    else:
        import scipy.io

        data: dict[str, Any] = {k: v.reshape(-1, 1) for k, v in trace.columns.items()}
        data[_META_KEY] = meta_json(trace.meta)
        with path.open("wb") as fh:
            scipy.io.savemat(fh, data, do_compression=True)
