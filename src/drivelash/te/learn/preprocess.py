"""Preprocessing of rack-and-pinion recordings for transmission-error learning (spec 02 §3).

Each step is one plain function with one job, testable on its own:

1. :func:`monotone_part` / :func:`resample_on_grid` — keep the samples of one
   direction of travel and interpolate every column over table position on a
   fixed grid (50 µm) aligned to multiples of the step, so all runs share grid
   points;
2. :func:`transmission_error` — TE (1) = x_T − θ_M d_p / (2 i_PG);
3. :func:`geometric_curve` — the no-load TE per direction (averaged over the
   no-load runs) as a uniform-grid lookup table :class:`GeometricCurve`;
4. :func:`deformation` — TE_def = TE − TE_geo;
5. :func:`remove_offset` — constant offset removal;
6. :func:`lowpass` — zero-phase Butterworth low-pass over position, cut-off
   :func:`mesh_cutoff` = 3 × tooth-meshing spatial frequency;
7. :func:`~drivelash.te.learn.features.bump_features` — tooth-meshing features M_j,
   eqs (4)–(5) (in :mod:`drivelash.te.learn.features`).

:class:`TEPipeline` chains them (a composite of small replaceable parts, like
pysindy): ``pipeline.geometric(no_load_traces)`` then
``pipeline.process(trace, geo)`` → :class:`RunData`, and
``pipeline.design_matrix(x_T, torque)`` → the model inputs
``[x_T, torque, M_1 … M_nt]``.

Units: positions in metres, torque in N·m, TE in metres everywhere in this module
except :attr:`RunData.te_def_um`, the learning target, in micrometres.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drivelash.errors import DataError, ParameterError
from drivelash.te.learn.features import bump_features

__all__ = [
    "GRID_STEP",
    "LOAD_TRIM",
    "UM",
    "GearGeometry",
    "GeometricCurve",
    "RunData",
    "TEPipeline",
    "deformation",
    "direction_key",
    "geometric_curve",
    "lowpass",
    "mesh_cutoff",
    "mesh_frequency",
    "monotone_part",
    "process_pass",
    "remove_offset",
    "resample_on_grid",
    "transmission_error",
    "trim_ends",
]

#: Resampling step over table position [m] (paper §IV: 50 µm).
GRID_STEP = 50e-6
#: Travel [m] dropped at both ends of each load run (:attr:`TEPipeline.trim`).
LOAD_TRIM = 30e-3

#: Conversion factor metres → micrometres.
UM = 1e6


def direction_key(direction: int | float) -> str:
    """``"pos"`` for direction +1, ``"neg"`` for −1 (the keys of per-direction models).

    Parameters
    ----------
    direction : int or float
        Any positive value is ``"pos"``, any negative one ``"neg"``.

    Raises
    ------
    DataError
        ``direction`` is 0 (or NaN).
    """
    if direction > 0:
        return "pos"
    if direction < 0:
        return "neg"
    raise DataError(f"direction must be +1 or -1, got {direction!r}", column="direction")


# ---------------------------------------------------------------------------
# 1. resampling
# ---------------------------------------------------------------------------
def monotone_part(x: np.ndarray, direction: int) -> np.ndarray:
    """Indices of the samples where the position strictly advances in ``direction``.

    A sample is kept if its position exceeds (direction +1) or undercuts (−1) all
    earlier kept samples: standstill, jitter and backward creep are dropped.

    Parameters
    ----------
    x : numpy.ndarray
        Table position x_T [m], time-ordered.
    direction : int
        +1 or −1.

    Returns
    -------
    numpy.ndarray
        Integer indices into ``x`` (increasing).
    """
    x = np.asarray(x, dtype=np.float64)
    s = x * (1.0 if direction > 0 else -1.0)
    if s.size == 0:
        return np.zeros(0, dtype=np.int64)
    prev = np.maximum.accumulate(np.concatenate(([-np.inf], s[:-1])))
    return np.flatnonzero(s > prev)


def resample_on_grid(
    x: np.ndarray, columns: Mapping[str, np.ndarray], step: float = GRID_STEP
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Linear interpolation of ``columns`` over position on the grid ``k · step``.

    Parameters
    ----------
    x : numpy.ndarray
        Strictly monotone table position [m] (increasing or decreasing).
    columns : Mapping[str, numpy.ndarray]
        Columns sampled at ``x`` (any units; interpolated linearly).
    step : float
        Grid step [m].

    Returns
    -------
    grid : numpy.ndarray
        Increasing grid positions [m], integer multiples of ``step`` inside ``[min x, max x]``.
    resampled : dict
        Each column on ``grid``.
    """
    if not step > 0:
        raise ParameterError("resample_on_grid", "step", f"must be > 0, got {step!r}")
    x = np.asarray(x, dtype=np.float64)
    if x.size < 2:
        raise DataError("fewer than two samples to resample over position", column="x_T")
    order = np.argsort(x, kind="stable")
    xs = x[order]
    if np.any(np.diff(xs) <= 0):
        raise DataError("position must be strictly monotone to resample", column="x_T")
    k0 = int(np.ceil(xs[0] / step - 1e-9))
    k1 = int(np.floor(xs[-1] / step + 1e-9))
    grid = np.arange(k0, k1 + 1, dtype=np.float64) * step
    grid = grid[(grid >= xs[0]) & (grid <= xs[-1])]
    out = {name: np.interp(grid, xs, np.asarray(v, dtype=np.float64)[order]) for name, v in columns.items()}
    return grid, out


