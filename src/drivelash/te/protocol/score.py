"""Scoring the compensation on the user's own recordings (issue 12 item 5; paper §VI).

``drivelash te score --uncompensated DIR --compensated DIR`` takes two campaign
directories (``te import`` of the user's passes without and with compensation; the run
list of the axis file says kind, direction, velocity and load of each file) and
computes what ``te validate`` computes on the virtual bench, from measurements:

* **improvement per 100 mm section and per pass**: the path error e = x_d − x_T of
  each constant-velocity pass, without and with compensation, matched by (direction,
  velocity, load); improvement = 1 − MAE_comp / MAE_uncomp per section, averaged per
  pass (:func:`drivelash.te.protocol.validate.summarize_passes`, the same figures).
  The set position x_d is taken from the recording when it holds a ``x_d`` column
  ("recorded"); otherwise it is **reconstructed** as the least-squares line through
  x_T(t) over the constant-velocity part (the CNC commanded a constant speed there):
  that removes the mean and the linear trend of the true path error over the pass,
  which (3) makes ≈ 0 (its zero at s = 0 suppresses the TE's drift and offset), while
  the tooth-meshing and runout parts that the score is about stay intact;
* **monitoring from real data** (the paper's estimate without a reference pass): eq. (3)
  applied to the TE measured during the compensated pass, x_T − θ_M d_p/(2 i), gives the
  path error the axis would have had without compensation; per section it is compared
  with the measured uncompensated pass, and the improvement estimated from it;
* **loop gains** for (3): K_v, K_p, T_n from the axis file (the campaign manifest), or
  **identified** from the uncompensated recordings (``--gains identify``): eq. (3) fitted
  to their measured TE and path error (output-error least squares,
  :func:`identify_loop_gains`, with standard deviations: at tooth-meshing frequencies
  below the loop bandwidth K_v is well determined, the velocity loop less); the report
  says which gains were used.

``te validate`` stays the virtual-bench protocol; ``te score`` needs no simulator and no
true TE.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import DataError, ParameterError
from drivelash.params import CascadeGains
from drivelash.te.protocol.monitoring import section_edges, section_mae

__all__ = [
    "WEAKLY_DETERMINED",
    "PassError",
    "ScoreConfig",
    "identify_loop_gains",
    "implausible_gains",
    "pass_path_error",
    "score_campaigns",
]


@dataclass(frozen=True)
class ScoreConfig:
    """Settings of :func:`score_campaigns`; values and reasons in docs/assumptions.md.

    Parameters
    ----------
    section_length : float
        Length of the scored sections [m] (paper: 100 mm).
    min_count : int
        Fewest samples of a section for a score.
    velocity_tolerance : float
        A sample belongs to the constant-velocity part when its velocity is within this
        share of the run's velocity [-] (recorded x_d: of dx_d/dt; reconstructed: of the
        measured table velocity, averaged over ``smooth``); an uncompensated and a
        compensated pass of one direction and load pair when their velocities agree within it.
    smooth : float
        Averaging window of the measured velocity for the reconstruction [s].
    trim : float
        Time cut from both ends of a reconstructed constant-velocity part [s] (the loop's
        settling after the ramp: several 1/K_v).
    train_max_load : float or None
        Largest training load [N] for the in-range / beyond-range split (None: all in range).
    """

    section_length: float = 0.1
    min_count: int = 10
    velocity_tolerance: float = 0.01
    smooth: float = 0.02
    trim: float = 0.05
    train_max_load: float | None = None

    def __post_init__(self) -> None:
        for n in ("section_length", "velocity_tolerance", "smooth"):
            v = getattr(self, n)
            if not (math.isfinite(v) and v > 0):
                raise ParameterError("ScoreConfig", n, f"must be > 0, got {v!r}")
        if not self.trim >= 0 or int(self.min_count) < 1:
            raise ParameterError("ScoreConfig", "trim", "trim must be >= 0 and min_count >= 1")


@dataclass(frozen=True)
class PassError:
    """Path error of one recorded pass on its constant-velocity part.

    Attributes
    ----------
    t, x_T, e : numpy.ndarray
        Time [s], table position [m], path error x_d − x_T [m] of the constant-velocity part.
    x_lo, x_hi : float
        Range of the set position over the whole pass [m] (section edges start at x_lo).
    set_position : str
        ``"recorded"`` or ``"reconstructed"``.
    """

    t: np.ndarray
    x_T: np.ndarray
    e: np.ndarray
    x_lo: float
    x_hi: float
    set_position: str


#: A section is scored only where both passes cover it alike: each one's samples in the section
#: may end at most this far [m] inside the other's (finding TH11). 1 mm: the tolerance of
#: ``te update`` and of the load-pass span check (``GEO_SPAN_TOL``); passes of one commanded
#: stroke cover the same positions within µm.
COVER_TOL = 1e-3


def _covered(x: np.ndarray, edges: np.ndarray) -> list[tuple[float, float]]:
    """Per section of ``edges``: the first and last sample position [m] of ``x`` in it ((inf,
    −inf) for none)."""
    x = np.asarray(x, dtype=np.float64)
    out = []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        s = x[(x >= a) & (x < b)]
        out.append((float(s.min()), float(s.max())) if s.size else (math.inf, -math.inf))
    return out


def _why_none(data: list[Any], cfg: ScoreConfig) -> str:
    """Why no section of any pass pair was scored (finding TH10: always "passes shorter than one
    section?", for passes at other machine coordinates and for sections too short to hold
    ``min_count`` samples)."""
    apart, few = [], []
    for ru, _, _, _, pu, pc in data:
        xu, xc = np.asarray(pu.x_T), np.asarray(pc.x_T)
        if xu.size == 0 or xc.size == 0:
            continue
        if xc.min() > xu.max() or xc.max() < xu.min():
            apart.append((ru, xu, xc))
            continue
        dx = float(np.median(np.abs(np.diff(np.sort(xu))))) if xu.size > 1 else math.inf
        few.append(cfg.section_length / dx if dx > 0 else math.inf)
    if apart and not few:
        ru, xu, xc = apart[0]
        return (
            "the compensated passes lie at other positions than the uncompensated ones (e.g."
            f" d={ru.direction:+d} v={ru.velocity * 1e3:g} mm/s: {xc.min() * 1e3:.1f} … {xc.max() * 1e3:.1f}"
            f" mm against {xu.min() * 1e3:.1f} … {xu.max() * 1e3:.1f} mm): no common section — are both"
            " recorded in the same machine coordinates (scale zero, [columns] offset)?"
        )
    if few and max(few) < cfg.min_count:
        return (
            f"a {cfg.section_length * 1e3:g} mm section holds at most {max(few):.0f} samples of these passes"
            f" (at their speed and sample rate), fewer than the {cfg.min_count} a section needs: use"
            f" longer sections (--section-mm)"
        )
    return "the passes are shorter than one section or share no section (compare their x_T ranges)"


def _moving_average(v: np.ndarray, n: int) -> np.ndarray:
    if n <= 1:
        return v
    k = np.ones(n) / n
    return np.convolve(np.pad(v, (n // 2, n - 1 - n // 2), mode="edge"), k, mode="valid")


def _largest_block(mask: np.ndarray) -> np.ndarray:
    """The longest contiguous run of True in ``mask`` (others False)."""
    m = np.asarray(mask, dtype=bool)
    if not m.any():
        return m
    d = np.diff(np.concatenate([[0], m.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    k = int(np.argmax(ends - starts))
    out = np.zeros_like(m)
    out[starts[k] : ends[k]] = True
    return out


def pass_path_error(columns: dict[str, np.ndarray], direction: int, velocity: float, cfg: ScoreConfig,
                    name: str = "") -> PassError:  # fmt: skip
    """Path error of a constant-velocity pass: from the recorded x_d, or with x_d reconstructed.

    Parameters
    ----------
    columns : mapping
        At least ``t`` [s] and ``x_T`` [m]; ``x_d`` [m] if recorded.
    direction : int
        Direction of travel (±1).
    velocity : float
        Travel speed of the constant-velocity part [m/s].
    cfg : ScoreConfig
        Tolerances.
    name : str
        Run name for error messages.
    """
    t = np.asarray(columns["t"], dtype=np.float64)
    x = np.asarray(columns["x_T"], dtype=np.float64)
    if t.size < 10:
        raise DataError(f"run {name}: fewer than 10 samples")
    dt = float(np.median(np.diff(t)))
    tol = cfg.velocity_tolerance * velocity
    if "x_d" in columns:
        xd = np.asarray(columns["x_d"], dtype=np.float64)
        m = _largest_block(np.abs(np.gradient(xd, t) - direction * velocity) <= tol)
        if np.count_nonzero(m) < 10:
            raise DataError(f"run {name}: the set position x_d never moves at {velocity * 1e3:g} mm/s")
        return PassError(t[m], x[m], xd[m] - x[m], float(xd.min()), float(xd.max()), "recorded")
    v = _moving_average(np.gradient(x, t), max(1, int(round(cfg.smooth / dt))))
    m = _largest_block(np.abs(v - direction * velocity) <= max(tol, 0.05 * velocity))
    idx = np.flatnonzero(m)
    k = int(round(cfg.trim / dt))
    if idx.size <= 2 * k + 10:
        raise DataError(
            f"run {name}: no constant-velocity part at {velocity * 1e3:g} mm/s to reconstruct x_d"
        )
    sel = np.zeros_like(m)
    sel[idx[k] : idx[-1] - k + 1] = True
    A = np.vstack([np.ones(np.count_nonzero(sel)), t[sel] - t[sel][0]]).T
    coef, *_ = np.linalg.lstsq(A, x[sel], rcond=None)
    slope = float(coef[1])
    if abs(slope - direction * velocity) > 0.05 * velocity:
        raise DataError(
            f"run {name}: measured speed {slope * 1e3:.4g} mm/s, listed {direction * velocity * 1e3:g}"
        )
    xd_line = A @ coef
    # the set position at rest before and after the pass: the recorded position there
    n_rest = max(1, int(round(0.05 / dt)))
    ends = np.concatenate([x[:n_rest], x[-n_rest:]])
    return PassError(t[sel], x[sel], xd_line - x[sel], float(ends.min()), float(ends.max()), "reconstructed")


def _detrend(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``y`` minus its least-squares line over ``t``."""
    A = np.vstack([np.ones_like(t), t - t[0]]).T
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    return y - A @ coef


