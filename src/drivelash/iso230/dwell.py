"""Dwell detection: the stationary stops of an ISO 230-2 test in a raw time series.

Input: time t, commanded position P_cmd, reference measurement P_actual (laser or linear
scale at the tool) and optionally the axis's own position P_axis. Only P_cmd decides
where the dwells are, so noise and drift of the measurement cannot move them.

The rule (numbers in :class:`DwellParams`, defaults in ``docs/assumptions.md``):

1. Velocity of the commanded position by a central difference over ±``T_v``:
   v_k = (P_cmd[k+w] − P_cmd[k−w]) / (t[k+w] − t[k−w]), w = round(T_v / T_s).
2. Feed speed v_feed = 99th percentile of |v|; a sample is *still* when
   |v_k| ≤ ``v_rel`` · v_feed.
3. A dwell is a run of still samples lasting at least ``T_dwell_min``. Shorter stops
   (the turn-around of an overshoot) are motion.
4. The first ``T_settle`` of the dwell (settling of the axis after the stop) and the
   last ``T_guard`` (before the next move) are skipped; the deviation is the mean of
   P_actual − P_cmd over the remainder (and of P_actual − P_axis when P_axis is given).
   The commanded position must be constant over that remainder (range ≤ the target
   tolerance), else the stop is ambiguous (a slow move) and refused.
5. Approach direction: the sign of the commanded velocity at the last moving sample
   before the dwell (so an overshoot-and-return counts as the direction of the return).
   A dwell with no motion before it (the recording starts at rest) has no approach
   direction and is skipped with a warning.
6. Targets: the dwells' commanded positions are clustered (gaps larger than
   ``target_tolerance`` × the travel separate targets); with a nominal target list each
   cluster must match one nominal target within that tolerance. Every target must have
   the same number of dwells in each direction; run j is the j-th dwell in time order.
   Any violation is refused with a one-line message naming the target.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from drivelash.errors import NO_LINES, DataError, DataRows, ParameterError
from drivelash.iso230.evaluate import DOWN, MAX_ABS, UP, Approaches, _fmt_pos, approaches_from_rows

__all__ = [
    "Drift",
    "DwellParams",
    "Dwells",
    "detect_dwells",
    "estimate_drift",
    "settle_dwells",
    "settling_trend",
]

#: Relative tolerance of the check T_dwell_min >= T_settle + T_guard + T_avg_min: the sum of
#: decimal seconds carries float round-off (0.8 + 0.05 + 0.1 = 0.9500000000000001), far below
#: one sample of any recording (docs/assumptions.md, "ISO 230-2").
DWELL_SUM_RTOL = 1e-9

#: A settling signature D (:func:`settling_trend`) counts as "the reading still moves" when it
#: exceeds this many of its own standard uncertainties *and* the standard uncertainty of B̄ (the
#: bias it leaves in B̄ is about D) *and* :data:`SETTLE_FLOOR_FRACTION` of the travel. Measured
#: (docs/assumptions.md, "ISO 230-2"): settled recordings give |D|/u_D ≤ 0.5; the tester's
#: slow axis (Kv 16.7 1/s) 85 at T_settle 0.25 s, 8.4 at 0.6 s (B̄ still 9 u off), 1.9 at 0.7 s.
SETTLE_SIGNIFICANCE = 3.0

#: Floor of that rule as a fraction of the travel [-]: 1 % of a laser's environmental
#: uncertainty (≈ 1 ppm of the distance), so noise-free simulations are not flagged for
#: nanometres.
SETTLE_FLOOR_FRACTION = 1e-8

#: Step [s] by which T_settle is lengthened until the windows are settled.
SETTLE_STEP = 0.05


@dataclass(frozen=True)
class DwellParams:
    """How dwells are found in a time series (the rule in the module docstring).

    Parameters
    ----------
    T_dwell_min : float
        Shortest stop counted as a dwell [s].
    T_settle : float
        Settling time skipped at the start of each dwell [s].
    T_guard : float
        Time skipped at the end of each dwell, before the next move [s].
    T_avg_min : float
        Shortest averaging window left after the skips [s].
    T_v : float
        Half-width of the central difference for the commanded velocity [s].
    v_rel : float
        Still threshold as a fraction of the feed speed (99th percentile of |v|) [-].
    target_tolerance : float
        Dwell positions closer than this fraction of the travel are one target; also
        the largest distance to a nominal target [-].

    Raises
    ------
    ParameterError
        A field outside its valid range (one line naming the class and the field).
    """

    T_dwell_min: float = 0.5
    T_settle: float = 0.25
    T_guard: float = 0.05
    T_avg_min: float = 0.1
    T_v: float = 0.01
    v_rel: float = 0.01
    target_tolerance: float = 1e-4

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if not (isinstance(v, int | float) and math.isfinite(v)):
                raise ParameterError("DwellParams", f.name, f"must be a finite number, got {v!r}")
        for name in ("T_dwell_min", "T_avg_min", "T_v", "v_rel", "target_tolerance"):
            if not getattr(self, name) > 0:
                raise ParameterError("DwellParams", name, f"must be > 0, got {getattr(self, name)!r}")
        for name in ("T_settle", "T_guard"):
            if getattr(self, name) < 0:
                raise ParameterError("DwellParams", name, f"must be >= 0, got {getattr(self, name)!r}")
        if not self.v_rel < 1:
            raise ParameterError("DwellParams", "v_rel", f"must be < 1, got {self.v_rel!r}")
        need = self.T_settle + self.T_guard + self.T_avg_min
        if self.T_dwell_min < need * (1.0 - DWELL_SUM_RTOL):
            raise ParameterError(
                "DwellParams",
                "T_dwell_min",
                f"must be >= T_settle + T_guard + T_avg_min = {need:g} s, got {self.T_dwell_min:g}",
            )


@dataclass(frozen=True)
class Dwells:
    """The dwells found, one row per approach, and the approaches they make.

    Attributes
    ----------
    t_start, t_end : numpy.ndarray
        Start and end of each dwell (still samples) [s].
    t_avg_start, t_avg_end : numpy.ndarray
        The averaging window after the settling and guard skips [s].
    P_cmd : numpy.ndarray
        Commanded position during the dwell [m or rad].
    target : numpy.ndarray
        Target position the dwell belongs to [m or rad].
    direction : numpy.ndarray
        +1 (↑) or −1 (↓).
    run : numpy.ndarray
        Run number within its target and direction (1, 2, …).
    deviation : numpy.ndarray
        Mean of P_actual − P_cmd over the window [m or rad].
    deviation_axis : numpy.ndarray or None
        Mean of P_actual − P_axis over the window, when P_axis is given.
    approaches : Approaches
        The reference deviations arranged by target, direction and run.
    approaches_axis : Approaches or None
        The same for P_actual − P_axis.
    v_feed, v_threshold : float
        Feed speed and still threshold [m/s or rad/s].
    warnings : list of str
        Dwells skipped and why.
    trend : numpy.ndarray or None
        Mean of P_actual − P_cmd over the second half of the window minus that over the
        first half [m or rad]: how much the reading still moves while it is averaged.
    """

    t_start: np.ndarray
    t_end: np.ndarray
    t_avg_start: np.ndarray
    t_avg_end: np.ndarray
    P_cmd: np.ndarray
    target: np.ndarray
    direction: np.ndarray
    run: np.ndarray
    deviation: np.ndarray
    deviation_axis: np.ndarray | None
    approaches: Approaches
    approaches_axis: Approaches | None
    v_feed: float
    v_threshold: float
    warnings: list[str] = field(default_factory=list)
    trend: np.ndarray | None = None

    def to_dict(self) -> dict[str, Any]:
        """The dwell table as JSON-ready lists (SI units)."""
        out: dict[str, Any] = {
            "count": int(self.t_start.size),
            "v_feed": self.v_feed,
            "v_threshold": self.v_threshold,
        }
        for k in ("t_start", "t_end", "t_avg_start", "t_avg_end", "P_cmd", "target", "deviation"):
            out[k] = getattr(self, k).tolist()
        out["direction"] = self.direction.astype(int).tolist()
        out["run"] = self.run.astype(int).tolist()
        if self.deviation_axis is not None:
            out["deviation_axis"] = self.deviation_axis.tolist()
        return out


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and stop (exclusive) indices of the runs of True in ``mask``."""
    edges = np.diff(np.concatenate(([0], mask.view(np.int8), [0])))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)


