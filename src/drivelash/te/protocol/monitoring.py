"""Monitoring the compensation while it is active (spec 02 §6, paper §VI).

With the compensation running, the path error that *would* occur without it is
estimated by applying the disturbance transfer function G_d,CL (3) to the measured
transmission error TE = x_T − x_M. The part of the TE the model does not explain,
ε = TE_measured − TE_model, passed through (3), is the path error the compensation
leaves because of model error. Both are evaluated per section of travel (100 mm);
sections where the model's path error exceeds a threshold are flagged — a trigger
for retraining (``update(stage="trees")``) or a condition-monitoring finding.

The threshold adapts to the drive: a section is flagged when its model path error
statistic exceeds ``max(floor, factor × median over all sections)``; a single bad
section cannot raise the median, so a local defect stands out. The statistic is the
peak |e| per section by default: a local defect of length ℓ ≪ 100 mm raises the
section *MAE* only by ≈ 2A v/(K_v L) (the loop suppresses slow errors, and the MAE
dilutes the rest), whereas its peak path error stands well above the model noise.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from drivelash.errors import DataError, ParameterError
from drivelash.te.runtime.table import TETable

__all__ = [
    "MonitorParams",
    "SectionReport",
    "defect_covered",
    "defect_flagged",
    "false_sections_per_metre",
    "model_te_along",
    "monitor_pass",
    "monitor_sections",
    "section_edges",
    "section_mae",
    "section_peak",
]

#: ``path_error(t [s], te [m]) -> e_x [m]``: (3) applied to a TE time series.
PathErrorFn = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class MonitorParams:
    """Settings of the section monitor; values and reasons in docs/assumptions.md.

    Parameters
    ----------
    section_length : float
        Length of a monitored section of travel [m] (paper: 100 mm).
    floor : float
        Smallest threshold [m] of the per-section ``statistic`` of the model path error (the
        peak |e| by default, or the MAE).
    factor : float
        Threshold as a multiple of the median of that statistic over the sections [-].
    min_coverage : float
        Share of a section that must be covered by samples for it to be judged [-].
    statistic : {"peak", "mae"}
        Per-section statistic of the model path error that is compared with the threshold.

    Raises
    ------
    ParameterError
        A field outside its valid range (one line naming the class and the field).
    """

    section_length: float = 0.1
    floor: float = 0.1e-6
    factor: float = 3.0
    min_coverage: float = 0.5
    statistic: str = "peak"

    def __post_init__(self) -> None:
        if self.statistic not in ("peak", "mae"):
            raise ParameterError(
                type(self).__name__, "statistic", f"must be 'peak' or 'mae', got {self.statistic!r}"
            )
        for n in ("section_length", "floor", "factor", "min_coverage"):
            v = getattr(self, n)
            if not (np.isfinite(v) and v > 0):
                raise ParameterError(type(self).__name__, n, f"must be finite and > 0, got {v!r}")


@dataclass(frozen=True)
class SectionReport:
    """Per-section monitoring result (arrays of equal length, one entry per section).

    Attributes
    ----------
    edges : numpy.ndarray
        Section boundaries [m], length n + 1.
    mae_uncompensated : numpy.ndarray
        Estimated path-error MAE without compensation, (3) applied to measured TE [m].
    mae_measured : numpy.ndarray
        Measured path-error MAE with compensation (x_d − x_T) [m].
    mae_model : numpy.ndarray
        Path-error MAE caused by model error, (3) applied to TE_meas − TE_model [m].
    peak_model : numpy.ndarray
        Peak |path error| caused by model error [m].
    improvement : numpy.ndarray
        Estimated improvement 1 − mae_measured / mae_uncompensated [-].
    threshold : float
        Threshold applied to the chosen statistic (``peak_model`` or ``mae_model``) [m].
    flagged : numpy.ndarray
        Boolean, True where the statistic exceeds the threshold.
    statistic : str
        ``"peak"`` or ``"mae"``.
    """

    edges: np.ndarray
    mae_uncompensated: np.ndarray
    mae_measured: np.ndarray
    mae_model: np.ndarray
    peak_model: np.ndarray
    improvement: np.ndarray
    threshold: float
    flagged: np.ndarray
    statistic: str = "peak"

    @property
    def judged_value(self) -> np.ndarray:
        """The per-section statistic compared with the threshold [m]."""
        return self.peak_model if self.statistic == "peak" else self.mae_model

    def flagged_intervals(self) -> list[tuple[float, float]]:
        """Flagged sections as (start, end) [m], adjacent ones merged."""
        out: list[tuple[float, float]] = []
        for i in np.flatnonzero(self.flagged):
            a, b = float(self.edges[i]), float(self.edges[i + 1])
            if out and abs(out[-1][1] - a) < 1e-12:
                out[-1] = (out[-1][0], b)
            else:
                out.append((a, b))
        return out


def section_mae(x: np.ndarray, values: np.ndarray, edges: np.ndarray, min_count: int = 1) -> np.ndarray:
    """Mean absolute value of ``values`` per position section [unit of values]; NaN if too few samples.

    Parameters
    ----------
    x : numpy.ndarray
        Positions of the samples [m].
    values : numpy.ndarray
        Signal (e.g. path error) [any unit].
    edges : numpy.ndarray
        Section boundaries [m], increasing.
    min_count : int
        Fewest samples for a section to get a value.
    """
    x = np.asarray(x, dtype=np.float64)
    v = np.abs(np.asarray(values, dtype=np.float64))
    idx = np.searchsorted(edges, x, side="right") - 1
    ok = (idx >= 0) & (idx < edges.size - 1)
    n = np.bincount(idx[ok], minlength=edges.size - 1).astype(np.float64)
    s = np.bincount(idx[ok], weights=v[ok], minlength=edges.size - 1)
    out = np.full(edges.size - 1, np.nan)
    good = n >= max(min_count, 1)
    out[good] = s[good] / n[good]
    return out


def section_peak(x: np.ndarray, values: np.ndarray, edges: np.ndarray, min_count: int = 1) -> np.ndarray:
    """Peak absolute value of ``values`` per section; NaN if too few samples (see :func:`section_mae`)."""
    x = np.asarray(x, dtype=np.float64)
    v = np.abs(np.asarray(values, dtype=np.float64))
    idx = np.searchsorted(edges, x, side="right") - 1
    ok = (idx >= 0) & (idx < edges.size - 1)
    n = np.bincount(idx[ok], minlength=edges.size - 1)
    out = np.zeros(edges.size - 1)
    np.maximum.at(out, idx[ok], v[ok])
    out[n < max(min_count, 1)] = np.nan
    return out


def section_edges(x_min: float, x_max: float, length: float) -> np.ndarray:
    """Section boundaries from ``x_min`` in steps of ``length`` up to ``x_max`` (last one partial) [m].

    The last boundary is ``x_max`` itself (one ulp above it, so that a sample at ``x_max``
    still falls into the last section of the right-open bins of :func:`section_mae`): a
    partial last section is reported as ending where the data end, not a full length later.
    """
    n = int(np.ceil((x_max - x_min) / length - 1e-9))
    edges = x_min + length * np.arange(n + 1, dtype=np.float64)
    edges[-1] = min(edges[-1], float(np.nextafter(x_max, np.inf)))
    return edges


def monitor_sections(
    t: np.ndarray,
    x_T: np.ndarray,
    te_measured: np.ndarray,
    te_model: np.ndarray,
    path_error_measured: np.ndarray,
    path_error: PathErrorFn,
    params: MonitorParams | None = None,
    edges: np.ndarray | None = None,
) -> SectionReport:
    """Judge the compensation per section from one pass recorded with compensation active.

    Parameters
    ----------
    t : numpy.ndarray
        Time [s], constant step.
    x_T : numpy.ndarray
        Table position (linear scale) [m].
    te_measured : numpy.ndarray
        Measured TE = x_T − x_M [m].
    te_model : numpy.ndarray
        The model's TE at the same instants (position, torque, flank) [m].
    path_error_measured : numpy.ndarray
        Measured path error x_d − x_T with compensation [m].
    path_error : callable
        ``path_error(t, te) -> e_x``: eq (3) applied to a TE time series [m].
    params : MonitorParams, optional
        Section length and threshold rule.
    edges : numpy.ndarray, optional
        Section boundaries [m]; default: from ``min(x_T)`` in steps of the section length.

    Returns
    -------
    SectionReport

    Raises
    ------
    DataError
        Arrays that are not 1-D of one length ≥ 4.
    """
    p = params or MonitorParams()
    arrs = [np.asarray(a, dtype=np.float64) for a in (t, x_T, te_measured, te_model, path_error_measured)]
    n = arrs[0].size
    if n < 4 or any(a.shape != (n,) for a in arrs):
        raise DataError("monitoring needs 1-D arrays of equal length (>= 4 samples)")
    t, x, te_m, te_hat, e_meas = arrs
    if edges is None:
        edges = section_edges(float(x.min()), float(x.max()), p.section_length)
    e_unc = np.asarray(path_error(t, te_m), dtype=np.float64)
    e_mod = np.asarray(path_error(t, te_m - te_hat), dtype=np.float64)
    # samples per section needed for a judgement: min_coverage of the samples an even pass would put there
    span = float(x.max() - x.min())
    per_m = n / span if span > 0 else float(n)
    min_count = int(p.min_coverage * per_m * p.section_length)
    mae_unc = section_mae(x, e_unc, edges, min_count)
    mae_meas = section_mae(x, e_meas, edges, min_count)
    mae_mod = section_mae(x, e_mod, edges, min_count)
    peak_mod = section_peak(x, e_mod, edges, min_count)
    with np.errstate(invalid="ignore", divide="ignore"):
        impr = 1.0 - mae_meas / mae_unc
    stat = peak_mod if p.statistic == "peak" else mae_mod
    valid = np.isfinite(stat)
    med = float(np.median(stat[valid])) if np.any(valid) else 0.0
    thr = max(p.floor, p.factor * med)
    flagged = valid & (np.nan_to_num(stat, nan=0.0) > thr)
    return SectionReport(
        np.asarray(edges), mae_unc, mae_meas, mae_mod, peak_mod, impr, thr, flagged, p.statistic
    )


def false_sections_per_metre(report: SectionReport, defect: tuple[float, float]) -> float:
    """Flagged sections that do not overlap the defect interval (start, end) [m], per metre of travel."""
    a, b = defect
    lo, hi = report.edges[:-1], report.edges[1:]
    overlap = (hi > a) & (lo < b)
    false = int(np.count_nonzero(report.flagged & ~overlap))
    judged = np.isfinite(report.mae_model)
    length = float(np.sum((hi - lo)[judged]))
    return false / length if length > 0 else float("nan")


def defect_covered(report: SectionReport, defect: tuple[float, float]) -> bool:
    """True when every judged section overlapping the defect interval (start, end) [m] is flagged."""
    a, b = defect
    lo, hi = report.edges[:-1], report.edges[1:]
    core = (hi > a) & (lo < b) & np.isfinite(report.mae_model)
    return bool(np.any(core) and np.all(report.flagged[core]))


def defect_flagged(report: SectionReport, defect: tuple[float, float]) -> bool:
    """True when any section overlapping the defect interval (start, end) [m] is flagged."""
    a, b = defect
    lo, hi = report.edges[:-1], report.edges[1:]
    return bool(np.any(report.flagged & (hi > a) & (lo < b)))


def model_te_along(table: TETable, res: dict[str, np.ndarray]) -> np.ndarray:
    """The compensator's model TE at the recorded positions, torques and flanks [m]."""
    out = np.empty(res["x_T"].size)
    for d in (1, -1):
        m = res["flank"] == d
        if np.any(m):
            out[m] = table.predict(res["x_T"][m], res["tq_model"][m], d)
    return out