def trim_ends(grid: np.ndarray, columns: Mapping[str, np.ndarray], length: float) -> tuple[np.ndarray, dict]:
    """Drop ``length`` [m] of travel at both ends (backlash traversal, acceleration)."""
    if length <= 0:
        return grid, dict(columns)
    keep = (grid >= grid[0] + length) & (grid <= grid[-1] - length)
    return grid[keep], {k: np.asarray(v)[keep] for k, v in columns.items()}


# ---------------------------------------------------------------------------
# 2.–5. transmission error, geometric curve, deformation, offset
# ---------------------------------------------------------------------------
def transmission_error(x_T: np.ndarray, theta_m: np.ndarray, d_p: float, i_pg: float) -> np.ndarray:
    """TE (1) = x_T − x_M with x_M = θ_M d_p / (2 i_PG).

    Parameters
    ----------
    x_T : numpy.ndarray
        Table position from the linear scale [m].
    theta_m : numpy.ndarray
        Motor angle [rad].
    d_p : float
        Pinion pitch diameter [m].
    i_pg : float
        Gearbox ratio (motor turns per pinion turn) [-].

    Returns
    -------
    numpy.ndarray
        TE [m].
    """
    return np.asarray(x_T, dtype=np.float64) - np.asarray(theta_m, dtype=np.float64) * d_p / (2.0 * i_pg)


@dataclass(frozen=True)
class GeometricCurve:
    """No-load transmission error of one direction on a uniform position grid.

    Parameters
    ----------
    x0 : float
        Position of the first value [m].
    step : float
        Grid step [m].
    te : numpy.ndarray
        TE_geo [m] at ``x0 + k·step``; outside the grid the end values hold.
    """

    x0: float
    step: float
    te: np.ndarray

    def __call__(self, x: np.ndarray | float) -> np.ndarray:
        """TE_geo [m] at positions ``x`` [m] (linear interpolation, clamped)."""
        xs = self.x0 + self.step * np.arange(self.te.size)
        return np.interp(np.asarray(x, dtype=np.float64), xs, self.te)

    @property
    def x(self) -> np.ndarray:
        """Grid positions [m]."""
        return self.x0 + self.step * np.arange(self.te.size)

    def span(self) -> tuple[float, float]:
        """First and last grid position [m]: where the curve holds measured data (held flat outside)."""
        return float(self.x0), float(self.x0 + self.step * (self.te.size - 1))