def _velocity(t: np.ndarray, P: np.ndarray, w: int) -> np.ndarray:
    idx = np.arange(t.size)
    hi = np.minimum(idx + w, t.size - 1)
    lo = np.maximum(idx - w, 0)
    return (P[hi] - P[lo]) / (t[hi] - t[lo])


def _assign(
    arr: np.ndarray, nominal: np.ndarray | None, tol: float, travel: float, p: DwellParams
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Target label of every dwell, the target positions and which dwells match none."""
    from drivelash.iso230.evaluate import cluster_targets

    pos = arr[:, 4]
    if nominal is None:
        span = max(float(np.ptp(pos)), 1e-300)
        centres, labels = cluster_targets(pos, tol / span)
        return labels, centres, np.zeros(pos.size, dtype=bool)
    idx = np.clip(np.searchsorted(nominal, pos), 1, max(nominal.size - 1, 1))
    cand = np.stack([idx - 1, np.minimum(idx, nominal.size - 1)], axis=1)
    dist = np.abs(nominal[cand] - pos[:, None])
    labels = cand[np.arange(pos.size), np.argmin(dist, axis=1)]
    return labels, nominal, np.abs(nominal[labels] - pos) > tol


def detect_dwells(
    t: np.ndarray,
    P_cmd: np.ndarray,
    P_actual: np.ndarray,
    P_axis: np.ndarray | None = None,
    *,
    params: DwellParams | None = None,
    nominal: np.ndarray | None = None,
    unit: str = "m",
    source: str = "",
    rows: DataRows = NO_LINES,
) -> Dwells:
    """Find the dwells of a bidirectional positioning test and arrange its approaches.

    Parameters
    ----------
    t : numpy.ndarray
        Time, increasing [s].
    P_cmd : numpy.ndarray
        Commanded position [m or rad].
    P_actual : numpy.ndarray
        Reference measurement of the position reached [m or rad].
    P_axis : numpy.ndarray, optional
        The axis's own position feedback [m or rad].
    params : DwellParams, optional
        Detection parameters (defaults when omitted).
    nominal : numpy.ndarray, optional
        Nominal target positions [m or rad]; every dwell must match one, every one
        must be reached.
    unit : str
        ``"m"`` or ``"rad"`` (messages and the result).
    source : str
        File name for messages.
    rows : DataRows, optional
        Where the samples' rows are in ``source`` (``Trace.rows``), for messages.

    Returns
    -------
    Dwells

    Raises
    ------
    DataError
        No motion, no dwell, a slow move taken for a dwell, a dwell matching no nominal
        target, a target without dwells, or unequal dwell counts — one line naming the
        target (or the time) and the problem.
    """
    p = params or DwellParams()
    t = np.asarray(t, dtype=np.float64)
    P_cmd = np.asarray(P_cmd, dtype=np.float64)
    P_actual = np.asarray(P_actual, dtype=np.float64)
    if t.size < 3:
        raise DataError(f"only {t.size} samples", path=source, column="t")
    for name, arr in (("t", t), ("P_cmd", P_cmd), ("P_actual", P_actual), ("P_axis", P_axis)):
        if arr is None:
            continue
        bad = ~np.isfinite(arr) | (np.abs(arr) > MAX_ABS)
        if bad.any():
            raise DataError(
                f"NaN, infinite or implausible value (beyond ±{MAX_ABS:g})", path=source, column=name,
                row=int(np.argmax(bad)), rows=rows,
            )  # fmt: skip
    T_s = float(np.median(np.diff(t)))
    travel = float(np.ptp(P_cmd))
    if travel <= 0:
        raise DataError("the commanded position never changes: no positioning test", path=source)
    w = max(1, int(round(p.T_v / T_s)))
    v = _velocity(t, P_cmd, w)
    v_feed = float(np.percentile(np.abs(v), 99.0))
    v_th = p.v_rel * v_feed
    still = np.abs(v) <= v_th
    starts, stops = _runs(still)
    dur = t[np.maximum(stops - 1, starts)] - t[starts]
    keep = dur >= p.T_dwell_min - 0.5 * T_s
    starts, stops = starts[keep], stops[keep]
    if starts.size == 0:
        raise DataError(
            f"no dwell found: no stop of the commanded position lasts {p.T_dwell_min:g} s"
            f" (still = |v| <= {v_th:.3g} {unit}/s, {p.v_rel:g} of the feed speed {v_feed:.3g} {unit}/s)",
            path=source,
        )
    tol = p.target_tolerance * travel
    moving = ~still
    warnings: list[str] = []
    rows: list[tuple[float, float, float, float, float, int, float, float, float]] = []
    for a, b in zip(starts, stops, strict=True):
        prev = np.flatnonzero(moving[:a])
        if prev.size == 0:
            warnings.append(
                f"dwell at t = {t[a]:.6g} s (P_cmd = {_fmt_pos(float(P_cmd[a]), unit)}) has no motion"
                " before it (no approach direction): skipped"
            )
            continue
        direction = UP if v[prev[-1]] > 0 else DOWN
        t0 = t[a] + p.T_settle
        t1 = t[b - 1] - p.T_guard
        win = slice(int(np.searchsorted(t, t0, side="left")), int(np.searchsorted(t, t1, side="right")))
        if win.stop - win.start < 2:
            raise DataError(
                f"dwell at t = {t[a]:.6g} s has fewer than 2 samples after the settling"
                f" ({p.T_settle:g} s) and guard ({p.T_guard:g} s) skips",
                path=source,
            )
        cmd = P_cmd[win]
        if float(np.ptp(cmd)) > tol:
            raise DataError(
                f"ambiguous dwell at t = {t[a]:.6g}…{t[b - 1]:.6g} s: the commanded position moves by"
                f" {_fmt_pos(float(np.ptp(cmd)), unit)} while nearly still (a slow move?);"
                " lower [dwell] v_rel or raise [dwell] target_tolerance",
                path=source,
            )
        dev_w = P_actual[win] - cmd
        dev = float(np.mean(dev_w))
        half = dev_w.size // 2
        trend = float(np.mean(dev_w[dev_w.size - half :]) - np.mean(dev_w[:half]))
        dev_axis = float(np.mean(P_actual[win] - P_axis[win])) if P_axis is not None else math.nan
        rows.append(
            (
                t[a],
                t[b - 1],
                t[win.start],
                t[win.stop - 1],
                float(np.median(cmd)),
                direction,
                dev,
                dev_axis,
                trend,
            )
        )
    if not rows:
        raise DataError("no dwell with an approach direction found", path=source)
    arr = np.array(rows, dtype=np.float64)
    nominal_sorted = None if nominal is None else np.sort(np.asarray(nominal, dtype=np.float64))
    labels, centres, far = _assign(arr, nominal_sorted, tol, travel, p)
    # the rest before and after the test (e.g. the overshoot position where the cycle
    # starts and ends) is not a target: drop the first and the last dwell when they
    # match no target approached from both sides (or no nominal target)
    drop = []
    for k in sorted({0, arr.shape[0] - 1}):
        lab = labels[k]
        dirs_there = set(arr[labels == lab, 5].astype(int)) if not far[k] else set()
        if far[k] or len(dirs_there) < 2:
            drop.append(k)
            warnings.append(
                f"dwell at t = {arr[k, 0]:.6g} s (P_cmd = {_fmt_pos(float(arr[k, 4]), unit)}) is the"
                f" {'first' if k == 0 else 'last'} of the recording and matches no target: taken as the"
                " rest position before or after the test, skipped"
            )
    if drop:
        arr = np.delete(arr, drop, axis=0)
        if arr.shape[0] == 0:
            raise DataError("no dwell left after the rest positions", path=source)
        labels, centres, far = _assign(arr, nominal_sorted, tol, travel, p)
    arr, labels, centres, far = _drop_overrun(
        arr, (labels, centres, far), nominal_sorted, (tol, travel, p), unit, warnings, source
    )
    pos = arr[:, 4]
    if far.any():
        k = int(np.argmax(far))
        raise DataError(
            f"dwell at t = {arr[k, 0]:.6g} s (P_cmd = {_fmt_pos(pos[k], unit)}) matches no nominal target"
            f" (nearest {_fmt_pos(float(centres[labels[k]]), unit)})"
            + targets_unit_hint(nominal_sorted, pos, unit, travel),
            path=source,
        )
    m = centres.size
    dirs = arr[:, 5].astype(np.int64)
    n_up = np.bincount(labels[dirs == UP], minlength=m)
    n_dn = np.bincount(labels[dirs == DOWN], minlength=m)
    n_ref = int(np.bincount(np.concatenate([n_up, n_dn])).argmax())
    for i in range(m):
        for sign, cnt in ((UP, n_up[i]), (DOWN, n_dn[i])):
            if cnt == n_ref:
                continue
            if n_up[i] + n_dn[i] == 0:
                raise DataError(f"target {_fmt_pos(float(centres[i]), unit)}: no dwell found", path=source)
            arrow = "+" if sign == UP else "-"
            other = "+" if sign == DOWN else "-"
            cnt_other = n_dn[i] if sign == UP else n_up[i]
            sel = np.flatnonzero(labels == i)
            when = (
                f"; dwells there at t = {', '.join(f'{x:.4g}' for x in arr[sel, 0][:8])} s"
                if sel.size
                else ""
            )
            hint = (
                "; a reversal point of the cycle (approached from one side only)? give the nominal"
                " [iso230] targets = [...] and dwells elsewhere are skipped"
                if nominal is None and min(n_up[i], n_dn[i]) == 0
                else ""
            )
            raise DataError(
                f"target {_fmt_pos(float(centres[i]), unit)}: {cnt} dwell(s) approached in direction {arrow}"
                f" but {cnt_other} in direction {other}, {n_ref} at the other targets"
                f" (missing or extra dwell){when}{hint}",
                path=source,
            )
    run = np.zeros(pos.size)
    for i in range(m):
        for sign in (UP, DOWN):
            sel = np.flatnonzero((labels == i) & (dirs == sign))
            run[sel[np.argsort(arr[sel, 0])]] = np.arange(1, sel.size + 1)
    target = centres[labels]
    ap = approaches_from_rows(target, run, dirs, arr[:, 6], unit=unit, source=source, target_tolerance=1e-12)
    ap_axis = None
    if P_axis is not None:
        ap_axis = approaches_from_rows(
            target, run, dirs, arr[:, 7], unit=unit, source=source, target_tolerance=1e-12
        )
    return Dwells(
        t_start=arr[:, 0],
        t_end=arr[:, 1],
        t_avg_start=arr[:, 2],
        t_avg_end=arr[:, 3],
        P_cmd=pos,
        target=target,
        direction=dirs.astype(np.float64),
        run=run,
        deviation=arr[:, 6],
        deviation_axis=arr[:, 7] if P_axis is not None else None,
        approaches=ap,
        approaches_axis=ap_axis,
        v_feed=v_feed,
        v_threshold=v_th,
        warnings=warnings,
        trend=arr[:, 8],
    )


@dataclass(frozen=True)
class Drift:
    """Drift of the reference during the test, seen across the runs.

    Attributes
    ----------
    rate, u_rate : float
        Drift rate and its standard uncertainty [m/s or rad/s]: the common slope of the
        deviations against time within each (target, direction) group.
    bias_B_mean : float
        What that drift adds to B̄: rate · mean_i(t̄_i↑ − t̄_i↓) [m or rad] (the ↓ approach
        of a target comes later in a run than the ↑ one).
    u_bias : float
        Standard uncertainty of ``bias_B_mean`` from that of the rate [m or rad].
    corrected : Approaches
        The deviations with the drift removed, x − rate·(t − t_0), for the deadzone
        comparison (the ISO values themselves stay uncorrected, as in the standard).
    """

    rate: float
    u_rate: float
    bias_B_mean: float
    u_bias: float
    corrected: Approaches


def estimate_drift(d: Dwells) -> Drift:
    """Drift rate from the dwells: least squares of x = a_(i,dir) + rate · t.

    The ISO evaluation does not correct drift (the standard does not); this tells how
    much of B̄ it may carry. Needs at least 2 runs per direction.

    Parameters
    ----------
    d : Dwells
        The dwells of a time series (:func:`detect_dwells`): their averaging windows give
        the times [s], their deviations the x [m or rad].

    Returns
    -------
    Drift
        The rate [m/s or rad/s] with its standard uncertainty (∞ when the times cannot
        determine it), its share of B̄ and the drift-corrected approaches.
    """
    t_mid = 0.5 * (d.t_avg_start + d.t_avg_end)
    keys = np.stack([d.target, d.direction], axis=1)
    _, group = np.unique(keys, axis=0, return_inverse=True)
    group = group.ravel()
    tc = t_mid.copy()
    xc = d.deviation.copy()
    for g in range(int(group.max()) + 1):
        sel = group == g
        tc[sel] -= tc[sel].mean()
        xc[sel] -= xc[sel].mean()
    stt = float(np.dot(tc, tc))
    if stt <= 0:
        return Drift(0.0, math.inf, 0.0, math.inf, d.approaches)
    rate = float(np.dot(tc, xc) / stt)
    dof = t_mid.size - int(group.max()) - 2
    res = xc - rate * tc
    u_rate = float(math.sqrt(np.dot(res, res) / max(dof, 1) / stt))
    up = d.direction > 0
    targets = np.unique(d.target)
    gaps = [t_mid[up & (d.target == P)].mean() - t_mid[~up & (d.target == P)].mean() for P in targets]
    gap = float(np.mean(gaps))
    x = d.deviation - rate * (t_mid - t_mid[0])
    corrected = approaches_from_rows(
        d.target,
        d.run,
        d.direction,
        x,
        unit=d.approaches.unit,
        source=d.approaches.source,
        target_tolerance=1e-12,
    )
    return Drift(rate, u_rate, rate * gap, abs(gap) * u_rate, corrected)


def _drop_overrun(
    arr: np.ndarray,
    assigned: tuple[np.ndarray, np.ndarray, np.ndarray],
    nominal: np.ndarray | None,
    how: tuple[float, float, DwellParams],
    unit: str,
    warnings: list[str],
    source: str,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Drop dwells at the test cycle's overrun points: beyond the outermost target, approached
    only outward (the reversal before the next run's approach; ISO 230-2's standard cycle
    overruns the end targets so that each is approached in both directions). With nominal
    targets: every dwell outside their span; without: an outermost detected position whose
    dwells all moved outward, with other targets inside. ``assigned`` is ``_assign``'s
    (labels, centres, far), ``how`` its (tol, travel, params). Returns the re-assigned
    (arr, labels, centres, far); a drop is reported in ``warnings``."""
    labels, centres, far = assigned
    tol, travel, p = how
    dirs = arr[:, 5].astype(np.int64)
    pos = arr[:, 4]
    inner = np.zeros(pos.size, dtype=bool)
    if nominal is not None and nominal.size:
        out = np.zeros(pos.size, dtype=bool)
        for beyond, outward in (
            (far & (pos < nominal[0] - tol), DOWN),
            (far & (pos > nominal[-1] + tol), UP),
        ):
            if beyond.any() and np.all(dirs[beyond] == outward):
                out |= beyond
        # the user has said which positions are targets: a stop elsewhere (a pendulum cycle's
        # turn-around, session 32 tester E4) is no approach — skipped when every nominal target
        # keeps its dwells and the stop is not approached like one (else the refusal below names
        # the mismatch: targets in mm, a target missing from the list)
        rest = far & ~out
        if rest.any() and np.unique(labels[~far]).size == nominal.size:
            inner = _not_target_like(pos, dirs, labels, far, rest, tol)
    else:
        out = np.zeros(pos.size, dtype=bool)
        if centres.size > 2:
            lo, hi = int(np.argmin(centres)), int(np.argmax(centres))
            for lab, outward in ((lo, DOWN), (hi, UP)):
                sel = labels == lab
                if sel.any() and np.all(dirs[sel] == outward):
                    out |= sel
    if not (out.any() or inner.any()):
        return arr, labels, centres, far
    if out.any():
        shown = ", ".join(sorted({_fmt_pos(float(x), unit) for x in pos[out]}))
        warnings.append(
            f"{int(out.sum())} dwell(s) at {shown}, beyond the outermost target and approached only outward:"
            " taken as the cycle's overrun (reversal) points, skipped"
        )
    if inner.any():
        places = list(dict.fromkeys(_fmt_pos(float(x), unit) for x in np.sort(pos[inner])))
        shown = ", ".join(places[:6]) + (f", … ({len(places)} positions)" if len(places) > 6 else "")
        warnings.append(
            f"{int(inner.sum())} dwell(s) at {shown} match no nominal [iso230] target: taken as stops"
            " between the approaches (a pendulum cycle's turn-arounds), skipped"
        )
    arr = arr[~(out | inner)]
    if arr.shape[0] == 0:
        raise DataError("no dwell left after the overrun points", path=source)
    labels, centres, far = _assign(arr, nominal, tol, travel, p)
    return arr, labels, centres, far


def _not_target_like(
    pos: np.ndarray, dirs: np.ndarray, labels: np.ndarray, far: np.ndarray, cand: np.ndarray, tol: float
) -> np.ndarray:
    """Which of the dwells ``cand`` (matching no nominal target) are not approached the way a
    target is: their position (grouped within ``tol`` [m or rad]) has other dwell counts per
    direction than the nominal targets have (n ↑ and n ↓). A pendulum cycle's turn-arounds are
    approached from one side, or once from one side and n − 1 times from the other."""
    from drivelash.iso230.evaluate import cluster_targets

    out = np.zeros(pos.size, dtype=bool)
    idx = np.flatnonzero(cand)
    counts = [
        (int(np.sum((labels == g) & ~far & (dirs == UP))), int(np.sum((labels == g) & ~far & (dirs == DOWN))))
        for g in np.unique(labels[~far])
    ]
    ref = max(set(counts), key=counts.count)
    _, lab = cluster_targets(pos[idx], tol / max(float(np.ptp(pos[idx])), 1e-300))
    for g in np.unique(lab):
        sel = idx[lab == g]
        if (int(np.sum(dirs[sel] == UP)), int(np.sum(dirs[sel] == DOWN))) != ref:
            out[sel] = True
    return out


def targets_unit_hint(nominal: Any, measured: np.ndarray, unit: str, travel: float) -> str:
    """A hint for an error about nominal ``[iso230] targets`` that match no measured position:
    when the nominal ones divided by 1000 match (targets written in mm, or in mrad, where the
    configuration takes m or rad), say so; else "". ``travel`` [m or rad] scales the match."""
    if nominal is None or len(nominal) == 0 or len(measured) == 0:
        return ""
    nom = np.sort(np.asarray(nominal, dtype=np.float64)) * 1e-3
    meas = np.asarray(measured, dtype=np.float64)
    tol = 0.02 * max(travel, float(np.ptp(meas)), 1e-12)
    near = np.abs(meas[:, None] - nom[None, :]).min(axis=1)
    if np.all(near <= tol):
        small = "mm" if unit == "m" else "mrad"
        return f" — [iso230] targets are in {unit}; these look like {small} (divide by 1000)"
    return ""


def settling_trend(d: Dwells) -> tuple[float, float, int]:
    """How much the reading still moves inside the averaging windows, by approach direction.

    A servo that has not settled moves the reading the same way after every approach from one
    side (the load creeps after the motor toward the target): the half-window changes Δ
    (:attr:`Dwells.trend`) of ↑ and ↓ approaches differ in sign. A drift of the reference moves
    both alike and cancels in D = (mean Δ↑ − mean Δ↓)/2, the settling signature; B̄ carries about
    −D of it (the window means lag the settled reading by about Δ/2 per direction).

    Parameters
    ----------
    d : Dwells
        The dwells of a time series (:func:`detect_dwells`).

    Returns
    -------
    D : float
        The settling signature [m or rad] (0 without trends).
    u_D : float
        Its standard uncertainty from the scatter of Δ within each direction [m or rad].
    worst : int
        Index of the dwell whose direction-signed Δ goes furthest the way of D.
    """
    if d.trend is None or d.trend.size == 0:
        return 0.0, math.inf, 0
    up = d.direction > 0
    if up.sum() < 2 or (~up).sum() < 2:
        return 0.0, math.inf, 0
    tr_up, tr_dn = d.trend[up], d.trend[~up]
    D = 0.5 * float(tr_up.mean() - tr_dn.mean())
    u_D = 0.5 * math.sqrt(float(tr_up.var(ddof=1)) / tr_up.size + float(tr_dn.var(ddof=1)) / tr_dn.size)
    signed = d.trend * np.where(up, 1.0, -1.0) * math.copysign(1.0, D)
    return D, u_D, int(np.argmax(signed))


def _moving(d: Dwells, travel: float) -> tuple[bool, float, float, int, float]:
    """(still moving?, D, u_D, worst dwell, u(B̄)) of the dwells' windows."""
    from drivelash.iso230.evaluate import evaluate

    D, u_D, worst = settling_trend(d)
    try:
        u_Bm = evaluate(d.approaches).u_B_mean
    except DataError:
        return False, D, u_D, worst, math.nan
    bound = max(SETTLE_SIGNIFICANCE * u_D, u_Bm, SETTLE_FLOOR_FRACTION * travel)
    return abs(D) > bound, D, u_D, worst, u_Bm


def settle_dwells(
    d: Dwells,
    t: np.ndarray,
    P_cmd: np.ndarray,
    P_actual: np.ndarray,
    P_axis: np.ndarray | None = None,
    *,
    params: DwellParams | None = None,
    nominal: np.ndarray | None = None,
    unit: str = "m",
    source: str = "",
    rows: DataRows = NO_LINES,
) -> tuple[Dwells, str | None]:
    """Dwells whose averaging windows hold a settled reading: T_settle lengthened when needed.

    When the reading still moves inside the windows of ``d`` (:func:`settling_trend`: the
    settling signature D beyond :data:`SETTLE_SIGNIFICANCE` of its uncertainty, beyond u(B̄) and
    beyond :data:`SETTLE_FLOOR_FRACTION` of the travel), the dwells are found again with T_settle
    lengthened by :data:`SETTLE_STEP` until they are settled, at most until the shortest dwell
    keeps T_guard + T_avg_min. Arguments as :func:`detect_dwells`; ``d`` is its result.

    Returns
    -------
    dwells : Dwells
        ``d`` unchanged when settled, else the dwells with the longer T_settle.
    note : str or None
        The warning naming the worst target, the movement and the T_settle used.

    Raises
    ------
    DataError
        No T_settle the dwells allow settles the reading (one line naming the target, the dwell
        and the movement): B and B̄ would lag the settled reading.
    """
    p = params or DwellParams()
    travel = float(np.ptp(P_cmd))
    moving, D, u_D, worst, u_Bm = _moving(d, travel)
    if not moving:
        return d, None
    assert d.trend is not None
    arrow = "↑" if d.direction[worst] > 0 else "↓"
    where = (
        f"target {_fmt_pos(float(d.target[worst]), unit)} {arrow}, dwell at t = {d.t_start[worst]:.6g} s,"
        f" moves {_fmt_dev(float(d.trend[worst]), unit)} between the halves of its window"
    )
    size = (
        f"settling signature {_fmt_dev(D, unit)} (↑ against ↓), {abs(D) / max(u_Bm, 1e-300):.3g}× u(B̄)"
        if u_Bm > 0
        else f"settling signature {_fmt_dev(D, unit)} (↑ against ↓)"
    )
    T_max = float(np.min(d.t_end - d.t_start)) - p.T_guard - p.T_avg_min
    T_new = p.T_settle
    for _ in range(10_000):
        T_new = round(T_new + SETTLE_STEP, 9)
        if T_new > T_max + 1e-9:
            break
        q = replace(p, T_settle=T_new, T_dwell_min=max(p.T_dwell_min, T_new + p.T_guard + p.T_avg_min))
        try:
            d2 = detect_dwells(
                t, P_cmd, P_actual, P_axis, params=q, nominal=nominal, unit=unit, source=source, rows=rows
            )
        except DataError:
            break
        if (
            d2.approaches.up.shape != d.approaches.up.shape
            or d2.approaches.down.shape != d.approaches.down.shape
        ):
            break
        if not _moving(d2, travel)[0]:
            return d2, (
                "the reading still moves inside the averaging windows after [dwell] T_settle ="
                f" {p.T_settle:g} s ({where}; {size}): a slowly settling axis — evaluated with"
                f" T_settle = {T_new:g} s"
                f" instead (set [dwell] T_settle = {T_new:g} or more)"
            )
    raise DataError(
        f"the reading still moves inside the averaging windows ({where}; {size}) and no [dwell] T_settle"
        f" up to {max(T_max, p.T_settle):g} s (the shortest dwell less T_guard and T_avg_min) settles it:"
        " B and B̄ would lag the settled reading; record longer dwells",
        path=source,
    )


def _fmt_dev(x: float, unit: str) -> str:
    """A deviation for a message: µm for linear axes, arcsec for rotary ones."""
    if unit == "rad":
        return f"{math.degrees(x) * 3600:.3g} arcsec"
    return f"{x * 1e6:.3g} µm"
