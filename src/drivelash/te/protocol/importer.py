"""``te import``: the user's recordings of a real axis → a campaign directory (published schema).

Each run of the axis file's ``[[runs]]`` list is read with :func:`~drivelash.io.load.load_trace`
(any format it reads: CSV, Parquet, HDF5, MAT) through the file's ``[columns]`` mapping
(units, encoder counts, current × torque constant, encoder sign ``scale = -1``, scale
zero ``offset``), checked for plausibility (:mod:`drivelash.te.protocol.plausibility`)
*before* anything is written, and stored as a Parquet trace in SI units next to a
``manifest.json`` of :mod:`drivelash.io.campaign` (``source = "imported"``: no seed, no
true TE). Errors refuse the import with one line naming the file and the problem;
warnings are printed and kept in the manifest.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import DataError
from drivelash.io.campaign import (
    FORMAT_NAME,
    FORMAT_VERSION,
    MANIFEST,
    OPTIONAL_COLUMNS,
    REQUIRED_COLUMNS,
    AxisBlock,
    CampaignManifest,
    RunEntry,
)
from drivelash.io.config import DriveConfig
from drivelash.io.load import load_trace, with_resample_hint
from drivelash.io.outputs import write_json
from drivelash.io.trace import Trace
from drivelash.te.protocol.axis import load_axis
from drivelash.te.protocol.plausibility import PlausibilityReport, check_runs, record_of

__all__ = ["MAX_BRIDGED_PERIODS", "check_bridged_gap", "import_campaign", "recording_paths", "summary_lines"]


def recording_paths(axis_path: str | Path) -> list[Path]:
    """The recordings an axis file lists (relative to the file), for output checks."""
    axis = load_axis(axis_path)
    return [axis.directory / r.file for r in axis.run_list(need_files=True)]  # type: ignore[operator]


def _direction_column(tr: Trace, direction: int) -> np.ndarray:
    """Commanded direction per sample: the run's for a pass, the sign of the set velocity for a sine."""
    if direction != 0:
        return np.full(len(tr), float(direction))
    x = tr["x_d"] if "x_d" in tr else tr["x_T"]
    v = np.gradient(x, tr["t"])
    s = np.sign(v)
    # standstill keeps the last direction of motion
    idx = np.where(s != 0, np.arange(s.size), 0)
    np.maximum.accumulate(idx, out=idx)
    s = s[idx]
    s[s == 0] = 1.0
    return s


#: What to do about non-uniform sampling in ``te import`` (tester H, TH9: the loader's hint named
#: ``--resample``, an option ``te import`` does not have).
RESAMPLE_HINT_AXIS = "resample explicitly with [sampling] resample = true in the axis file"

#: Longest stretch [sample periods] that ``[sampling] resample = true`` may bridge by linear
#: interpolation while the axis moves: resampling is for jitter (a sample a little early or
#: late bridges 1-2 periods); a longer stretch is a hole in the recording (a lost trace buffer)
#: whose data would be invented (finding A11: 2 s = 2000 periods, 40 mm, TE 6.4 µm off).
MAX_BRIDGED_PERIODS = 10


def check_bridged_gap(tr: Trace, path: str) -> None:
    """Refuse a resampled pass in which interpolation bridged a gap while the table moved.

    Linear interpolation leaves x_T, θ_M and the torque *exactly* on one line (second differences
    at rounding level) over the bridged stretch; measured data in motion never are (noise,
    quantisation). A stretch longer than :data:`MAX_BRIDGED_PERIODS` sample periods over which
    the table moved is refused in one line naming the file, the time, the length and the travel.

    Parameters
    ----------
    tr : Trace
        The loaded (resampled) pass: ``t`` [s], ``x_T`` [m], ``theta_m`` [rad], ``torque_m`` [N·m].
    path : str
        The recording, for the message.
    """
    t = np.asarray(tr["t"], dtype=np.float64)
    if t.size < MAX_BRIDGED_PERIODS + 3:
        return
    lin = np.ones(t.size - 2, dtype=bool)
    for name in ("x_T", "theta_m", "torque_m"):
        v = np.asarray(tr[name], dtype=np.float64)
        tol = 1e-9 * float(np.max(np.abs(v))) + 1e-300
        lin &= np.abs(np.diff(v, 2)) <= tol
    # runs of True: k consecutive linear second differences = k + 1 bridged intervals
    edges = np.flatnonzero(np.diff(np.concatenate(([0], lin.astype(np.int8), [0]))))
    x = np.asarray(tr["x_T"], dtype=np.float64)
    for a, b in zip(edges[0::2], edges[1::2], strict=True):
        periods = b - a + 1
        travel = abs(x[b + 1] - x[a])
        if periods > MAX_BRIDGED_PERIODS and travel > 0:
            dt = t[b + 1] - t[a]
            raise DataError(
                f"resampling bridged a gap of {dt:.4g} s ({periods} sample periods, {travel * 1e3:.3g} mm"
                f" of travel) at t = {t[a]:.6g} s by linear interpolation: the data there would be"
                f" invented — cut the recording at the gap or record the pass again (resample = true"
                f" is for jitter: at most {MAX_BRIDGED_PERIODS} periods)",
                path=path,
                column="t",
            )