def geometric_curve(
    grids: Sequence[np.ndarray], tes: Sequence[np.ndarray], step: float = GRID_STEP
) -> GeometricCurve:
    """Average of no-load TE curves (one direction) on their common grid.

    Parameters
    ----------
    grids : sequence of numpy.ndarray
        Grid positions [m] of each no-load run (multiples of ``step``).
    tes : sequence of numpy.ndarray
        TE [m] of each run on its grid.
    step : float
        Grid step [m].

    Returns
    -------
    GeometricCurve
        The mean over runs at every grid point covered by at least one run.
    """
    if len(grids) == 0:
        raise DataError("no no-load run for a direction: cannot build the geometric curve")
    k = [np.rint(g / step).astype(np.int64) for g in grids]
    k0 = min(int(a[0]) for a in k)
    k1 = max(int(a[-1]) for a in k)
    acc = np.zeros(k1 - k0 + 1)
    cnt = np.zeros(k1 - k0 + 1)
    for ki, te in zip(k, tes, strict=True):
        acc[ki - k0] += te
        cnt[ki - k0] += 1
    ok = cnt > 0
    xs = (np.arange(k0, k1 + 1) * step)[ok]
    te = acc[ok] / cnt[ok]
    full = np.interp(np.arange(k0, k1 + 1) * step, xs, te)
    return GeometricCurve(float(k0 * step), float(step), full)


def deformation(grid: np.ndarray, te: np.ndarray, geo: GeometricCurve) -> np.ndarray:
    """TE_def = TE − TE_geo(x) [m] on ``grid`` [m]."""
    return np.asarray(te, dtype=np.float64) - geo(grid)


def remove_offset(values: np.ndarray, mode: str = "mean") -> np.ndarray:
    """Remove a constant offset: ``"mean"`` subtracts the mean, ``"none"`` returns a copy."""
    v = np.asarray(values, dtype=np.float64)
    if mode == "mean":
        return v - v.mean()
    if mode == "none":
        return v.copy()
    raise ParameterError("remove_offset", "mode", f"must be 'mean' or 'none', got {mode!r}")


# ---------------------------------------------------------------------------
# 6. zero-phase low-pass over position
# ---------------------------------------------------------------------------
def mesh_frequency(d_p: float, n_t: int) -> float:
    """Tooth-meshing spatial frequency n_t / (π d_p) [1/m] (one per tooth pitch)."""
    return n_t / (np.pi * d_p)


def mesh_cutoff(d_p: float, n_t: int, factor: float = 3.0) -> float:
    """Low-pass cut-off = ``factor`` × tooth-meshing spatial frequency [1/m] (paper: 3)."""
    return factor * mesh_frequency(d_p, n_t)