def identify_loop_gains(
    runs: list[dict[str, Any]], J_s: float, start: CascadeGains | None = None, detrend: bool = True
) -> tuple[CascadeGains, dict[str, Any]]:
    """K_v, K_p, T_n of eq. (3) identified from recorded passes (output-error least squares).

    For each run, eq. (3) with the trial gains is applied to the measured TE over the
    whole recording, and the result is compared with the measured path error on the
    constant-velocity part; ``scipy.optimize.least_squares`` minimises the difference over
    (log K_v, log K_p, log T_n), from ``start`` and from a few spread starts. With a
    reconstructed set position (``detrend``) the least-squares line over the part is taken
    out of both, as it is out of the reconstructed path error.

    What the recordings determine depends on their spectrum: the TE's tooth-meshing
    and runout frequencies (v/pitch, v/circumference) lie below the position-loop
    bandwidth, where (3) ≈ −s/K_v — K_v is well determined, K_p and T_n (the velocity loop)
    much less. ``info["std"]`` gives the standard deviations from the Jacobian, so the
    report says what is identified.

    Parameters
    ----------
    runs : list of dict
        Per run: ``t`` [s] and ``te`` [m] over the whole recording, ``mask`` (bool, the
        constant-velocity part) and ``e`` [m] (the measured path error on the part).
    J_s : float
        Combined inertia of the axis [kg·m²] (axis file).
    start : CascadeGains, optional
        First start (e.g. the axis file's gains).
    detrend : bool
        Remove the least-squares line of the prediction over the part.

    Returns
    -------
    gains : CascadeGains
        Identified K_v [1/s], K_p [N·m·s/rad], T_n [s] (torque limit and k_ff of ``start``).
    info : dict
        ``std`` and ``relative_std`` (K_v only; None for K_p and T_n, which the passes barely
        determine: :data:`WEAKLY_DETERMINED`, ``note``), ``rms_residual_um``,
        ``rms_path_error_um``, ``cost``, ``starts``.
    """
    from scipy.optimize import least_squares

    from drivelash.control.path_error import predict_path_error

    if not runs:
        raise DataError("no runs to identify the loop gains from")
    # at most 1 kHz: the TE's content lies far below, and (3) is evaluated many times
    prepared, targets = [], []
    for r in runs:
        t = np.asarray(r["t"], dtype=np.float64)
        m = np.asarray(r["mask"], dtype=bool)
        e = np.asarray(r["e"], dtype=np.float64)
        if e.size != np.count_nonzero(m):
            raise DataError("identification: e must hold the path error on the masked samples")
        step = max(1, int(round(1e-3 / float(np.median(np.diff(t))))))
        keep = np.flatnonzero(m) % step == 0
        prepared.append((t[::step], np.asarray(r["te"], dtype=np.float64)[::step], m[::step]))
        targets.append(e[keep])
    scale = float(np.sqrt(np.mean(np.concatenate(targets) ** 2))) or 1.0

    def gains_of(p: np.ndarray) -> CascadeGains:
        base = start or CascadeGains(K_v=1.0, K_p=1.0, T_n=1.0, torque_limit=1e6)
        return CascadeGains(K_v=float(np.exp(p[0])), K_p=float(np.exp(p[1])), T_n=float(np.exp(p[2])),
                            torque_limit=base.torque_limit, k_ff=base.k_ff, T_s=base.T_s)  # fmt: skip

    def resid(p: np.ndarray) -> np.ndarray:
        g = gains_of(p)
        out = []
        for (t, te, m), e in zip(prepared, targets, strict=True):
            pred = predict_path_error(te, t, J_s, g)[m]
            if detrend:
                pred = _detrend(t[m], pred)
            out.append((e - pred) / scale)
        return np.concatenate(out)

    starts = [np.log([start.K_v, start.K_p, start.T_n])] if start is not None else []
    starts += [np.log([K_v, K_v * 20 * J_s, 4.0 / K_v]) for K_v in (30.0, 100.0, 300.0)]
    best = None
    for p0 in starts:
        # trial gains far off (e.g. swapped passes) overflow inside the solver: judged afterwards
        # (implausible_gains), not printed as numpy warnings
        with np.errstate(over="ignore", invalid="ignore"):
            sol = least_squares(resid, p0, x_scale=1.0, method="trf", max_nfev=200)
        if best is None or sol.cost < best.cost:
            best = sol
    assert best is not None
    g = gains_of(best.x)
    r = best.fun
    dof = max(1, r.size - 3)
    s2 = float(r @ r) / dof
    try:
        cov = np.linalg.inv(best.jac.T @ best.jac) * s2
        rel = np.sqrt(np.clip(np.diag(cov), 0.0, None))  # std of log(gain) = relative std
    except np.linalg.LinAlgError:
        rel = np.full(3, np.inf)
    info = {
        # K_p, T_n: the Jacobian's σ is no measure — the passes barely constrain them (finding D2:
        # 54.1 N·m·s/rad and 8.69 ms "± 2 %" for the drive's 15.7 and 3.05 ms, with a monitoring
        # estimate as good as with the true gains); withheld, the values flagged
        "std": {"K_v": g.K_v * rel[0], "K_p": None, "T_n": None},
        "relative_std": {"K_v": float(rel[0]), "K_p": None, "T_n": None},
        "weakly_determined": list(WEAKLY_DETERMINED),
        "note": WEAK_NOTE,
        "rms_residual_um": float(np.sqrt(np.mean(r**2)) * scale * 1e6),
        "rms_path_error_um": scale * 1e6,
        "cost": float(best.cost),
        "starts": len(starts),
    }
    return g, info