def monitor_pass(sim: Any, table: TETable, res: dict[str, np.ndarray], v: float, edges: np.ndarray,
                 params: MonitorParams | None = None) -> SectionReport:  # fmt: skip
    """Run the section monitor on a compensated pass (constant-velocity part).

    Parameters
    ----------
    sim : RackAxisSimulator
        The bench the pass ran on (``r_eff`` [m], ``J_s`` [kg·m²], controller gains).
    table : TETable
        The compensator's table (the model TE along the pass).
    res : dict of numpy.ndarray
        The pass (:func:`~drivelash.te.protocol.passes.run_pass`): ``t`` [s], ``x_T``,
        ``x_d`` [m], ``v_d`` [m/s], ``theta_m`` [rad], ``e`` [m], ….
    v : float
        The pass's constant set speed [m/s]: samples at |v_d| = v are judged.
    edges : numpy.ndarray
        Section boundaries [m].
    params : MonitorParams, optional
        Threshold rule.
    """
    from drivelash.control.path_error import predict_path_error

    J_s = float(sim.bench.J_s)
    gains = sim.gains
    te_meas = sim.bench.te_from_measurement(res["x_T"], res["theta_m"])  # eq. (1), one implementation
    te_hat = model_te_along(table, res)
    m = np.abs(np.abs(res["v_d"]) - v) < 1e-9 * max(v, 1.0)
    idx = np.flatnonzero(m)
    sl = slice(idx[0], idx[-1] + 1)

    def pe(t: np.ndarray, te: np.ndarray) -> np.ndarray:
        return predict_path_error(te, t, J_s, gains)

    return monitor_sections(res["t"][sl], res["x_T"][sl], te_meas[sl], te_hat[sl], res["e"][sl], pe,
                            params, edges)  # fmt: skip
