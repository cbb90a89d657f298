"""Recordings larger than memory: :class:`TraceStream` reads a recording in row chunks.

The same mapping, unit conversion and validation as :func:`drivelash.io.load_trace`,
applied chunk by chunk, so a multi-hour 8 kHz recording is read in bounded memory:

1. **validation pass** over the needed columns (cheap: Parquet/HDF5 read only those
   columns; CSV is parsed by pyarrow's streaming reader): NaN/Inf (first bad row per
   column), time monotonic and uniform across chunk boundaries, the sample period
   ``T_s`` as the exact median of all intervals (the same value :attr:`Trace.T_s` gives on
   the whole recording), implausible time units, constant signals, encoder wrap-around;
2. a second pass only where a check needs a figure of the whole signal first: clipped
   torque (fraction of samples at the extreme, longest run) and the position/velocity
   unit check (velocity against the derivative of position over the samples with
   motion, |dθ/dt| > 0.1 max |dθ/dt|; the threshold is applied on a histogram with 1/16
   octave bins, see ``docs/assumptions.md``);
3. then :meth:`TraceStream.chunks` yields :class:`~drivelash.io.Trace` chunks whose
   values are bit-identical to the rows of :func:`load_trace` on the same file
   (unwrapping carries its correction across chunks; the conversion is elementwise).

Non-uniform sampling with resampling asked for, and MAT v5 files, are read whole (within
the memory budget, :mod:`drivelash.io.budget`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import DataError
from drivelash.io.config import ColumnMap, DriveConfig, SamplingSection, is_prismatic
from drivelash.io.formats import DEFAULT_CHUNK_ROWS, ColumnSource, open_source
from drivelash.io.trace import UNITS as TRACE_UNITS
from drivelash.io.trace import Trace

__all__ = ["DEFAULT_CHUNK_ROWS", "TraceStream", "iter_trace_chunks"]

#: Above this many distinct sample intervals the exact median keeps every interval (8 B each).
_MAX_DISTINCT_STEPS = 1 << 16
#: Histogram resolution of the unit check: bins per octave of |dθ/dt|.
_BINS_PER_OCTAVE = 16
#: Arrays above this size are allocated with mmap and returned to the OS when freed (glibc
#: ``M_MMAP_THRESHOLD``, fixed while streaming) [bytes].
MMAP_THRESHOLD_BYTES = 128 * 1024
#: Buffers of the file readers while streaming (pyarrow's CSV read-ahead of 4 MiB blocks and
#: their parsed columns, the Parquet page buffer), budgeted as one figure [bytes].
READER_BUFFER_BYTES = 64 * 2**20


@dataclass
class _Col:
    """How one Trace column is made from one source column."""

    name: str
    source: str
    factor: float
    scale: float = 1.0
    offset: float = 0.0
    affine: bool = True  # raw * factor * scale + offset (mapped) or raw * factor (time unit only)
    modulus: float | None = None  # encoder wrap-around candidate (file units)
    jump: str = ""
    kind: str | None = None

    def convert(self, raw: np.ndarray) -> np.ndarray:
        if self.affine:
            return raw * self.factor * self.scale + self.offset
        return raw * self.factor if self.factor != 1.0 else raw


def _plan(
    src: ColumnSource, cmap: dict[str, ColumnMap] | None, sampling: SamplingSection, warnings: list[str]
) -> list[_Col]:
    """The Trace columns of ``src`` under the mapping (the rules of ``load._apply_mapping``);
    ``warnings`` receives what the mapping could not check."""
    from drivelash.io.load import _factor, _one_rev, check_mapped_column, passthrough_unit, time_factor

    path = src.path
    plan: list[_Col] = []
    if cmap is None:
        for k in src.names:
            passthrough_unit(src, k)
            if k == "t":
                plan.append(_Col("t", "t", time_factor(src, "t", sampling), affine=False))
            elif k.startswith("theta"):
                plan.append(_Col(k, k, 1.0, affine=False, modulus=2 * math.pi, jump="one revolution"))
            else:
                plan.append(_Col(k, k, 1.0, affine=False))
        cmap = {}
    made: set[str] = {c.name for c in plan}
    for source, cm in cmap.items():
        kind = check_mapped_column(source, cm, list(src.names), made, path)
        modulus = cm.wrap if cm.wrap is not None else (_one_rev(cm) if kind == "angle" else None)
        if not cm.column.startswith("theta"):
            modulus = None
        plan.append(
            _Col(
                cm.column,
                source,
                _factor(cm, src, source, warnings),  # type: ignore[arg-type]
                cm.scale,
                cm.offset,
                True,
                modulus,
                f"{modulus:g} {cm.unit}" if modulus is not None else "",
                kind,
            )
        )
        made.add(cm.column)
    for name in src.names:
        if name in TRACE_UNITS and name != "t" and name not in made and name not in cmap:
            passthrough_unit(src, name)
            mod = 2 * math.pi if name.startswith("theta") else None
            plan.append(_Col(name, name, 1.0, affine=False, modulus=mod, jump="one revolution"))
            made.add(name)
    if "t" not in made and sampling.sample_rate is None:
        for name in ("t", "time"):  # an unmapped time column in [sampling] time_unit
            if name in src.names:
                plan.insert(0, _Col("t", name, time_factor(src, name, sampling), affine=False))
                break
    return plan


class _Stats:
    """Running figures of one column over the validation pass."""

    def __init__(self) -> None:
        self.bad = 0
        self.first_bad: int | None = None
        self.first_bad_nan = True
        self.lo = math.inf
        self.hi = -math.inf
        self.first_si: float | None = None
        self.jumps = 0
        self.first_jump: int | None = None
        self.last_raw: float | None = None
        self.raw_lo = math.inf
        self.raw_hi = -math.inf


def mapped_names(path: str | Path, mapping: Any = None) -> list[str]:
    """The Trace columns the file at ``path`` gives under ``mapping`` (as :class:`TraceStream`
    and :func:`~drivelash.io.load_trace` map it), read from its header alone: no values are
    loaded or checked."""
    from drivelash.io.load import _mapping_from

    cmap, sampling = _mapping_from(mapping)
    src = open_source(Path(path))
    try:
        return [c.name for c in _plan(src, cmap, sampling, [])]
    finally:
        src.close()


class TraceStream:
    """A validated recording, read in row chunks (see the module docstring).

    Parameters
    ----------
    path : str or Path
        CSV, Parquet, HDF5 or MATLAB file.
    mapping : DriveConfig or dict, optional
        Column mapping, as for :func:`drivelash.io.load_trace`.
    required : iterable of str
        Trace columns the caller needs.
    columns : iterable of str, optional
        Trace columns to read and yield (``t`` always); default: every mapped column.
    chunk_rows : int
        Rows per chunk.
    resample : bool, optional
        As for :func:`load_trace` (resampling reads the recording whole).
    check_saturation : bool
        Refuse clipped torque/force columns.

    Attributes
    ----------
    n_samples : int
    T_s : float
        Sample period [s]: the median of all intervals, as :attr:`Trace.T_s`.
    names : list of str
        The columns each chunk carries.
    meta : dict
        As ``load_trace(...).meta``.
    """

    def __init__(
        self,
        path: str | Path,
        mapping: DriveConfig | Mapping[str, Any] | None = None,
        *,
        required: Iterable[str] = (),
        columns: Iterable[str] | None = None,
        chunk_rows: int = DEFAULT_CHUNK_ROWS,
        resample: bool | None = None,
        check_saturation: bool = True,
    ) -> None:
        from drivelash.io.load import _mapping_from

        self.path = Path(path)
        self.chunk_rows = max(3, int(chunk_rows))
        _fix_mmap_threshold()
        cmap, sampling = _mapping_from(mapping)
        if resample is not None:
            sampling = sampling.model_copy(update={"resample": resample})
        self._sampling = sampling
        self._mapping = mapping
        self._t_unit = next((cm.unit for cm in (cmap or {}).values() if cm.column == "t"), None)
        self._required = list(required)
        self._check_saturation = check_saturation
        self._whole: Trace | None = None
        self._src = open_source(self.path)
        try:
            self._setup(cmap, sampling, columns)
        except BaseException:
            self._src.close()
            raise

    # ------------------------------------------------------------------ set-up
    def _setup(self, cmap: Any, sampling: SamplingSection, columns: Any) -> None:
        src = self._src
        spath = str(self.path)
        plan_warnings: list[str] = []
        plan = _plan(src, cmap, sampling, plan_warnings)
        names = [c.name for c in plan]
        if "t" not in names and sampling.sample_rate is None:
            from drivelash.io.load import time_hint

            raise DataError(
                "missing required column 't' (no time column mapped and no [sampling] sample_rate)"
                + time_hint(list(src.names)),
                path=spath,
                column="t",
            )
        have = names if "t" in names else ["t", *names]
        missing = [r for r in self._required if r not in have]
        if missing:
            raise DataError(
                f"missing required column (have: {', '.join(have)}); map it in [columns]",
                path=spath,
                column=missing[0],
            )
        if columns is not None:
            want = ["t", *[c for c in columns if c != "t"]]
            unknown = [c for c in want if c not in have]
            if unknown:
                raise DataError(f"no such column (have: {', '.join(have)})", path=spath, column=unknown[0])
            plan = [c for c in plan if c.name in want]
        from drivelash.io.load import unread_column

        self._plan = plan
        #: columns no computation reads: NaN/inf leaves them out instead of refusing the file
        self._unread = {c.name for c in plan if unread_column(c.name, cmap, self._required)}
        self.n_samples = src.n_rows
        self._warnings: list[str] = plan_warnings
        self._unwrap: dict[str, float] = {}
        self.names = ["t", *[c.name for c in plan if c.name != "t"]]
        self.meta: dict[str, Any] = {}
        while True:
            try:
                self._validate()
                break
            except DataError as exc:
                # a text column (a CNC's status or comment column) passed through only because
                # no [columns] table names what to read: dropped, as the whole-file loader and a
                # Parquet file's string columns do (A16); a column a computation uses still fails
                text = self._src.unread
                if cmap is not None or exc.column not in text or exc.column in TRACE_UNITS:
                    raise
                self._plan = [c for c in self._plan if c.source != exc.column]
                self.names = ["t", *[c.name for c in self._plan if c.name != "t"]]
                self._unread.discard(exc.column)
                self._warnings, self._unwrap = list(plan_warnings), {}
        plan = self._plan
        kinds = {c.name: c.kind for c in plan if c.kind}
        self.meta = self._meta(kinds, cmap)

    def _meta(self, kinds: dict[str, str], cmap: Any) -> dict[str, Any]:
        prismatic = is_prismatic(kinds)
        kinds_m = {kinds.get("theta_m"), kinds.get("omega_m")} - {None, "dimensionless"}
        if prismatic and kinds_m & {"angle", "angular_velocity"}:
            raise DataError(
                "theta_m and omega_m mix a length and an angle unit",
                path=str(self.path),
                column=self._origin("omega_m"),
            )
        meta: dict[str, Any] = dict(self._src.meta)
        meta.update(
            {
                "source": str(self.path),
                "format": self._src.fmt,
                "axis": "prismatic" if prismatic else meta.get("axis", "rotary"),
                "warnings": list(meta.get("warnings", [])) + self._warnings,
            }
        )
        if prismatic:
            from drivelash.io.load import PRISMATIC_UNITS

            meta["units"] = dict(PRISMATIC_UNITS)
        if self._src.scalars:
            meta["scalars"] = {k: float(v) for k, v in self._src.scalars.items()}
        if cmap is not None:
            meta["mapping"] = {k: v.model_dump(exclude_defaults=True) for k, v in cmap.items()}
        return meta

    def _origin(self, name: str) -> str:
        for c in self._plan:
            if c.name == name:
                return c.source
        return name

    def _t_col(self) -> _Col | None:
        return next((c for c in self._plan if c.name == "t"), None)

    def _raw_chunks(self, cols: list[_Col]) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        """(first row, source arrays) of each chunk of ``cols``' sources."""
        sources = list(dict.fromkeys(c.source for c in cols))
        row = 0
        for ch in self._src.chunks(sources, self.chunk_rows):
            n = len(next(iter(ch.values()))) if ch else 0
            yield row, ch
            row += n

    def _t_chunk(self, row: int, n: int, raw: dict[str, np.ndarray]) -> np.ndarray:
        tc = self._t_col()
        if tc is not None:
            return tc.convert(raw[tc.source])
        return np.arange(row, row + n) / self._sampling.sample_rate

    # ------------------------------------------------------------------ validation
    def _validate(self) -> None:
        from drivelash.io.load import RESAMPLE_HINT, _check_plausible_period, wrap_note

        spath = str(self.path)
        plan = self._plan
        stats = {c.name: _Stats() for c in plan}
        step_vals: dict[float, int] = {}
        all_steps: list[np.ndarray] | None = None
        t_last: float | None = None
        bad_time: tuple[int, float, float] | None = None
        n = self.n_samples
        if n < 3:
            raise DataError(f"only {n} sample(s); need at least 3", path=spath, column=self._origin("t"))
        for row, raw in self._raw_chunks(plan):
            m = len(next(iter(raw.values())))
            for c in plan:
                st = stats[c.name]
                r = raw[c.source]
                fin = np.isfinite(r)
                if not fin.all():
                    k = int(np.flatnonzero(~fin)[0])
                    if st.first_bad is None:
                        st.first_bad, st.first_bad_nan = row + k, bool(np.isnan(r[k]))
                    st.bad += int((~fin).sum())
                    continue
                if st.first_bad is not None:
                    continue
                si = c.convert(r)
                if st.first_si is None:
                    st.first_si = float(si[0])
                st.lo, st.hi = min(st.lo, float(si.min())), max(st.hi, float(si.max()))
                if c.modulus is not None:
                    rr = r if st.last_raw is None else np.concatenate(([st.last_raw], r))
                    jumps = np.abs(np.diff(rr)) > 0.5 * c.modulus
                    if jumps.any():
                        st.jumps += int(jumps.sum())
                        if st.first_jump is None:
                            base = row - (0 if st.last_raw is None else 1)
                            st.first_jump = base + int(np.flatnonzero(jumps)[0]) + 1
                    st.last_raw = float(r[-1])
                    st.raw_lo, st.raw_hi = min(st.raw_lo, float(r.min())), max(st.raw_hi, float(r.max()))
            if any(stats[c.name].first_bad is not None for c in plan if c.name not in self._unread):
                continue
            t = self._t_chunk(row, m, raw)
            tt = t if t_last is None else np.concatenate(([t_last], t))
            steps = np.diff(tt)
            if bad_time is None and np.any(steps <= 0):
                i = int(np.flatnonzero(steps <= 0)[0])
                base = row - (0 if t_last is None else 1)
                bad_time = (base + i + 1, float(tt[i]), float(tt[i + 1]))
            t_last = float(t[-1])
            if all_steps is not None:
                all_steps.append(steps)
            else:
                u, cnt = np.unique(steps, return_counts=True)
                for v, k in zip(u.tolist(), cnt.tolist(), strict=True):
                    step_vals[v] = step_vals.get(v, 0) + k
                if len(step_vals) > _MAX_DISTINCT_STEPS:  # jittery clock: keep every interval
                    from drivelash.io.budget import check_budget

                    check_budget(8.0 * n, what=f"{spath}: the exact median of {n} irregular sample intervals")
                    all_steps = [np.repeat(np.array(list(step_vals)), list(step_vals.values()))]
        # an unread column with NaN/inf is left out (the loader's rule, load.unread_column)
        from drivelash.io.load import float32_time_hint, unread_note

        for c in [c for c in plan if c.name in self._unread and stats[c.name].first_bad is not None]:
            st = stats.pop(c.name)
            what = "NaN" if st.first_bad_nan else "infinite value"
            self._warnings.append(unread_note(spath, c.source, what, st.first_bad, st.bad, self._src.rows))
            plan = [p for p in plan if p.name != c.name]
        if len(plan) != len(self._plan):
            self._plan = plan
            self.names = ["t", *[c.name for c in plan if c.name != "t"]]
        # the first problem in the loader's order: non-finite values, time, constant, …
        for c in plan:
            st = stats[c.name]
            if st.first_bad is not None:
                what = "NaN" if st.first_bad_nan else "infinite value"
                raise DataError(
                    f"{what} ({st.bad} bad sample(s))",
                    path=spath,
                    column=c.source,
                    row=st.first_bad,
                    rows=self._src.rows,
                )
        tcol = self._origin("t")
        if bad_time is not None:
            row, a, b = bad_time
            what = "duplicated time stamp" if a == b else "time goes backwards (non-increasing)"
            raise DataError(
                f"{what}: t={b!r} after t={a!r}" + float32_time_hint(float(a), float(b)),
                path=spath,
                column=tcol,
                row=row,
                rows=self._src.rows,
            )
        if all_steps is not None:
            med = float(np.median(np.concatenate(all_steps)))
            dev_max = None
        else:
            med = _median_of_counts(step_vals)
            dev_max = max(abs(v - med) / med for v in step_vals)
        _check_plausible_period(med, spath, tcol, self._sampling, self._t_unit)
        tol = self._sampling.tolerance
        if (dev_max is None or dev_max > tol) and self._first_irregular(med, tol) is not None:
            if self._sampling.resample:  # resampling needs the whole recording
                self._read_whole()
                return
            row, step = self._first_irregular(med, tol)  # type: ignore[misc]
            raise DataError(
                f"non-uniform sampling: interval {step:.6g} s vs median {med:.6g} s"
                f" (deviation {abs(step - med) / med:.1%} > tolerance {tol:.1%});"
                f" {RESAMPLE_HINT}",
                path=spath,
                column=tcol,
                row=row,
                rows=self._src.rows,
            )
        self.T_s = med
        # encoder wrap-around: unwrap when the signal jumps and stays within one modulus
        for c in plan:
            st = stats[c.name]
            if c.modulus is None or not st.jumps or c.modulus <= 0:
                continue
            if st.raw_hi - st.raw_lo > c.modulus * (1 + 1e-9):
                continue
            self._unwrap[c.name] = c.modulus
            self._warnings.append(
                wrap_note(spath, c.source, st.jumps, c.jump, st.first_jump or 0, self._src.rows)
            )
        self._second_pass(stats)

    def _first_irregular(self, med: float, tol: float) -> tuple[int, float] | None:
        t_last = None
        for row, raw in self._raw_chunks([c for c in self._plan if c.name == "t"] or self._plan[:1]):
            m = len(next(iter(raw.values())))
            t = self._t_chunk(row, m, raw)
            tt = t if t_last is None else np.concatenate(([t_last], t))
            steps = np.diff(tt)
            dev = np.abs(steps - med) / med
            if np.any(dev > tol):
                i = int(np.flatnonzero(dev > tol)[0])
                return row - (0 if t_last is None else 1) + i + 1, float(steps[i])
            t_last = float(t[-1])
        return None

    def _second_pass(self, stats: dict[str, _Stats]) -> None:
        """Constant and clipped signals; the position/velocity unit check."""
        from drivelash.io._seam import SeamScan
        from drivelash.io._velscale import VelocityScaleFit
        from drivelash.io.load import (
            DWELL_POSITIONS,
            MAY_STAND_STILL,
            SIGNAL_COLUMNS,
            ExtremeRuns,
            check_position_spans,
            check_unit_ratio,
            check_velocity_scale,
            raise_saturated,
            raise_seam,
        )

        spath = str(self.path)
        names = list(dict.fromkeys([*SIGNAL_COLUMNS, *self._required]))
        plan = {c.name: c for c in self._plan}
        for name in names:
            if name not in plan or name == "t":
                continue
            st = stats[name]
            # unwrapping cannot make a constant signal move; a still load is a verdict, not an error
            if st.hi - st.lo == 0 and name not in MAY_STAND_STILL:
                raise DataError(
                    f"constant signal (every sample is {st.first_si:.6g})",
                    path=spath,
                    column=plan[name].source,
                    row=0,
                    rows=self._src.rows,
                )
        sat = [
            n
            for n in names
            if n in plan and (n.startswith("torque") or n.startswith("F_"))
            and (self._check_saturation or not n.startswith("torque"))
        ]  # fmt: skip
        pairs = [s for s in ("m", "l") if f"theta_{s}" in plan and f"omega_{s}" in plan]

        def spans() -> None:  # after the saturation checks, before the velocity check (the loader's order)
            check_position_spans(
                {n: stats[n].hi - stats[n].lo for n in plan if n != "t" and n in stats},
                {n: c.kind for n, c in plan.items()},
                {n: c.source for n, c in plan.items()},
                spath,
            )

        if not sat and not pairs:
            spans()
            return
        k = max(1, min(25, self.n_samples // 50))
        dwell = [p for p in DWELL_POSITIONS if p in plan]
        sat_state = {n: {key: ExtremeRuns(dwell) for key in ("hi", "lo")} for n in sat}
        units = {s: _UnitAcc(k) for s in pairs}
        seams = {s: SeamScan(plan[f"theta_{s}"].source) for s in pairs}
        scales = {s: VelocityScaleFit() for s in pairs}
        for ch in self.chunks():
            for n in sat:
                a = ch[n]
                for key, ext in (("hi", stats[n].hi), ("lo", stats[n].lo)):
                    sat_state[n][key].feed(a == ext, {p: ch[p] for p in dwell}, ch.row0)
            for s, acc in units.items():
                acc.feed(ch["t"], ch[f"theta_{s}"], ch[f"omega_{s}"], ch.row0)
                seams[s].feed(ch["t"], ch[f"theta_{s}"], ch[f"omega_{s}"], ch.row0)
                scales[s].feed(ch["t"], ch[f"theta_{s}"], ch[f"omega_{s}"])
        for n in sat:
            for key, label, ext in (("hi", "maximum", stats[n].hi), ("lo", "minimum", stats[n].lo)):
                raise_saturated(
                    sat_state[n][key], self.n_samples, label, ext, spath, plan[n].source, self._src.rows
                )
        spans()
        for s, acc in units.items():
            acc.finish()
            ratio, row = acc.ratio()
            if ratio is None:
                continue
            check_unit_ratio(ratio, s, spath, plan[f"omega_{s}"].source, row, self._src.rows)
        for s, scan in seams.items():  # after the unit check, as in the loader
            scan.finish()
            raise_seam(scan, plan[f"theta_{s}"].kind == "length", spath, self._src.rows)
        for s, fit in scales.items():  # after the seam check, as in the loader
            check_velocity_scale(fit, s, spath, plan[f"omega_{s}"].source)

    def _read_whole(self) -> None:
        """Read the recording whole with :func:`load_trace` (within the memory budget)."""
        from drivelash.io.load import load_trace

        self._src.check_whole([c.source for c in self._plan])
        tr = load_trace(
            self.path,
            self._mapping,
            required=self._required,
            resample=True,
            check_saturation=self._check_saturation,
        )
        keep = ["t", *[c.name for c in self._plan if c.name != "t"]]
        self._whole = tr.select(keep)
        self._warnings.extend(w for w in tr.meta.get("warnings", []) if w not in self._warnings)
        self.T_s = tr.T_s
        self.n_samples = len(tr)
        self._unwrap = {}

    # ------------------------------------------------------------------ data
    def chunks(self, chunk_rows: int | None = None) -> Iterator[_Chunk]:
        """The recording in chunks of SI columns (:class:`~drivelash.io.Trace` with ``row0``).

        Parameters
        ----------
        chunk_rows : int, optional
            Rows per chunk (at least 3); default the stream's ``chunk_rows``.
        """
        if chunk_rows is not None and chunk_rows != self.chunk_rows:
            self.chunk_rows = max(3, int(chunk_rows))
        if self._whole is not None:
            for a in range(0, len(self._whole), self.chunk_rows):
                part = self._whole.slice(a, a + self.chunk_rows)
                ch = _Chunk(part.columns, self.meta)
                ch.row0 = a
                yield ch
            return
        carry: dict[str, tuple[float, float]] = {}  # name -> (last raw, cumulative correction)
        for row, raw in self._raw_chunks(self._plan):
            m = len(next(iter(raw.values())))
            cols: dict[str, np.ndarray] = {"t": self._t_chunk(row, m, raw)}
            for c in self._plan:
                if c.name == "t":
                    continue
                r = raw[c.source]
                mod = self._unwrap.get(c.name)
                if mod is not None:
                    r = _unwrap_chunk(r, mod, carry, c.name)
                cols[c.name] = c.convert(r)
            ch = _Chunk({k: cols[k] for k in self.names}, self.meta)
            ch.row0 = row
            yield ch

    def __iter__(self) -> Iterator[_Chunk]:
        return self.chunks()

    def peak_bytes(self) -> float:
        """Memory the data of a chunked read need at the peak [bytes] (not the interpreter).

        ``min(chunk_rows, n)`` rows of every read column, :data:`WHOLE_READ_FACTOR` copies of
        each (raw, float64, SI, temporaries), plus :data:`READER_BUFFER_BYTES` for the file
        readers' buffers; the whole recording when it was read whole (resampling).
        """
        from drivelash.io.formats import WHOLE_READ_FACTOR

        rows = self.n_samples if self._whole is not None else min(self.chunk_rows, self.n_samples)
        return float(rows) * len(self.names) * 8.0 * WHOLE_READ_FACTOR + READER_BUFFER_BYTES

    def close(self) -> None:
        """Release the file."""
        self._src.close()

    def __enter__(self) -> TraceStream:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


_MMAP_FIXED = False


def _fix_mmap_threshold() -> None:
    """Keep glibc's mmap threshold at :data:`MMAP_THRESHOLD_BYTES` (once per process).

    glibc raises the threshold each time a mapped block is freed (up to 32 MiB), after
    which the per-chunk arrays come from the heap, whose fragmentation grew the reader's
    peak RSS by ≈ 9 B per sample of the recording (measured: 400 → 425 MiB from a 2- to an
    8-minute 8 kHz Parquet file; with the threshold fixed, 400 → 403 MiB). Setting it
    disables that adjustment. Other C libraries: nothing is done.
    """
    global _MMAP_FIXED
    if _MMAP_FIXED:
        return
    _MMAP_FIXED = True
    import ctypes
    import ctypes.util
    import sys

    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return
    M_MMAP_THRESHOLD = -3
    mallopt(ctypes.c_int(M_MMAP_THRESHOLD), ctypes.c_int(MMAP_THRESHOLD_BYTES))


class _Chunk(Trace):
    """A chunk of a :class:`TraceStream`: a Trace and the row of its first sample."""

    row0: int = 0


def _unwrap_chunk(r: np.ndarray, period: float, carry: dict, name: str) -> np.ndarray:
    """``np.unwrap(x, period)`` of the whole column, one chunk at a time (bit-identical)."""
    last, corr0 = carry.get(name, (None, 0.0))
    x = r if last is None else np.concatenate(([last], r))
    # numpy's unwrap: ph_correct from the wrapped differences, cumulated from the start
    dd = np.diff(x)
    interval_high = period / 2
    interval_low = -interval_high
    ddmod = np.mod(dd - interval_low, period) + interval_low
    ddmod[(ddmod == interval_low) & (dd > 0)] = interval_high
    ph_correct = ddmod - dd
    ph_correct[np.abs(dd) < period / 2] = 0
    cum = np.cumsum(np.concatenate(([corr0], ph_correct)))
    if last is None:
        out = r.copy()
        out[1:] = r[1:] + cum[1:]
    else:
        out = r + cum[1:]
    carry[name] = (float(r[-1]), float(cum[-1]))
    return out


def _median_of_counts(counts: dict[float, int]) -> float:
    """``np.median`` of a multiset given as value → count (same arithmetic for even sizes)."""
    vals = np.array(sorted(counts))
    cum = np.cumsum([counts[v] for v in vals.tolist()])
    total = int(cum[-1])
    lo = vals[int(np.searchsorted(cum, (total - 1) // 2, side="right"))]
    hi = vals[int(np.searchsorted(cum, total // 2, side="right"))]
    return float(np.median(np.array([lo, hi]))) if total % 2 == 0 else float(hi)


class _UnitAcc:
    """The loader's unit check (``load._check_units``) accumulated over chunks.

    dθ/dt (``np.gradient``) and its moving average over ``k`` samples are computed on each
    chunk with ``k + 2`` samples of context on both sides, so they equal the whole-signal
    values; Σ ω·d and Σ d·d are binned by |d| (1/16 octave) until max |d| is known.
    """

    def __init__(self, k: int) -> None:
        self.k = k
        self.ctx = k + 2
        self.buf: dict[str, np.ndarray] | None = None
        self.buf_row = 0
        self.emitted = 0
        self.bins: dict[str, np.ndarray] = {}
        self.dmax = 0.0
        self.first_row_by_bin: dict[int, int] = {}

    def feed(self, t: np.ndarray, th: np.ndarray, om: np.ndarray, row0: int) -> None:
        new = {"t": t, "th": th, "om": om}
        if self.buf is None:
            self.buf, self.buf_row = new, row0
        else:
            self.buf = {k: np.concatenate((self.buf[k], new[k])) for k in new}
        self._process(final=False)

    def finish(self) -> None:
        if self.buf is not None:
            self._process(final=True)

    def _process(self, final: bool) -> None:
        b = self.buf
        assert b is not None
        n = b["t"].size
        # positions [lo, hi) of the buffer whose values have full context (or are at the edges)
        lo = self.emitted - self.buf_row
        hi = n if final else n - self.ctx
        if hi <= lo or n < 2:
            return
        d = np.gradient(b["th"], b["t"])
        om = b["om"]
        if self.k > 1:
            ker = np.ones(self.k) / self.k
            d = np.convolve(d, ker, mode="same")
            om = np.convolve(om, ker, mode="same")
        # the buffer's own edges are not the signal's edges, except the very first and last
        d, om = d[lo:hi], om[lo:hi]
        ad = np.abs(d)
        self.dmax = max(self.dmax, float(ad.max()) if ad.size else 0.0)
        mant, expo = np.frexp(ad)
        idx = _bin_of(ad, mant, expo)
        size = 2300 * _BINS_PER_OCTAVE
        for key, w in (("od", om * d), ("dd", d * d), ("n", np.ones_like(d))):
            acc = np.bincount(idx, weights=w, minlength=size)
            self.bins[key] = self.bins.get(key, 0) + acc
        if ad.size:  # first row with motion, per bin (for the error message)
            for bi in np.unique(idx):
                if int(bi) not in self.first_row_by_bin:
                    self.first_row_by_bin[int(bi)] = self.buf_row + lo + int(np.flatnonzero(idx == bi)[0])
        self.emitted = self.buf_row + hi
        keep = 2 * self.ctx
        cut = max(0, hi - keep)
        self.buf = {k: v[cut:] for k, v in b.items()}
        self.buf_row += cut

    def ratio(self) -> tuple[float | None, int]:
        if not self.bins or self.dmax <= 0:
            return None, 0
        thr = 0.1 * self.dmax
        mant, expo = np.frexp(np.array([thr]))
        tb = int(_bin_of(np.array([thr]), mant, expo)[0])
        sel = slice(tb + 1, None)  # bins wholly above the threshold (within 1/16 octave)
        n = float(self.bins["n"][sel].sum())
        if n < 10:
            return None, 0
        dd = float(self.bins["dd"][sel].sum())
        if dd == 0:
            return None, 0
        rows = [r for b, r in self.first_row_by_bin.items() if b > tb]
        return float(self.bins["od"][sel].sum()) / dd, (min(rows) if rows else 0)


def _bin_of(ad: np.ndarray, mant: np.ndarray, expo: np.ndarray) -> np.ndarray:
    """Histogram bin of |d|: 1/16 octave (from the float's exponent and mantissa); 0 for zero."""
    fine = np.floor((mant - 0.5) * 2 * _BINS_PER_OCTAVE)
    return np.where(ad > 0, (expo + 1100) * _BINS_PER_OCTAVE + fine, 0).astype(np.int64)


def iter_trace_chunks(
    path: str | Path,
    mapping: DriveConfig | Mapping[str, Any] | None = None,
    *,
    required: Iterable[str] = (),
    columns: Iterable[str] | None = None,
    chunk_rows: int = DEFAULT_CHUNK_ROWS,
    check_saturation: bool = True,
) -> Iterator[Trace]:
    """Validate a recording, then yield it in chunks of SI columns (see :class:`TraceStream`).

    Every chunk is a :class:`~drivelash.io.Trace` (``meta`` as ``load_trace`` gives it);
    concatenated, the chunks equal ``load_trace(path, mapping)`` bit for bit.

    Parameters
    ----------
    path : str or Path
        CSV, Parquet, HDF5 or MATLAB file.
    mapping : DriveConfig or dict, optional
        Column mapping, as for :func:`drivelash.io.load_trace`.
    required : iterable of str
        Trace columns the caller needs.
    columns : iterable of str, optional
        Trace columns to yield (``t`` always); default: every mapped column.
    chunk_rows : int
        Rows per chunk.
    check_saturation : bool
        Refuse clipped torque/force columns.

    Yields
    ------
    Trace
        The next chunk, SI columns.

    Raises
    ------
    DataError
        As :func:`drivelash.io.load_trace`, before the first chunk is yielded.
    """
    with TraceStream(
        path,
        mapping,
        required=required,
        columns=columns,
        chunk_rows=chunk_rows,
        check_saturation=check_saturation,
    ) as stream:
        yield from stream.chunks()