def score_campaigns(
    unc: Any,
    comp: Any,
    cfg: ScoreConfig | None = None,
    gains: str = "auto",
    progress: Any = None,
) -> dict[str, Any]:
    """Score compensated against uncompensated recordings (see the module docstring).

    Parameters
    ----------
    unc, comp : Campaign
        The two campaigns (:func:`drivelash.te.protocol.campaign.load_campaign`); their
        ``load`` runs are matched by direction, load and velocity (within
        ``cfg.velocity_tolerance``, the nearest).
    cfg : ScoreConfig, optional
        Section length, tolerances, training load limit.
    gains : {"auto", "axis", "identify"}
        Loop gains of eq. (3): from the axis file, identified from the uncompensated runs,
        or ``auto`` (the axis file when it has them, else identified).
    progress : callable, optional
        One-line progress messages.

    Returns
    -------
    dict
        ``rows`` (one per pass and section), ``passes`` (the figures of
        :func:`~drivelash.te.protocol.validate.summarize_passes`), ``monitoring`` (eq. (3)
        estimate against the measured uncompensated passes), ``gains`` (used, with their
        source, and the identified ones when computed), ``unmatched`` runs.
    """
    from drivelash.control.path_error import predict_path_error
    from drivelash.te.protocol.validate import summarize_passes

    cfg = cfg or ScoreConfig()
    say = progress or (lambda s: None)
    if gains not in ("auto", "axis", "identify"):
        raise ParameterError("te score", "--gains", f"must be auto, axis or identify, got {gains!r}")
    from drivelash.te.learn.preprocess import GearGeometry
    from drivelash.te.protocol.campaign import check_same_axis

    bench = unc.bench
    # passes of another axis cannot be compared (the check of te update)
    ref = GearGeometry.from_bench(comp.bench)
    where = Path(unc.directory) / "manifest.json"
    check_same_axis(unc, ref, where, "the compensated passes'", "the uncompensated passes'")
    pairs, unmatched = [], []
    free = list(comp.select(kind="load"))
    for ru in unc.select(kind="load"):
        rc = _partner(ru, free, cfg.velocity_tolerance)
        if rc is not None:
            free.remove(rc)
            pairs.append((ru, rc))
        else:
            unmatched.append(f"{ru.path.name}: no compensated run with direction {ru.direction:+d}, "
                             f"{ru.velocity * 1e3:g} mm/s, {ru.load:g} N")  # fmt: skip
    if not pairs:
        raise DataError("no pair of uncompensated and compensated load runs with the same direction, "
                        "velocity "
                        "and load", path=str(comp.directory))  # fmt: skip
    axis_gains = _axis_gains(unc)
    data = []
    for ru, rc in pairs:
        cu, cc = ru.trace().columns, rc.trace().columns
        pu = pass_path_error(cu, ru.direction, ru.velocity, cfg, ru.path.name)
        pc = pass_path_error(cc, rc.direction, rc.velocity, cfg, rc.path.name)
        data.append((ru, rc, cu, cc, pu, pc))
    identified, id_info = None, None
    if gains == "identify" or (gains == "auto" and axis_gains is None):
        say("identifying K_v, K_p, T_n of eq. (3) from the uncompensated runs")
        id_runs = []
        for _, _, cu, _, pu, _ in data:
            t = np.asarray(cu["t"], dtype=np.float64)
            te = bench.te_from_measurement(np.asarray(cu["x_T"]), np.asarray(cu["theta_m"]))
            id_runs.append({"t": t, "te": te, "mask": np.isin(t, pu.t), "e": pu.e})
        identified, id_info = identify_loop_gains(
            id_runs, float(bench.J_s), axis_gains, detrend=pu.set_position == "reconstructed"
        )
    if gains == "axis" and axis_gains is None:
        raise DataError(
            "the campaign's axis has no loop gains; use --gains identify", path=str(unc.directory)
        )
    used = identified if (gains == "identify" or axis_gains is None) else axis_gains
    source = "identified" if used is identified else "axis file"
    problem = implausible_gains(used) if used is identified else None
    warnings: list[str] = []
    if problem is not None:
        warnings.append(
            f"the identified eq. (3) gains are implausible ({problem}): no monitoring estimate; are"
            " --uncompensated and --compensated swapped, or give the axis file's gains (--gains axis)"
        )
    rows, mon = [], []
    for ru, _, _, cc, pu, pc in data:
        edges = section_edges(pu.x_lo, pu.x_hi, cfg.section_length)
        mu = section_mae(pu.x_T, pu.e, edges, cfg.min_count)
        mc = section_mae(pc.x_T, pc.e, edges, cfg.min_count)
        # monitoring: (3) on the TE measured during the compensated pass
        t_c = np.asarray(cc["t"], dtype=np.float64)
        te = bench.te_from_measurement(np.asarray(cc["x_T"]), np.asarray(cc["theta_m"]))
        m_c = np.isin(t_c, pc.t)
        if problem is None:
            e_est = predict_path_error(te, t_c, float(bench.J_s), used)
            me = section_mae(np.asarray(cc["x_T"])[m_c], e_est[m_c], edges, cfg.min_count)
        else:
            me = np.full(edges.size - 1, np.nan)
        cover_u, cover_c = _covered(pu.x_T, edges), _covered(pc.x_T, edges)
        for i in range(edges.size - 1):
            if not (np.isfinite(mu[i]) and np.isfinite(mc[i])):
                continue
            (ua, ub), (ca, cb) = cover_u[i], cover_c[i]
            if ca > ua + COVER_TOL or cb < ub - COVER_TOL:
                # one pass covers part of the section only: its MAE is over other positions
                # (finding TH11: a trace started 30 mm late "improved" 50-150 mm by 3.5-5 %)
                warnings.append(
                    f"pass d={ru.direction:+d} v={ru.velocity * 1e3:g} mm/s F={ru.load:g} N: section"
                    f" {edges[i] * 1e3:.1f} … {edges[i + 1] * 1e3:.1f} mm left out: the compensated pass"
                    f" covers {ca * 1e3:.1f} … {cb * 1e3:.1f} mm of it, the uncompensated {ua * 1e3:.1f} …"
                    f" {ub * 1e3:.1f} mm"
                )
                continue
            rows.append({
                "direction": int(ru.direction), "velocity": float(ru.velocity), "load": float(ru.load),
                "x_start": float(edges[i]), "x_end": float(edges[i + 1]),
                "mae_uncomp_um": float(mu[i] * 1e6), "mae_comp_um": float(mc[i] * 1e6),
                "improvement": float(1.0 - mc[i] / mu[i]),
            })  # fmt: skip
            if np.isfinite(me[i]):
                mon.append({
                    "direction": int(ru.direction), "velocity": float(ru.velocity), "load": float(ru.load),
                    "x_start": float(edges[i]), "mae_uncomp_um": float(mu[i] * 1e6),
                    "mae_estimated_um": float(me[i] * 1e6),
                    "improvement_measured": float(1.0 - mc[i] / mu[i]),
                    "improvement_estimated": float(1.0 - mc[i] / me[i]),
                })  # fmt: skip
        say(f"pass d={ru.direction:+d} v={ru.velocity * 1e3:g} mm/s F={ru.load:g} N: "
            f"x_d {pu.set_position}/{pc.set_position}")  # fmt: skip
    if not rows:
        raise DataError(f"no section scored: {_why_none(data, cfg)}", path=str(comp.directory))
    max_load = cfg.train_max_load if cfg.train_max_load is not None else math.inf
    out: dict[str, Any] = {
        "rows": rows,
        "passes": summarize_passes(rows, max_load),
        "train_max_load": cfg.train_max_load,
        "set_position": sorted({d[4].set_position for d in data} | {d[5].set_position for d in data}),
        "gains": {"used": None if problem else _gains_dict(used), "source": source},
        "unmatched": unmatched,
    }
    if problem is not None:
        out["gains"]["implausible"] = problem
    avg = out["passes"]["average_improvement"]
    if avg < 0:
        warnings.append(
            f"the compensated passes are worse than the uncompensated ones (average {100 * avg:+.1f} %):"
            " are --uncompensated and --compensated swapped?"
        )
    out["warnings"] = warnings
    if axis_gains is not None:
        out["gains"]["axis_file"] = _gains_dict(axis_gains)
    if identified is not None:
        out["gains"]["identified"] = _gains_dict(identified)
        out["gains"]["identification"] = id_info
    if mon:
        est = np.array([m["mae_estimated_um"] for m in mon])
        ref = np.array([m["mae_uncomp_um"] for m in mon])
        out["monitoring"] = {
            "sections": mon,
            "median_relative_error": float(np.median(np.abs(est - ref) / ref)),
            "average_improvement_estimated": float(np.mean([m["improvement_estimated"] for m in mon])),
            "average_improvement_measured": float(np.mean([m["improvement_measured"] for m in mon])),
        }
    return out