def lowpass(values: np.ndarray, step: float, cutoff: float, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth low-pass of a signal sampled over position.

    Parameters
    ----------
    values : numpy.ndarray
        Signal on a uniform grid.
    step : float
        Grid step [m].
    cutoff : float
        Cut-off spatial frequency [1/m] (−3 dB of each pass; forward-backward doubles the order).
    order : int
        Butterworth order of one pass.

    Returns
    -------
    numpy.ndarray
        Filtered signal, no phase shift (``scipy.signal.sosfiltfilt``).

    Raises
    ------
    ParameterError
        ``cutoff`` not in (0, 1/(2 step)) [1/m].
    DataError
        Fewer than 8 grid points.
    """
    from scipy.signal import butter, sosfiltfilt

    nyq = 0.5 / step
    if not 0 < cutoff < nyq:
        raise ParameterError("lowpass", "cutoff", f"must be in (0, {nyq:g}) 1/m for step {step:g} m")
    sos = butter(order, cutoff / nyq, output="sos")
    v = np.asarray(values, dtype=np.float64)
    padlen = min(3 * (2 * len(sos) + 1) * 10, v.size - 1)
    if v.size < 8:
        raise DataError(f"only {v.size} grid points: too short to filter")
    return sosfiltfilt(sos, v, padlen=padlen)


# ---------------------------------------------------------------------------
# the composite
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class GearGeometry:
    """The numbers of the drive that preprocessing needs.

    Parameters
    ----------
    d_p : float
        Pinion pitch diameter [m].
    n_t : int
        Pinion teeth [-].
    i_pg : float
        Gearbox ratio [-].
    eps : float
        Contact ratio ε [-] (used in the bump features).

    Raises
    ------
    ParameterError
        A field outside its valid range (one line naming the class and the field).
    """

    d_p: float
    n_t: int
    i_pg: float
    eps: float

    def __post_init__(self) -> None:
        for name in ("d_p", "i_pg", "eps"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
                raise ParameterError("GearGeometry", name, f"must be finite and > 0, got {v!r}")
        if not (isinstance(self.n_t, (int, np.integer)) and self.n_t >= 2):
            raise ParameterError("GearGeometry", "n_t", f"must be an integer >= 2, got {self.n_t!r}")

    @classmethod
    def from_bench(cls, bench: Any) -> GearGeometry:
        """Read ``d_p``, ``n_t``, ``i_PG``/``i_pg`` and ``eps``/``contact_ratio`` from a bench object.

        Parameters
        ----------
        bench : object
            A :class:`~drivelash.physics.rack_pinion.RackPinionBench` or any object with
            ``d_p`` [m], ``n_t``, ``i_PG`` (or ``i_pg``) and ``eps`` (or ``contact_ratio``).
        """

        def pick(*names: str) -> Any:
            for n in names:
                if hasattr(bench, n):
                    v = getattr(bench, n)
                    return v() if callable(v) else v
            raise ParameterError(type(bench).__name__, names[0], "missing on the bench object")

        return cls(
            d_p=float(pick("d_p")),
            n_t=int(pick("n_t")),
            i_pg=float(pick("i_PG", "i_pg")),
            eps=float(pick("epsilon", "eps")),
        )

    def to_dict(self) -> dict[str, float | int]:
        """JSON-serialisable form."""
        return {"d_p": self.d_p, "n_t": int(self.n_t), "i_pg": self.i_pg, "eps": self.eps}


@dataclass
class RunData:
    """One processed run of one direction on the position grid.

    Attributes
    ----------
    x : numpy.ndarray
        Grid positions [m].
    torque : numpy.ndarray
        Motor torque [N·m], low-passed like the target.
    te_def_um : numpy.ndarray
        Deformation TE_def [µm] (offset removed, low-passed): the learning target.
    direction : int
        +1 or −1.
    meta : dict
        Provenance (load [N], velocity [m/s], run name, …), plus ``offset_um``: the
        constant removed from TE_def [µm], and ``torque_mean`` [N·m].
    """

    x: np.ndarray
    torque: np.ndarray
    te_def_um: np.ndarray
    direction: int
    meta: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class TEPipeline:
    """Chains the preprocessing steps; every number is a field (all replaceable).

    Parameters
    ----------
    geometry : GearGeometry
        Drive geometry.
    step : float
        Resampling grid step [m] (paper: 50 µm).
    cutoff_factor : float
        Low-pass cut-off in multiples of the tooth-meshing spatial frequency (paper: 3).
    filter_order : int
        Butterworth order per pass.
    offset : str
        ``"mean"`` (remove each run's mean TE_def) or ``"none"``.
    trim : float
        Travel [m] dropped at both ends of each load run (acceleration ramps, flank
        change, filter edges).
    geo_trim : float
        Travel [m] dropped at both ends of each no-load (geometric) run.
    """

    geometry: GearGeometry
    step: float = GRID_STEP
    cutoff_factor: float = 3.0
    filter_order: int = 4
    offset: str = "mean"
    trim: float = LOAD_TRIM
    geo_trim: float = 5e-3

    @property
    def cutoff(self) -> float:
        """Low-pass cut-off [1/m]."""
        return mesh_cutoff(self.geometry.d_p, self.geometry.n_t, self.cutoff_factor)

    def _grid_run(self, columns: Mapping[str, np.ndarray], direction: int) -> tuple[np.ndarray, dict]:
        x = np.asarray(columns["x_T"], dtype=np.float64)
        idx = monotone_part(x, direction)
        if "direction" in columns:
            d = np.asarray(columns["direction"])[idx]
            idx = idx[np.sign(d) == np.sign(direction)]
        if idx.size < 16:
            raise DataError(f"fewer than 16 moving samples in direction {direction:+d}", column="x_T")
        te = transmission_error(
            x[idx], np.asarray(columns["theta_m"])[idx], self.geometry.d_p, self.geometry.i_pg
        )
        grid, cols = resample_on_grid(
            x[idx], {"te": te, "torque": np.asarray(columns["torque_m"], dtype=np.float64)[idx]}, self.step
        )
        return grid, cols

    def geometric(self, no_load: Sequence[Mapping[str, np.ndarray]], direction: int) -> GeometricCurve:
        """TE_geo of one direction from its no-load runs (low-passed like the target).

        Parameters
        ----------
        no_load : sequence of column mappings
            Each needs ``x_T`` [m], ``theta_m`` [rad], ``torque_m`` [N·m] (and optionally ``direction``).
        direction : int
            +1 or −1.
        """
        grids, tes = [], []
        for cols in no_load:
            g, c = self._grid_run(cols, direction)
            g, c = trim_ends(g, c, self.geo_trim)
            grids.append(g)
            tes.append(c["te"])
        geo = geometric_curve(grids, tes, self.step)
        return GeometricCurve(geo.x0, geo.step, lowpass(geo.te, self.step, self.cutoff, self.filter_order))

    def process(
        self,
        columns: Mapping[str, np.ndarray],
        direction: int,
        geo: GeometricCurve,
        meta: Mapping[str, Any] | None = None,
        span: tuple[float, float] | None = None,
    ) -> RunData:
        """Resample → TE → TE_def → low-pass → trim → offset removal, for one run and direction.

        Parameters
        ----------
        columns : mapping of str to numpy.ndarray
            One run: ``x_T`` [m], ``theta_m`` [rad], ``torque_m`` [N·m] (and ``direction``).
        direction : int
            The direction whose part of the run is processed, +1 or −1.
        geo : GeometricCurve
            TE_geo of that direction (subtracted: TE_def = TE − TE_geo).
        meta : mapping, optional
            Provenance copied into the result's ``meta``.
        span : tuple of float, optional
            ``(x_min, x_max)`` [m] where ``geo`` holds data: an end of the pass reaching more
            than ``trim`` beyond it is cut there before the low-pass (then trimmed like any end),
            so no row is built on a held-flat TE_geo; ``meta["cropped_m"]`` records the travel
            cut. A pass reaching at most ``trim`` beyond ``span`` (the usual: runs over the same
            travel, the no-load curve trimmed by ``geo_trim`` only) is processed as without it.
            Default: the whole pass.

        Raises
        ------
        DataError
            Fewer than 16 samples moving in ``direction``, or a run shorter than twice the trim
            length.
        """
        grid, c = self._grid_run(columns, direction)
        m = dict(meta or {})
        if span is not None:
            # an end reaching more than ``trim`` beyond the span is cut at the span (before the
            # low-pass: no held-flat TE_geo enters the filter; the trim below then drops the
            # filter's edge); a pass reaching at most ``trim`` beyond it is processed as before
            tol = 1e-9
            lo = span[0] if grid[0] < span[0] - self.trim - tol else -np.inf
            hi = span[1] if grid[-1] > span[1] + self.trim + tol else np.inf
            keep = (grid >= lo - tol) & (grid <= hi + tol)
            if not keep.all():
                m["cropped_m"] = float((~keep).sum() * self.step)
                grid, c = grid[keep], {k: v[keep] for k, v in c.items()}
                if grid.size < 16:
                    raise DataError(
                        f"the pass lies outside the no-load curve ({span[0]:.4f} ... {span[1]:.4f} m)",
                        column="x_T",
                    )
        # low-pass the whole pass, then drop the ends (ramps, flank change, filter edges);
        # the offset is removed over the kept part (a constant passes the low-pass unchanged)
        filt = {
            "def": lowpass(deformation(grid, c["te"], geo), self.step, self.cutoff, self.filter_order),
            "torque": lowpass(c["torque"], self.step, self.cutoff, self.filter_order),
        }
        travel = float(grid[-1] - grid[0]) if grid.size else 0.0
        grid, filt = trim_ends(grid, filt, self.trim)
        if grid.size < 8:
            raise DataError(
                f"the pass in direction {int(np.sign(direction)):+d} covers {travel * 1e3:.4g} mm at constant"
                f" velocity, too short for the {self.trim * 1e3:.4g} mm trimmed at each end",
                column="x_T",
            )
        te_def = remove_offset(filt["def"], self.offset)
        torque = filt["torque"]
        m["offset_um"] = float(np.mean(filt["def"]) * UM) if self.offset == "mean" else 0.0
        m["torque_mean"] = float(np.mean(torque))
        return RunData(grid, torque, te_def * UM, int(np.sign(direction)), m)

    def design_matrix(self, x_T: np.ndarray, torque: np.ndarray) -> np.ndarray:
        """Model inputs ``[x_T [m], torque [N·m], M_1 … M_nt]``, shape ``(n, 2 + n_t)``.

        Parameters
        ----------
        x_T : numpy.ndarray
            Table positions [m].
        torque : numpy.ndarray
            Motor torque [N·m], one per position.
        """
        x_T = np.asarray(x_T, dtype=np.float64).reshape(-1)
        torque = np.broadcast_to(np.asarray(torque, dtype=np.float64), x_T.shape)
        g = self.geometry
        return np.column_stack([x_T, torque, bump_features(x_T, g.n_t, g.d_p, g.eps)])

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable configuration."""
        return {
            "geometry": self.geometry.to_dict(),
            "step": self.step,
            "cutoff_factor": self.cutoff_factor,
            "filter_order": self.filter_order,
            "offset": self.offset,
            "trim": self.trim,
            "geo_trim": self.geo_trim,
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> TEPipeline:
        """Inverse of :meth:`to_dict`.

        Parameters
        ----------
        d : mapping
            What :meth:`to_dict` wrote.
        """
        g = d["geometry"]
        return cls(
            GearGeometry(float(g["d_p"]), int(g["n_t"]), float(g["i_pg"]), float(g["eps"])),
            step=float(d["step"]),
            cutoff_factor=float(d["cutoff_factor"]),
            filter_order=int(d["filter_order"]),
            offset=str(d["offset"]),
            trim=float(d["trim"]),
            geo_trim=float(d.get("geo_trim", 5e-3)),
        )


def process_pass(
    pipeline: Any,
    run: Any,
    direction: int,
    geo: Any,
    meta: Mapping[str, Any],
    span: tuple[float, float] | None = None,
) -> RunData:
    """``pipeline.process`` of one campaign pass (:class:`~drivelash.te.protocol.campaign` run),
    its error naming the pass's file (``te update`` said "column 'x_T': run shorter than twice the
    trim length" for a 30 mm pass, without saying which of the passes; session 36)."""
    try:
        return pipeline.process(run.trace().columns, direction, geo, meta=meta, span=span)
    except DataError as exc:
        if exc.path:
            raise
        raise DataError(exc.problem, path=str(run.path), column=exc.column, row=exc.row) from None