#: Radians per file unit of an angle column (for the wrap period of :func:`align_wraps`).
_RAD_PER_UNIT = {"rad": 1.0, "deg": math.pi / 180.0, "rev": 2.0 * math.pi}


def align_wraps(
    traces: list[Trace], paths: Sequence[Path], columns: Any, r_eff: float, warn: Callable[[str], None] | None
) -> list[Trace]:
    """Put every file's unwrapped motor position on one branch of a declared counter ``wrap``.

    The loader unwraps each file from its own first sample, so files that start on either side of
    a wrap come out whole counter periods apart (finding TH5: a 32-bit counter at 2^22 counts/rev
    wrapped inside the travel; the +1 passes started before the wrap, the −1 passes after it, 2^32
    counts = 19.30 m of rack apart, and no single ``offset`` could fix both — the advice was
    −3145.86 rad, then +3288.13 rad). Here the first file is put on the branch that brings its
    median TE nearest zero and every other file on the branch nearest the first one's; the shifts
    are reported in one line (``warn``) naming the files. Without a ``wrap`` on the theta_m mapping
    nothing changes.
    """
    cm = next((m for m in dict(columns).values() if m.column == "theta_m"), None)
    if cm is None or not cm.wrap:
        return traces
    per_unit = 2.0 * math.pi / cm.counts_per_rev if cm.unit == "counts" and cm.counts_per_rev else None
    per_unit = per_unit or _RAD_PER_UNIT.get(cm.unit)
    if per_unit is None:
        return traces
    period = float(cm.wrap) * per_unit * abs(float(cm.scale)) * r_eff  # [m] of TE per counter period
    med = [float(np.median(np.asarray(tr["x_T"]) - np.asarray(tr["theta_m"]) * r_eff)) for tr in traces]
    ref = med[0] - round(med[0] / period) * period
    out, moved = [], []
    for tr, m, path in zip(traces, med, paths, strict=True):
        n = round((m - ref) / period)
        out.append(
            tr if n == 0 else tr.with_columns({"theta_m": np.asarray(tr["theta_m"]) + n * period / r_eff})
        )
        if n:
            moved.append(f"{Path(path).name} ({n:+d})")
    if moved and warn is not None:
        shown = ", ".join(moved[:6]) + (", …" if len(moved) > 6 else "")
        warn(
            f"{paths[0]}: theta_m of {len(moved)} file(s) shifted by whole periods of wrap = {cm.wrap:g}"
            f" ({period / r_eff:.6g} rad each) onto the branch of {Path(paths[0]).name}: {shown} — each file"
            " is unwrapped from its own first sample, and these start on another side of the wrap"
        )
    return out


