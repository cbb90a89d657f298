"""The :class:`Trace`: a constant-rate recording with named SI columns.

Contract (DESIGN.md): ``t`` [s], ``theta_m`` [rad], ``omega_m`` [rad/s],
``theta_l`` [rad], ``omega_l`` [rad/s], ``torque_m`` [N·m]; optional further
columns (``delta_true`` [rad] in simulations, ``x_T`` [m], ``F_load`` [N] for
rack-and-pinion drives, …). ``meta`` holds JSON-serialisable provenance
(scenario name, seed, parameters).
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import NO_LINES, DataError, DataRows

TWO_MASS_COLUMNS = ("t", "theta_m", "omega_m", "theta_l", "omega_l", "torque_m")


def meta_json(meta: Mapping[str, Any]) -> str:
    """``meta`` as strict one-line JSON (numpy types converted, non-finite floats → null)."""
    from drivelash.io.outputs import jsonable

    return json.dumps(jsonable(dict(meta)), allow_nan=False)


UNITS: dict[str, str] = {
    "t": "s",
    "theta_m": "rad",
    "omega_m": "rad/s",
    "theta_l": "rad",
    "omega_l": "rad/s",
    "torque_m": "N·m",
    "delta_true": "rad",
    "x_T": "m",
    "x_d": "m",
    "F_load": "N",
    # ISO 230-2 positioning tests (drivelash.iso230); positions in rad on a rotary axis
    "P_target": "m",
    "P_cmd": "m",
    "P_actual": "m",
    "P_axis": "m",
    "x_dev": "m",
    "run": "1",
    "direction": "1",
}


@dataclass
class Trace:
    """A recording sampled at a constant period, columns in SI units.

    Parameters
    ----------
    columns : Mapping[str, numpy.ndarray]
        Column name → 1-D float64 array; all of equal length; must include ``t``.
    meta : dict
        JSON-serialisable provenance (scenario, seed, parameters, source file).
    rows : DataRows
        Where each sample's row is in the source file, for messages (set by
        :func:`~drivelash.io.load_trace`; a slice or a selection of columns does not keep it).

    Raises
    ------
    DataError
        A column that is not 1-D, columns of unequal length, or no ``t``.
    """

    columns: dict[str, np.ndarray]
    meta: dict[str, Any] = field(default_factory=dict)
    rows: DataRows = field(default=NO_LINES, repr=False, compare=False)

    def __post_init__(self) -> None:
        cols: dict[str, np.ndarray] = {}
        n = None
        for k, v in self.columns.items():
            a = np.ascontiguousarray(np.asarray(v, dtype=np.float64))
            if a.ndim != 1:
                raise DataError(f"must be one-dimensional, got shape {a.shape}", column=k)
            if n is None:
                n = a.size
            elif a.size != n:
                raise DataError(f"has {a.size} samples, expected {n}", column=k)
            cols[k] = a
        if "t" not in cols:
            raise DataError("a trace needs a time column", column="t")
        self.columns = cols

    # -- access -------------------------------------------------------------
    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.columns[name]
        except KeyError:
            raise DataError(f"no such column; available: {', '.join(self.columns)}", column=name) from None

    def __contains__(self, name: object) -> bool:
        return name in self.columns

    def __len__(self) -> int:
        return self.columns["t"].size

    @property
    def names(self) -> list[str]:
        """Column names in order."""
        return list(self.columns)

    @property
    def T_s(self) -> float:
        """Sample period [s] (median of time differences)."""
        t = self.columns["t"]
        if t.size < 2:
            raise DataError("fewer than two samples: no sample time", column="t")
        return float(np.median(np.diff(t)))

    @property
    def duration(self) -> float:
        """Recording length t[-1] − t[0] [s]."""
        t = self.columns["t"]
        return float(t[-1] - t[0]) if t.size else 0.0

    def select(self, names: Iterable[str]) -> Trace:
        """A trace with only ``names`` (``t`` always kept).

        Parameters
        ----------
        names : iterable of str
            Columns to keep.
        """
        keep = ["t"] + [n for n in names if n != "t"]
        return Trace({n: self[n] for n in keep}, dict(self.meta))

    def slice(self, start: int, stop: int | None = None) -> Trace:
        """Rows ``start:stop`` as a new trace.

        Parameters
        ----------
        start : int
            First row (0-based).
        stop : int, optional
            Row after the last; default the end.
        """
        return Trace({k: v[start:stop] for k, v in self.columns.items()}, dict(self.meta))

    def with_columns(self, extra: Mapping[str, np.ndarray]) -> Trace:
        """A copy with ``extra`` columns added or replaced.

        Parameters
        ----------
        extra : mapping of str to numpy.ndarray
            Columns to add or replace (SI units, the trace's length).
        """
        cols = dict(self.columns)
        cols.update(extra)
        return Trace(cols, dict(self.meta))

    @classmethod
    def from_frame(
        cls,
        df: Any,
        mapping: Any = None,
        *,
        required: Iterable[str] = (),
        resample: bool | None = None,
        check_saturation: bool = True,
    ) -> Trace:
        """A trace from a :class:`pandas.DataFrame`, with every check :func:`~drivelash.io.load_trace` makes.

        Parameters
        ----------
        df : pandas.DataFrame
            Columns by name, read as from a file (errors name ``<DataFrame>``): numeric and
            boolean columns as they are; a ``datetime64`` column (time stamps, with or without a
            zone) as seconds [s] from its first stamp, as the Parquet reader reads them (the first
            stamp in ``meta["time_origin"]``); a ``timedelta64`` column as seconds [s]. A time
            index named ``t`` (or ``time``) is used as that column. Other non-numeric columns
            are ignored unless they are read (a Trace name or a mapped source): then they are
            refused (``not numeric (dtype object)``). Duplicate or MultiIndex column names are
            refused.
        mapping, required, resample, check_saturation
            As for :func:`~drivelash.io.load_trace` (a dict maps *source column → Trace column*).

        Raises
        ------
        DataError
            Not a DataFrame, MultiIndex or duplicate column names, a read column that is not
            numeric, an empty time stamp, no numeric column or no rows; then as
            :func:`~drivelash.io.load_trace` (one line naming ``<DataFrame>``, column and row).
        """
        import pandas as pd

        from drivelash.io.formats import RawTable
        from drivelash.io.load import _mapping_from, trace_from_table

        where = "<DataFrame>"
        required = list(required)
        if not isinstance(df, pd.DataFrame):
            raise DataError(f"must be a pandas DataFrame, got {type(df).__name__}", path=where)
        if isinstance(df.columns, pd.MultiIndex):
            raise DataError(
                f"MultiIndex column names ({df.columns[0]!r}, …): flatten them, e.g. "
                "df.columns = ['_'.join(map(str, c)) for c in df.columns]",
                path=where,
            )
        dup = df.columns[df.columns.duplicated()]
        if len(dup):
            raise DataError("duplicate column name", path=where, column=str(dup[0]))
        time_index = (
            df.index.name is None
            and df.index.dtype.kind in "fMm"
            and len(df.index) > 1
            and bool(df.index.is_monotonic_increasing)
        )  # an unnamed float, time-stamp or duration index is likely the time: named in the
        # missing-'t' message (C14; a resampled or logged frame's DatetimeIndex too, G14)
        if df.index.name in ("t", "time") and df.index.name not in df.columns:
            df = df.reset_index()  # the time as the index: the same column as from a file
        cmap, sampling = _mapping_from(mapping)
        if resample is not None:
            sampling = sampling.model_copy(update={"resample": resample})
        read = set(UNITS) | {"t", "time", *required} | set(cmap or {})
        cols: dict[str, np.ndarray] = {}
        meta: dict[str, Any] = {}
        for name in df.columns:
            col = df[name]
            key = str(name)
            kind = col.dtype.kind
            if kind == "M":  # time stamps: seconds from the first, as the Parquet reader reads them
                from drivelash.io.formats import stamps_to_seconds

                stamps = pd.DatetimeIndex(col)
                if len(stamps) and pd.isna(stamps[0]):
                    raise DataError("empty time stamp", path=where, column=key, row=0)
                cols[key] = stamps_to_seconds(_ns(stamps), int(stamps[0].value) if len(stamps) else 0)
                meta.setdefault("timestamp_columns", []).append(key)
                meta.setdefault("time_origin", {})[key] = stamps[0].isoformat()
                continue
            if kind == "m":  # durations: seconds
                from drivelash.io.formats import stamps_to_seconds

                cols[key] = stamps_to_seconds(_ns(pd.TimedeltaIndex(col)), 0)
                continue
            a = np.asarray(col)
            if a.dtype.kind in "biuf" and a.ndim == 1:
                cols[key] = a.astype(np.float64)
            elif key in read:
                raise DataError(
                    f"not numeric (dtype {col.dtype}): convert it, e.g. "
                    f"df[{key!r}] = pd.to_numeric(df[{key!r}])",
                    path=where,
                    column=key,
                )
        if not cols:
            raise DataError("no numeric columns found", path=where)
        if len(df) == 0:
            raise DataError("no data rows", path=where)
        if time_index and sampling.sample_rate is None and not ({"t", "time"} & set(cols)):
            # only for the message of the refusal that follows: what the index holds
            meta["unnamed_time_index"] = {"M": "time stamps", "m": "durations"}.get(
                df.index.dtype.kind, "numbers"
            )
        table = RawTable(cols, {}, meta, where, "DataFrame")
        return trace_from_table(table, cmap, sampling, required=required, check_saturation=check_saturation)

    def to_pandas(self):  # noqa: ANN201 - pandas is an optional import at call time
        """The columns as a :class:`pandas.DataFrame`."""
        import pandas as pd

        return pd.DataFrame(self.columns)

    # -- files --------------------------------------------------------------
    def to_parquet(self, path: str | Path) -> Path:
        """Write Parquet; ``meta`` goes into the schema metadata as JSON.

        Parameters
        ----------
        path : str or Path
            Output file.
        """
        import pyarrow as pa
        import pyarrow.parquet as pq

        path = Path(path)
        table = pa.table(self.columns)
        table = table.replace_schema_metadata({b"drivelash.meta": meta_json(self.meta).encode()})
        pq.write_table(table, path)
        return path

    @classmethod
    def from_parquet(cls, path: str | Path) -> Trace:
        """Read a file written by :meth:`to_parquet` (or any numeric Parquet table).

        Parameters
        ----------
        path : str or Path
            The Parquet file (columns in SI units; ``meta`` from its schema metadata).
        """
        import pyarrow.parquet as pq

        table = pq.read_table(path)
        meta: dict[str, Any] = {}
        md = table.schema.metadata or {}
        if b"drivelash.meta" in md:
            meta = json.loads(md[b"drivelash.meta"].decode())
            meta.pop("generator", None)  # who wrote the file, not the recording's provenance
        cols = {name: table.column(name).to_numpy() for name in table.column_names}
        return cls(cols, meta)

    def to_csv(self, path: str | Path) -> Path:
        """Write CSV with a header row; floats with 17 significant digits (lossless).

        Parameters
        ----------
        path : str or Path
            Output file (``meta`` on a first ``# drivelash.meta`` line).
        """
        path = Path(path)
        names = self.names
        data = np.column_stack([self.columns[n] for n in names])
        header = ",".join(names)
        meta_line = "# drivelash.meta " + meta_json(self.meta)
        with path.open("w", encoding="utf-8", newline="\n") as fh:
            fh.write(meta_line + "\n")
            np.savetxt(fh, data, delimiter=",", header=header, comments="", fmt="%.17g")
        return path

    def save(self, path: str | Path) -> Path:
        """Write by extension (any format :func:`drivelash.io.formats.write_trace` knows).

        Parameters
        ----------
        path : str or Path
            Output file; the format from its extension.
        """
        from drivelash.io.formats import write_trace

        return write_trace(self, path)


def _ns(index: Any) -> np.ndarray:
    """Nanoseconds of a pandas Datetime/TimedeltaIndex: int64, or float64 with NaN at NaT
    (what the Parquet reader gets from Arrow)."""
    v = index.as_unit("ns").asi8
    nat = np.asarray(index.isna())
    if not nat.any():
        return v
    out = v.astype(np.float64)
    out[nat] = np.nan
    return out