def _partner(ru: Any, candidates: list[Any], tolerance: float) -> Any:
    """The compensated run of ``ru``'s direction and load whose velocity is nearest ``ru``'s, within
    ``tolerance`` (relative); None if there is none.

    Velocities are measured at import when ``[[runs]]`` lists none: the two recordings of one
    commanded pass differ by the TE's slope (which the compensation removes) and the scale's
    noise, ~1e-4 relative (finding D8: 50.005 vs 50.000 mm/s, dropped from the score when compared
    to 1e-9); commanded velocities differ by far more than ``tolerance``.
    """
    best, gap = None, math.inf
    for rc in candidates:
        if rc.direction != ru.direction or abs(rc.load - ru.load) > 1e-9:
            continue
        d = abs(rc.velocity / ru.velocity - 1.0) if ru.velocity > 0 else math.inf
        if d <= tolerance and d < gap:
            best, gap = rc, d
    return best


#: Gains of eq. (3) the passes do not determine: the TE's meshing and runout frequencies lie
#: below the position-loop bandwidth, where (3) ≈ −s/K_v, so the velocity loop's K_p, T_n only
#: shape a small residual (module doc).
WEAKLY_DETERMINED = ("K_p", "T_n")
WEAK_NOTE = (
    "K_p and T_n are weakly determined by the passes (their TE lies below the loop bandwidth): effective"
    " values for eq. (3), not a measurement of the drive's velocity controller; K_v is identified (its std"
    " from the Jacobian assumes white residuals: a lower bound)"
)