def import_campaign(
    axis_path: str | Path,
    out_dir: str | Path,
    max_load: float = 3000.0,
    warn: Callable[[str], None] | None = None,
    for_score: bool = False,
) -> tuple[CampaignManifest, PlausibilityReport]:
    """Read, check and store the recordings of an axis file as a campaign in ``out_dir``.

    Parameters
    ----------
    axis_path : str or Path
        The axis file: ``[geometry]`` (required), ``[drive]``, ``[gains]``, ``[columns]``,
        ``[sampling]`` and ``[[runs]]`` with a ``file`` each.
    out_dir : str or Path
        Directory to write (a staging directory of :class:`drivelash.io.outputs.Outputs`).
    max_load : float
        Largest training load [N] (only the plausibility's count of training loads uses it).
    warn : callable, optional
        Receives each plausibility warning as one line.
    for_score : bool
        Passes to be scored (``te score``), not fitted: the checks only a fit needs (geometric
        runs, two training loads per direction) are warnings (``check_runs``).

    Returns
    -------
    manifest, report
        The written manifest and the plausibility report.

    Raises
    ------
    ConfigError, DataError
        A bad axis file or recording, or an implausible campaign (nothing written).
    """
    axis = load_axis(axis_path)
    bench = axis.bench(require_geometry=True)
    gains = axis.cascade_gains(bench, default=False)
    runs = axis.run_list(need_files=True)
    mapping = DriveConfig(columns=axis.columns, sampling=axis.sampling)
    traces: list[Trace] = []
    records = []
    for r in runs:
        path = axis.directory / str(r.file)
        try:
            tr = load_trace(path, mapping, required=REQUIRED_COLUMNS)
        except DataError as exc:  # te import has no --resample option: name the axis file's key
            raise with_resample_hint(exc, RESAMPLE_HINT_AXIS) from None
        if any("resampled linearly" in w for w in tr.meta.get("warnings", [])):
            check_bridged_gap(tr, str(path))
        for w in tr.meta.get("warnings", []):
            if warn is not None:
                warn(w)
        traces.append(tr)
    paths = [axis.directory / str(r.file) for r in runs]
    traces = align_wraps(traces, paths, axis.columns or {}, bench.r_eff, warn)
    for r, tr in zip(runs, traces, strict=True):
        records.append(
            record_of(str(axis.directory / str(r.file)), r.kind, r.direction, r.load, r.velocity, tr)
        )
    scales = {m.column: float(m.scale) for m in (axis.columns or {}).values()}
    offsets = {m.column: float(m.offset) for m in (axis.columns or {}).values()}
    cols = axis.columns or {}
    x_unit = next(((name, str(m.unit)) for name, m in cols.items() if m.column == "x_T"), None)
    report = check_runs(
        records, bench.r_eff, bench.tooth_pitch, bench.travel, max_load=max_load, source=str(axis_path),
        column_scales=scales, x_unit=x_unit, for_score=for_score, n_t=bench.n_t, column_offsets=offsets,
        geometry=bench,
    )  # fmt: skip
    report.raise_errors()  # an error is the one line the user sees; warnings only when it goes on
    if warn is not None:
        for f in report.warnings:
            warn(f.line())

    stored = [c for c in OPTIONAL_COLUMNS if c in ("F_load", "direction") or all(c in tr for tr in traces)]
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    entries = []
    for i, (r, tr, info) in enumerate(zip(runs, traces, report.runs, strict=True)):
        v = float(r.velocity) if r.velocity else float(info["velocity_measured"])
        if r.kind == "sine":
            v = float(np.max(np.abs(np.gradient(tr["x_T"], tr["t"]))))
        cols = {c: np.asarray(tr[c], dtype=np.float64) for c in REQUIRED_COLUMNS}
        for c in stored:
            if c in tr:
                cols[c] = np.asarray(tr[c], dtype=np.float64)
        cols.setdefault("F_load", np.full(len(tr), float(r.load)))
        cols.setdefault("direction", _direction_column(tr, r.direction))
        d = {1: "pos", -1: "neg", 0: "both"}[r.direction]
        name = f"{i:03d}_{r.kind}_v{v * 1e3:.4g}mmps_F{r.load:g}N_{d}.parquet"
        meta = {
            "recording": str(r.file),
            "kind": r.kind,
            "load": r.load,
            "velocity": v,
            "direction": r.direction,
        }
        Trace({c: cols[c] for c in (*REQUIRED_COLUMNS, *stored)}, meta).save(out / name)
        entries.append(
            RunEntry(
                file=name,
                kind=r.kind,
                direction=r.direction,
                velocity=v,
                load=float(r.load),
                samples=len(tr),
                duration=float(tr["t"][-1] - tr["t"][0]) or None,
                recording=str(r.file),
            )  # fmt: skip
        )
    manifest = CampaignManifest.model_validate(
        {
            "format": FORMAT_NAME,
            "version": FORMAT_VERSION,
            "source": "imported",
            "axis": AxisBlock.of(bench, gains),
            "columns": [*REQUIRED_COLUMNS, *stored],
            "runs": entries,
            "import": {
                "axis_file": str(axis_path),
                "max_load": max_load if math.isfinite(max_load) else None,
                "plausibility": report.to_dict(),
            },
        }
    )
    write_json(out / MANIFEST, manifest.dump())
    return manifest, report


def distinct_velocities(velocities: Sequence[float]) -> list[float]:
    """Velocities [m/s] grouped within ``te score``'s pairing tolerance (``ScoreConfig.velocity_tolerance``,
    relative to a group's slowest), one median per group: measured velocities of one commanded speed
    differ by ~1e-4 (finding D8: "50, 50, 50, 99.98, 99.99, 99.99, 100" for 50 and 100 mm/s)."""
    from drivelash.te.protocol.score import ScoreConfig

    tol = ScoreConfig().velocity_tolerance
    groups: list[list[float]] = []
    for v in sorted(velocities):
        if groups and v <= groups[-1][0] * (1.0 + tol):
            groups[-1].append(v)
        else:
            groups.append([v])
    return [float(np.median(g)) for g in groups]


def summary_lines(manifest: CampaignManifest, report: PlausibilityReport) -> list[str]:
    """What ``te import`` prints: runs, loads, velocities, the geometric runs' coverage."""
    runs = manifest.runs
    speeds = distinct_velocities(manifest.velocities)
    kinds = {k: sum(r.kind == k for r in runs) for k in ("geometric", "load", "sine")}
    lines = [
        f"{len(runs)} runs ({kinds['geometric']} geometric, {kinds['load']} load, {kinds['sine']} sine);"
        f" loads {', '.join(f'{f:g}' for f in manifest.loads) or 'none'} N;"
        f" velocities {', '.join(f'{v * 1e3:.4g}' for v in speeds) or 'none'} mm/s",
    ]
    if report.valid_range:
        lo, hi = report.valid_range
        lines.append(
            f"covered by the geometric runs of both directions and the load passes: {lo:.4f} … {hi:.4f} m"
            " (a fitted model's valid range is where its no-load curves hold data within it)"
        )
    lines.append(f"plausibility: {len(report.warnings)} warning(s), no error")
    return lines
