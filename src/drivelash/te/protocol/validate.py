"""Validation of the compensation on the virtual bench, spec 02 §6 (paper §VI, Figs 8–9).

``drivelash te validate MODEL_DIR -o DIR`` runs, on the drive the model was trained on:

(a) **sinusoidal trajectory** with direction changes, without and with compensation:
    path error, TE and v_c (Fig. 8); reversal error (peak |e| around each reversal),
    peak v_c against the drive limits, path-error spectrum above 50 Hz;
(b) **constant-velocity passes** at the campaign velocities with loads 0 … 5000 N
    (500 N steps), each without and with compensation; improvement of the path-error
    MAE per 100 mm section (Fig. 9 as heat maps and a CSV table);
(c) **monitoring** (:mod:`drivelash.te.protocol.wear_demo`): the rack develops a local
    defect; with compensation active the flagged sections are compared with the
    defect; after ``update(stage="trees")`` on new passes the improvement returns.

The passes and the compensator's table stay inside the model's valid range (where it was
measured, :func:`~drivelash.te.runtime.table.measured_range`, the range ``te export``
writes); ``summary.json`` states it (``valid_range``) with the share of each protocol's
compensation cycles whose set positions left the table — there the compensator holds the
table's edge value — which is zero unless a configured ``x_range`` goes beyond it.

One pass with the compensator in the loop: :mod:`drivelash.te.protocol.passes`.
Figures (paper Figs 8–9, monitoring) are drawn by a ``figures`` object passed in
(:mod:`drivelash.report.te_figures`); the protocol itself never imports matplotlib.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import DataError
from drivelash.io.outputs import jsonable, write_json
from drivelash.te.protocol.bench import ModelDrive, ValidationConfig, compensator_for, table_for
from drivelash.te.protocol.monitoring import section_edges, section_mae
from drivelash.te.protocol.passes import pass_range, pass_trajectory, run_pass, score_pass
from drivelash.te.protocol.wear_demo import TreesUpdater, monitoring_demo
from drivelash.te.runtime.compensator import X_SLACK, Compensator, CompensatorParams
from drivelash.te.runtime.export import export_table
from drivelash.te.runtime.table import TEPredictor, TETable, measured_range

__all__ = [
    "acceptance",
    "band_rms",
    "constant_velocity_validation",
    "outside_by_section",
    "reversal_errors",
    "reversal_times",
    "sine_validation",
    "summarize_passes",
    "valid_range_report",
    "validate",
]


def constant_velocity_validation(
    sim: Any,
    table: TETable,
    params: CompensatorParams,
    velocities: tuple[float, ...],
    cfg: ValidationConfig,
    progress: Callable[[str], None] | None = None,
) -> list[dict[str, Any]]:
    """All passes of protocol (b); one row per (direction, velocity, load, section).

    Returns
    -------
    list of dict
        Keys ``direction, velocity, load, x_start, x_end, mae_uncomp_um, mae_comp_um, improvement,
        outside_share`` (share of the section's scored samples [-] where the compensator's set
        positions left its table and it held the table's edge value).
    """
    lo, hi = pass_range(sim, cfg)
    edges = section_edges(lo, hi, cfg.section_length)
    rows: list[dict[str, Any]] = []
    for d in cfg.directions:
        for v in velocities:
            _, x_d, v_d = pass_trajectory(sim, lo, hi, v, d)
            for F in cfg.loads:
                unc = run_pass(sim, x_d, v_d, F, None)
                comp = run_pass(sim, x_d, v_d, F, Compensator(table, params, d))
                mu, mc = score_pass(unc, comp, v, edges)
                held = outside_by_section(comp, v, edges)
                for i in range(edges.size - 1):
                    if not (np.isfinite(mu[i]) and np.isfinite(mc[i])):
                        continue
                    rows.append({
                        "direction": int(d),
                        "velocity": float(v),
                        "load": float(F),
                        "x_start": float(edges[i]),
                        "x_end": float(edges[i + 1]),
                        "mae_uncomp_um": float(mu[i] * 1e6),
                        "mae_comp_um": float(mc[i] * 1e6),
                        "improvement": float(1.0 - mc[i] / mu[i]),
                        "outside_share": float(held[i]),
                    })  # fmt: skip
                if progress is not None:
                    imp = [r["improvement"] for r in rows[-(edges.size - 1) :] if r["load"] == F]
                    progress(f"pass d={d:+d} v={v * 1e3:g} mm/s F={F:g} N: "
                             f"mean improvement {np.mean(imp):.1%}")  # fmt: skip
    return rows


def outside_by_section(comp: dict[str, np.ndarray], v: float, edges: np.ndarray) -> np.ndarray:
    """Share of the scored samples per section [-] (the constant-velocity part, as :func:`score_pass`)
    where the compensator held its table's edge value (``comp["outside"]`` of :func:`run_pass`)."""
    m = np.abs(np.abs(comp["v_d"]) - v) < 1e-9 * max(v, 1.0)
    return np.nan_to_num(section_mae(comp["x_T"][m], comp["outside"][m], edges, min_count=1))


def valid_range_report(
    valid: tuple[float, float],
    table: TETable,
    passes: tuple[float, float],
    outside: dict[str, float],
    rows: list[dict[str, Any]],
) -> dict[str, Any]:
    """What ``summary.json`` says about the valid range: where the model was measured, the table,
    the positions the passes used, and how much of each protocol ran outside the table.

    Parameters
    ----------
    valid : tuple of float
        The model's valid range [m] (:func:`~drivelash.te.runtime.table.measured_range`).
    table : TETable
        The compensator's table.
    passes : tuple of float
        Positions of the passes [m] (:func:`~drivelash.te.protocol.passes.pass_range`).
    outside : dict
        Protocol name → share of its compensation cycles [-] whose set positions left the table.
    rows : list of dict
        Section rows of protocol (b) (with ``outside_share``).
    """
    grid = table.x_grid
    held = [r for r in rows if r.get("outside_share", 0.0) > 0.0]
    return {
        "x_min": float(valid[0]),
        "x_max": float(valid[1]),
        "definition": "where the model was measured: the span the no-load runs of both directions"
        " covered ∩ the span the no-load curves hold data (drivelash.te.runtime.table.measured_range,"
        " the range te export writes)",
        "table_x_min": float(grid[0]),
        "table_x_max": float(grid[-1]),
        "passes_x_min": float(passes[0]),
        "passes_x_max": float(passes[1]),
        "beyond_table": "the compensator holds the table's edge value (no extrapolation; v_c,TE = 0"
        " there), as a SINUMERIK compensation table holds its first and last value",
        "cycles_outside_share": {k: float(v) for k, v in outside.items()},
        "sections_outside": len(held),
        "sections_scored": len(rows),
    }


def summarize_passes(rows: list[dict[str, Any]], train_max_load: float) -> dict[str, Any]:
    """Acceptance figures of protocol (b) from the section rows."""
    if not rows:
        raise DataError("no scored sections (passes too short for one section?)")
    imp = np.array([r["improvement"] for r in rows])
    load = np.array([r["load"] for r in rows])
    groups: dict[tuple[int, float, float], list[float]] = {}
    for r in rows:
        groups.setdefault((r["direction"], r["velocity"], r["load"]), []).append(r["improvement"])
    avg = {k: float(np.mean(v)) for k, v in groups.items()}
    inr = [v for k, v in avg.items() if k[2] <= train_max_load]
    out_r = [v for k, v in avg.items() if k[2] > train_max_load]
    pos = [r["improvement"] for r in rows if r["direction"] == 1]
    return {
        "average_improvement": float(np.mean(imp)),
        "average_improvement_positive_direction": float(np.mean(pos)) if pos else float("nan"),
        "min_in_range_pass_average": float(min(inr)) if inr else float("nan"),
        "min_beyond_range_pass_average": float(min(out_r)) if out_r else float("nan"),
        "mean_in_range": float(np.mean(imp[load <= train_max_load])) if inr else float("nan"),
        "mean_beyond_range": float(np.mean(imp[load > train_max_load]))
        if np.any(load > train_max_load)
        else float("nan"),  # fmt: skip
        "min_in_range_section": float(np.min(imp[load <= train_max_load])) if inr else float("nan"),
        "min_section": float(np.min(imp)),
        "pass_averages": [
            {"direction": k[0], "velocity": k[1], "load": k[2], "improvement": v}
            for k, v in sorted(avg.items())
        ],
    }


# ---------------------------------------------------------------------------
# (a) sinusoidal trajectory, Fig. 8


def reversal_times(t: np.ndarray, v_d: np.ndarray) -> np.ndarray:
    """Instants where the set velocity changes sign during the motion [s]."""
    s = np.sign(v_d)
    moving = np.flatnonzero(s != 0)
    if moving.size < 2:
        return np.zeros(0)
    sm = s[moving]
    k = np.flatnonzero(sm[1:] != sm[:-1])
    return t[moving[k + 1]]


def reversal_errors(res: dict[str, np.ndarray], window: tuple[float, float]) -> np.ndarray:
    """Peak |e| [m] in [t_r − before, t_r + after] around each reversal."""
    t = res["t"]
    out = []
    for tr in reversal_times(t, res["v_d"]):
        m = (t >= tr - window[0]) & (t <= tr + window[1])
        out.append(float(np.max(np.abs(res["e"][m]))))
    return np.array(out)


def band_rms(e: np.ndarray, fs: float, f_min: float = 50.0) -> float:
    """RMS of ``e`` in the band above ``f_min`` [unit of e] (Welch PSD, Hann, 1 s segments)."""
    from scipy import signal

    nper = min(e.size, int(fs))
    f, P = signal.welch(e - np.mean(e), fs=fs, nperseg=nper)
    df = f[1] - f[0]
    return float(np.sqrt(np.sum(P[f > f_min]) * df))


def sine_validation(
    sim: Any, table: TETable, params: CompensatorParams, cfg: ValidationConfig, load: float = 0.0
) -> tuple[dict[str, Any], dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Protocol (a): figures and both runs (uncompensated, compensated)."""
    from drivelash.sim.rack_axis import sine_trajectory

    lo, hi = pass_range(sim, cfg)
    xc = 0.5 * (lo + hi)
    amp = min(cfg.sine_amplitude, 0.5 * (hi - lo))
    _, x_d, v_d = sine_trajectory(xc, amp, cfg.sine_frequency, cfg.sine_periods, sim.T_s)
    unc = run_pass(sim, x_d, v_d, load, None)
    comp = run_pass(sim, x_d, v_d, load, Compensator(table, params, 1))
    ru = reversal_errors(unc, cfg.reversal_window)
    rc = reversal_errors(comp, cfg.reversal_window)
    fs = 1.0 / sim.T_s
    hf_u = band_rms(unc["e"], fs)
    hf_c = band_rms(comp["e"], fs)
    r = float(sim.bench.r_eff)
    dvc = np.diff(comp["v_c"][:: int(round(params.t_sc / sim.T_s))]) / params.t_sc
    J_s = float(sim.bench.J_s)
    figures = {
        "reversal_error_uncomp_um": (ru * 1e6).tolist(),
        "reversal_error_comp_um": (rc * 1e6).tolist(),
        "reversal_reduction": float(1.0 - np.max(rc) / np.max(ru)) if ru.size else float("nan"),
        "reversal_reduction_each": (1.0 - rc / ru).tolist() if ru.size else [],
        "mae_uncomp_um": float(np.mean(np.abs(unc["e"])) * 1e6),
        "mae_comp_um": float(np.mean(np.abs(comp["e"])) * 1e6),
        "hf_rms_uncomp_nm": hf_u * 1e9,
        "hf_rms_comp_nm": hf_c * 1e9,
        "hf_ratio": hf_c / hf_u if hf_u > 0 else float("nan"),
        "peak_v_c_mm_s": float(np.max(np.abs(comp["v_c"])) * 1e3),
        "v_c_limit_mm_s": params.v_max * 1e3,
        "peak_v_c_motor_rpm": float(np.max(np.abs(comp["v_c"])) / r * 60 / (2 * math.pi)),
        "peak_dv_c_dt_m_s2": float(np.max(np.abs(dvc))) if dvc.size else 0.0,
        "peak_v_c_torque_Nm": float(np.max(np.abs(dvc)) * J_s / r) if dvc.size else 0.0,
        "torque_limit_Nm": float(sim.gains.torque_limit),
        "reversals": int(ru.size),
        "cycles_outside_share": float(np.mean(comp["outside"])) if comp["outside"].size else 0.0,
    }
    return figures, unc, comp


def _table_torque_line(table: TETable, cfg: ValidationConfig) -> str:
    """The progress line that states the torque range of the compensation table ``validate``
    built and what set it: ``cfg.table_torque_max`` when given, else the training runs.

    Parameters
    ----------
    table : TETable
        The table of the validation.
    cfg : ValidationConfig
        Its settings (``table_torque_max`` [N·m], ``train_max_load`` [N]).

    Returns
    -------
    str
        E.g. ``"table torque range 0 … 6.79 N·m (the training runs' torque, loads up to 3000 N)"``.
    """
    span = max(float(np.max(np.abs(table.torque_grid(d)))) for d in (+1, -1))
    why = (
        "set by table_torque_max"
        if cfg.table_torque_max is not None
        else f"the training runs' torque, loads up to {cfg.train_max_load:g} N"
    )
    return f"table torque range 0 … {span:.2f} N·m ({why})"


def validate(
    model: TEPredictor,
    drive: Any,
    out_dir: Path,
    cfg: ValidationConfig | None = None,
    updater: TreesUpdater | None = None,
    progress: Callable[[str], None] | None = None,
    figures: Any = None,
) -> dict[str, Any]:
    """Run protocols (a)–(c) and write figures, tables and ``summary.json`` into ``out_dir``.

    Parameters
    ----------
    model : TEPredictor
        The fitted model (``predict(x_T, torque, direction)`` [m]).
    drive : ModelDrive or Campaign
        The virtual drive the model was trained on (:func:`~drivelash.te.protocol.bench.drive_for_model`,
        rebuilt from the model alone), or its training campaign.
    out_dir : pathlib.Path
        Output directory (created).
    cfg : ValidationConfig, optional
        Protocol settings.
    updater : TreesUpdater, optional
        A trainable model for the monitoring demo (fitted here on the campaign, then
        ``update(stage="trees")`` on passes over the worn rack); None runs the demo's
        detection half with ``model`` and skips the update.
    progress : callable, optional
        Receives one-line progress messages.
    figures : object, optional
        Draws the figures: ``fig_sine(unc, comp, r_eff, path, variant=...)``,
        ``fig_heatmaps(rows, train_max_load, path)`` and ``fig_monitor(before, after,
        defect, path)`` (:mod:`drivelash.report.te_figures`); None writes no figures.

    Returns
    -------
    dict
        The summary (also written to ``summary.json``).
    """
    if not isinstance(drive, ModelDrive):
        drive = ModelDrive(model, campaign=drive)
    valid = measured_range(model)
    cfg = (cfg or ValidationConfig()).resolved(float(drive.bench.travel), valid)
    say = progress or (lambda s: None)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    sim = drive.simulator()
    bench = sim.bench
    velocities = cfg.velocities or drive.velocities
    tq_max = drive.torque_max
    table = table_for(model, bench, cfg, meta={"axis": "rack-and-pinion table", "seed": drive.seed},
                      torque_max=tq_max)  # fmt: skip
    say(_table_torque_line(table, cfg))
    params = compensator_for(bench, table, cfg.compensator)
    export_table(table, out / "te_table.json", params)
    summary: dict[str, Any] = {"config": jsonable(asdict(cfg)), "compensator": asdict(params)}
    passes = pass_range(sim, cfg)
    say(f"valid range {valid[0] * 1e3:.3f} … {valid[1] * 1e3:.3f} mm (where the model was measured);"
        f" passes over {passes[0] * 1e3:.3f} … {passes[1] * 1e3:.3f} mm")  # fmt: skip
    if passes[0] < valid[0] - X_SLACK or passes[1] > valid[1] + X_SLACK:
        say("warning: the passes leave the valid range; there the compensator holds its table's edge"
            " value (summary.json: valid_range.cycles_outside_share)")  # fmt: skip

    say("(a) sinusoidal trajectory")
    sine, unc, comp = sine_validation(sim, table, params, cfg)
    if figures is not None:
        figures.fig_sine(
            unc, comp, float(bench.r_eff), out / "fig8_sine.png", variant="compensator as validated, no load"
        )
    summary["sine"] = sine
    # the paper's settings (t_ss = 35 ms, flank change on the torque sign only) for comparison,
    # and a loaded sine (load drive reversing with the motion) as a robustness check
    paper = dataclasses.replace(params, t_ss=35e-3, t_ss_sign=35e-3, release=0.0)
    sine_p, _, comp_p = sine_validation(sim, table, paper, cfg)
    if figures is not None:
        figures.fig_sine(
            unc,
            comp_p,
            float(bench.r_eff),
            out / "fig8_sine_paper_settings.png",
            variant="the paper's settings (t_ss = 35 ms, flank change on the torque sign only)",
        )
    summary["sine_paper_settings"] = sine_p
    sine_l, unc_l, comp_l = sine_validation(sim, table, params, cfg, load=cfg.sine_load)
    if figures is not None:
        figures.fig_sine(
            unc_l,
            comp_l,
            float(bench.r_eff),
            out / "fig8_sine_loaded.png",
            variant=f"loaded: load drive {cfg.sine_load:g} N reversing with the motion",
        )
    summary["sine_loaded"] = sine_l

    say("(b) constant-velocity passes")
    rows = constant_velocity_validation(sim, table, params, velocities, cfg, progress)
    _write_csv(rows, out / "improvement_sections.csv")
    if figures is not None:
        figures.fig_heatmaps(rows, cfg.train_max_load, out / "fig9_improvement.png")
    summary["passes"] = summarize_passes(rows, cfg.train_max_load)

    say("(c) monitoring with a local rack defect")
    summary["monitoring"] = monitoring_demo(drive, sim, table, params, cfg, out, updater, say, model, figures)
    outside = {k: summary[k]["cycles_outside_share"] for k in ("sine", "sine_paper_settings", "sine_loaded")}
    outside["passes"] = _weighted_outside(rows)
    outside["monitoring"] = summary["monitoring"]["cycles_outside_share"]
    summary["valid_range"] = valid_range_report(valid, table, passes, outside, rows)
    summary["acceptance"] = acceptance(summary)
    summary["wall_time_s"] = time.perf_counter() - t_start
    write_json(out / "summary.json", summary, indent=1)
    return summary


def acceptance(summary: dict[str, Any]) -> dict[str, Any]:
    """The issue's acceptance checks from a summary (value, limit, passed)."""
    p = summary["passes"]
    s = summary["sine"]
    m = summary["monitoring"]

    def chk(value: float, limit: float, ge: bool = True) -> dict[str, Any]:
        ok = bool(value >= limit) if ge else bool(value <= limit)
        return {"value": value, "limit": limit, "passed": ok}

    out = {
        "average_improvement": chk(p["average_improvement"], 0.75),
        "min_in_range_pass_average": chk(p["min_in_range_pass_average"], 0.60),
        "min_beyond_range_pass_average": chk(p["min_beyond_range_pass_average"], 0.35),
        "reversal_reduction": chk(s["reversal_reduction"], 0.80),
        "peak_v_c_within_limit": chk(s["peak_v_c_mm_s"], s["v_c_limit_mm_s"], ge=False),
        "hf_ratio_above_50Hz": chk(s["hf_ratio"], 1.0, ge=False),
        "monitor_defect_covered": {"value": m["defect_covered"], "passed": bool(m["defect_covered"])},
        "monitor_false_sections_per_m": chk(m["false_sections_per_m"], 1.0, ge=False),
    }
    if "improvement_defect_section_after_update" in m:
        out["update_restores_defect_section"] = chk(
            m["improvement_defect_section_after_update"], m["improvement_mean_before_update"] - 0.1
        )
    if "defect_flagged_after_update" in m:
        # the monitor must no longer flag the defect once update(stage="trees") has learnt it
        cleared = not m["defect_flagged_after_update"]
        out["monitor_cleared_after_update"] = {"value": cleared, "passed": cleared}
    return out


def _weighted_outside(rows: list[dict[str, Any]]) -> float:
    """Share of protocol (b)'s scored samples [-] outside the table (sections weighted by length)."""
    w = np.array([r["x_end"] - r["x_start"] for r in rows])
    share = np.array([r["outside_share"] for r in rows])
    return float(np.sum(w * share) / np.sum(w)) if rows else 0.0


def _write_csv(rows: list[dict[str, Any]], path: Path) -> None:
    import csv

    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