#: Plausible position-loop gains K_v [1/s] of eq. (3): below 0.5 1/s (0.03 (m/min)/mm) no CNC axis
#: is tuned; above 1e4 1/s the position loop would be faster than any servo velocity loop
#: (≤ ~1 kHz bandwidth). K_p and T_n are less well determined by the passes (module doc): they
#: must be finite and > 0.
K_V_RANGE = (0.5, 1e4)


def implausible_gains(g: CascadeGains) -> str | None:
    """Why identified loop gains are not physical (None: plausible)."""
    vals = {"K_v": g.K_v, "K_p": g.K_p, "T_n": g.T_n}
    for name, v in vals.items():
        if not (math.isfinite(v) and v > 0):
            return f"{name} = {v!r}"
    lo, hi = K_V_RANGE
    if not lo <= g.K_v <= hi:
        return f"K_v {g.K_v:.4g} 1/s outside {lo:g} ... {hi:g} 1/s"
    return None


def _axis_gains(campaign: Any) -> CascadeGains | None:
    try:
        g = campaign.gains
    except (KeyError, TypeError, ValueError):
        return None
    return g if isinstance(g, CascadeGains) else None


def _gains_dict(g: CascadeGains) -> dict[str, float]:
    return {"K_v": g.K_v, "K_p": g.K_p, "T_n": g.T_n, "k_ff": g.k_ff}
