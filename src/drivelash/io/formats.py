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

import io
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import DataError
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
    """

    columns: dict[str, np.ndarray]
    scalars: dict[str, float] = field(default_factory=dict)
    meta: dict[str, Any] = field(default_factory=dict)
    path: str = ""
    fmt: str = ""


# --------------------------------------------------------------------------- sniffing
def _sniff(head: bytes) -> str:
    """Format suggested by the first bytes of a file: a name from FORMATS or 'text'/'binary'."""
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
    if b"\x00" in head:
        return "binary"
    try:
        head.decode("utf-8")
    except UnicodeDecodeError as exc:
        if exc.start < len(head) - 4:  # not just a multi-byte char cut at the end
            return "binary"
    return "text"


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
        raise DataError(
            f"unsupported file type '{ext or '(no extension)'}' (supported: .csv, .parquet, .h5/.hdf5, .mat)",
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
        "parquet": "Parquet",
        "hdf5": "HDF5",
        "mat": "MATLAB v5",
        "mat73": "MATLAB v7.3",
    }
    if expected == "csv":
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
    return meta if isinstance(meta, dict) else {}


# --------------------------------------------------------------------------- readers
def _read_csv(p: Path) -> RawTable:
    import pandas as pd

    raw = p.read_bytes()
    try:
        text = raw.decode("utf-8")
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
    header = body_nonblank[0]
    sep = ","
    if "," not in header:
        for cand in (";", "\t"):
            if cand in header:
                sep = cand
                break
        else:
            if " " in header.strip():
                sep = r"\s+"
    tokens = [h.strip() for h in (header.split(sep) if sep != r"\s+" else header.split())]
    n_fields = len(tokens)
    dup = next((h for i, h in enumerate(tokens) if h in tokens[:i]), None)
    if dup is not None:
        raise DataError("duplicated column name in the header", path=str(p), column=dup)
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
        )
    try:
        df = pd.read_csv(
            io.StringIO("\n".join(body)),
            sep=sep,
            engine="c" if sep != r"\s+" else "python",
            skipinitialspace=True,
            dtype=str,
            keep_default_na=False,
        )
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError, csv_error()) as exc:
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise DataError(f"malformed CSV: {msg}", path=str(p)) from None
    cols: dict[str, np.ndarray] = {}
    seen: set[str] = set()
    for c in df.columns:
        name = str(c).strip()
        if name in seen:
            raise DataError("duplicated column name in the header", path=str(p), column=name)
        seen.add(name)
        s = df[c].fillna("").astype(str).str.strip()
        obj = s.to_numpy(dtype=object)
        try:
            vals = np.array(obj, dtype=np.float64)  # Python float(): exact, accepts nan/inf
        except (ValueError, TypeError, OverflowError):
            for row, text in enumerate(obj):
                try:
                    float(text)
                except (ValueError, TypeError, OverflowError):
                    what = "empty field" if text == "" else f"not a number: {str(text)[:40]!r}"
                    raise DataError(what, path=str(p), column=name, row=row) from None
            raise DataError("unparseable values", path=str(p), column=name) from None
        cols[name] = vals
    if not cols or len(next(iter(cols.values()))) == 0:
        raise DataError("no data rows below the header", path=str(p))
    return RawTable(cols, {}, meta, str(p), "csv")


def csv_error() -> type[Exception]:
    """The stdlib CSV error class (pandas' python engine can raise it)."""
    import csv

    return csv.Error


def _read_parquet(p: Path) -> RawTable:
    import pyarrow as pa
    import pyarrow.parquet as pq

    tail = b""
    if p.stat().st_size >= 8:
        with p.open("rb") as fh:
            fh.seek(-4, os.SEEK_END)
            tail = fh.read(4)
    if tail != b"PAR1":
        raise DataError("Parquet footer missing (truncated file?)", path=str(p))
    try:
        table = pq.read_table(p)
    except (pa.ArrowException, OSError, ValueError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise DataError(f"unreadable Parquet file (truncated or corrupt?): {msg}", path=str(p)) from None
    meta: dict[str, Any] = {}
    md = table.schema.metadata or {}
    if b"drivelash.meta" in md:
        meta = _parse_meta(md[b"drivelash.meta"])
    cols: dict[str, np.ndarray] = {}
    for name in table.column_names:
        col = table.column(name)
        if not (
            pa.types.is_integer(col.type) or pa.types.is_floating(col.type) or pa.types.is_boolean(col.type)
        ):
            continue
        cols[str(name)] = col.to_numpy(zero_copy_only=False).astype(np.float64)
    return RawTable(cols, {}, meta, str(p), "parquet")


def _h5_open(p: Path):  # noqa: ANN202
    import h5py

    try:
        return h5py.File(p, "r")
    except OSError as exc:
        msg = str(exc).splitlines()[0] if str(exc) else "unreadable"
        hint = "truncated file?" if "truncated" in msg.lower() or "eof" in msg.lower() else "corrupt file?"
        raise DataError(f"unreadable HDF5 file ({hint}): {msg}", path=str(p)) from None


def _read_pandas_fixed(group: Any) -> dict[str, np.ndarray]:
    """A pandas ``HDFStore`` fixed-format frame (``axis0``, ``blockN_items``, ``blockN_values``)."""
    cols: dict[str, np.ndarray] = {}
    i = 0
    while f"block{i}_items" in group and f"block{i}_values" in group:
        items = [x.decode() if isinstance(x, bytes) else str(x) for x in group[f"block{i}_items"][()]]
        ds = group[f"block{i}_values"]
        vals = np.asarray(ds[()])
        transposed = bool(ds.attrs.get("transposed", False))
        if vals.ndim == 2:
            if transposed or (vals.shape[1] == len(items) and vals.shape[0] != len(items)):
                vals = vals.T
            for name, row in zip(items, vals, strict=False):
                col = _as_column(row)
                if col is not None:
                    cols[name] = col
        i += 1
    return cols


def _read_hdf5(p: Path) -> RawTable:
    import h5py

    items: dict[str, Any] = {}
    meta: dict[str, Any] = {}
    order: list[str] = []
    with _h5_open(p) as f:
        try:
            if _META_KEY in f.attrs:
                meta = _parse_meta(f.attrs[_META_KEY])
            if _ORDER_KEY in f.attrs:
                got = json.loads(str(f.attrs[_ORDER_KEY]))
                order = [str(x) for x in got] if isinstance(got, list) else []
            for k, v in f.attrs.items():
                if (
                    k not in (_META_KEY, _ORDER_KEY)
                    and np.asarray(v).dtype.kind in "biuf"
                    and np.asarray(v).size == 1
                ):
                    items[str(k)] = v

            frames: list[Any] = []

            def visit(name: str, obj: Any) -> None:
                if isinstance(obj, h5py.Group) and "block0_items" in obj and "block0_values" in obj:
                    frames.append(obj)
                elif isinstance(obj, h5py.Dataset):
                    if "/block" in f"/{name}" or name.endswith(("axis0", "axis1")) or "#refs#" in name:
                        return
                    if obj.dtype.names:  # compound table (e.g. pandas 'table' format)
                        data = obj[()]
                        for fld in obj.dtype.names:
                            arr = np.asarray(data[fld])
                            if arr.ndim == 2:
                                for j in range(arr.shape[1]):
                                    items[f"{fld}_{j}"] = arr[:, j]
                            else:
                                items[fld if fld != "index" else f"{name}/index"] = arr
                        return
                    if obj.size <= 10_000_000:
                        items[name] = obj[()]

            f.visititems(visit)
            for g in frames:
                items.update(_read_pandas_fixed(g))
        except (OSError, KeyError, ValueError, RuntimeError) as exc:
            msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise DataError(f"unreadable HDF5 content (truncated or corrupt?): {msg}", path=str(p)) from None
    cols, scalars = _split(items)
    # Shorter names when unambiguous: 'trace/theta_m' → 'theta_m'
    base = [k.rsplit("/", 1)[-1] for k in cols]
    if len(set(base)) == len(base):
        cols = {b: v for b, v in zip(base, cols.values(), strict=True)}
    if order:  # column order as written by drivelash
        cols = {k: cols[k] for k in order if k in cols} | {k: v for k, v in cols.items() if k not in order}
    return RawTable(cols, scalars, meta, str(p), "hdf5")


def _read_mat(p: Path, kind: str) -> RawTable:
    if kind == "mat73":
        table = _read_hdf5(p)
        table.fmt = "mat73"
        return table
    import scipy.io

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
    return RawTable(cols, scalars, meta, str(p), "mat")


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


def read_raw(path: str | Path) -> RawTable:
    """Read the source columns of a recording (no mapping, no validation).

    Parameters
    ----------
    path : str or Path
        ``.csv``/``.txt``, ``.parquet``/``.pq``, ``.h5``/``.hdf5``, ``.mat`` (v5 or v7.3).

    Raises
    ------
    DataError
        Missing, empty, truncated or wrong-type file; malformed content.
    """
    p = Path(path)
    kind = detect_format(p)
    if kind == "csv":
        table = _read_csv(p)
    elif kind == "parquet":
        table = _read_parquet(p)
    elif kind == "hdf5":
        table = _read_hdf5(p)
    else:
        table = _read_mat(p, kind)
    if not table.columns:
        raise DataError("no numeric columns found", path=str(p))
    n = {v.size for v in table.columns.values()}
    if n == {0}:
        raise DataError("file has no data rows", path=str(p))
    return table


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
        header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created by: drivelash HDF5 schema 1.00 ."
        block = header.ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02" + b"IM"
        with path.open("r+b") as fh:
            fh.write(block.ljust(userblock, b"\x00")[:userblock])


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
    """
    from drivelash.io.outputs import atomic_write, final_suffix, is_staging_path

    p = Path(path)
    if fmt is None:
        fmt = EXTENSIONS.get(final_suffix(p))
        if fmt is None:
            raise DataError(
                f"unsupported extension '{final_suffix(p)}' (use .csv, .parquet, .h5, .mat)", path=str(p)
            )
    if fmt not in FORMATS:
        raise DataError(f"unknown format '{fmt}' (one of {', '.join(FORMATS)})", path=str(p))
    if is_staging_path(p):
        _write(trace, p, fmt)
        return p
    with atomic_write(p) as tmp:
        _write(trace, tmp, fmt)
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
