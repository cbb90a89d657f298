"""HTML reports of ``estimate``, ``identify`` and ``observe`` runs.

One self-contained file per run (figures as embedded PNGs, no scripts, no network):

- :func:`write_estimate_report` — deadzone estimation: trace overview, δ̂(t) with the
  excitation verdict shaded, estimated shaft torque vs Δθ (deadzone picture),
  motor/load hysteresis and phase portraits, parameter and figure-of-merit tables;
- :func:`write_identify_report` — IDIM-LS: measured vs predicted force, residual,
  friction characteristic, parameter table with standard deviations, cross-test;
- :func:`write_observe_report` — disturbance observer on one axis.

``render_*`` return the HTML text; ``write_*`` also write it atomically.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.report.html import Figure, Section, render_html, significant_decimals
from drivelash.report.save import save_figure
from drivelash.units import GapUnit, gap_unit

__all__ = [
    "render_estimate_report",
    "render_identify_report",
    "render_observe_report",
    "save_figure",
    "write_estimate_report",
    "write_identify_report",
    "write_observe_report",
]

_MAX_POINTS = 6000


def _thin(*arrays: np.ndarray, n: int = _MAX_POINTS) -> list[np.ndarray]:
    """Every k-th sample so plots stay light (PNG size) — plots only, never analysis."""
    size = len(arrays[0])
    k = max(1, size // n)
    return [np.asarray(a)[::k] for a in arrays]


def _units(trace: Any) -> GapUnit:
    """The recording's units (:func:`drivelash.units.gap_unit` of its ``meta["axis"]``): rad,
    rad/s, N·m, kg·m² … on a rotary axis; m, m/s, N, kg … on a prismatic one, gaps in mrad or µm."""
    return gap_unit(trace.meta.get("axis"))


#: an ISO 8601 time that ends in a zone (``Z``, ``+01:00``)
_ZONED = re.compile(r"(Z|[+-]\d{2}:?\d{2})$")


def _recording_html(trace: Any) -> list[str]:
    """The recording's start (a time-stamp column's first stamp) and its load warnings."""
    import html

    start = []
    for col, stamp in trace.meta.get("time_origin", {}).items():
        zone = "" if _ZONED.search(str(stamp)) else " (no time zone in the file)"
        start.append(
            f"<p>Recorded from {html.escape(str(stamp))}{zone} — the first time stamp of column"
            f" {html.escape(repr(str(col)))}; the time axis is in seconds from it.</p>"
        )
    return start + [f'<div class="warn">{html.escape(w)}</div>' for w in trace.meta.get("warnings", [])]


def _overview_figure(trace: Any, N: float | None = None) -> Figure:
    """The recording's positions, velocities and torque against time. With a gear ratio ``N``
    (≠ 1) and a load encoder, the motor side is drawn at the load (θ_m/N, ω_m/N) beside θ_l,
    ω_l: on one axis θ_m would dwarf θ_l by N (a robot axis: N = 257, θ_l a flat line)."""
    u = _units(trace)
    names = [n for n in ("theta_m", "theta_l", "omega_m", "omega_l", "torque_m") if n in trace]
    geared = N is not None and math.isfinite(N) and N > 0 and N != 1.0 and "theta_l" in trace

    def draw(fig: Any) -> None:
        groups = [
            [n for n in names if n.startswith("theta")],
            [n for n in names if n.startswith("omega")],
            [n for n in names if n.startswith("torque")],
        ]
        groups = [g for g in groups if g] or [[n for n in trace.names if n != "t"][:1]]
        axes = fig.subplots(len(groups), 1, sharex=True, squeeze=False)[:, 0]
        labels = {
            "theta": f"position [{u.si}]",
            "omega": f"velocity [{u.velocity}]",
            "torque": f"{u.effort} [{u.torque}]",
        }
        for ax, g in zip(axes, groups, strict=True):
            for n in g:
                scale = N if geared and n.endswith("_m") and not n.startswith("torque") else None
                t, y = _thin(trace["t"], trace[n] / scale if scale else trace[n])
                ax.plot(t, y, lw=0.8, label=f"{n} / N (N = {scale:.6g})" if scale else n)
            label = labels.get(g[0].split("_")[0], g[0])
            ax.set_ylabel(
                label.replace(" [", ", load side [") if geared and g[0][:5] in ("theta", "omega") else label
            )
            ax.grid(alpha=0.3)
            ax.legend(loc="upper right", fontsize=8)
        axes[-1].set_xlabel("time [s]")

    return Figure("overview", "Recording overview (SI units after mapping).", draw, (10, 2.2 * 3))


# --------------------------------------------------------------------------- estimate
def _excited_spans(t: np.ndarray, mask: np.ndarray) -> list[tuple[float, float]]:
    if not mask.any():
        return []
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [(float(t[a]), float(t[b])) for a, b in zip(starts, stops, strict=True)]


def render_estimate_report(
    trace: Any, result: Any, config: Any = None, *, title: str | None = None, summary: dict | None = None
) -> str:
    """HTML of a deadzone-estimation run.

    Parameters
    ----------
    trace : Trace
        The recording the estimator ran on.
    result : EstimationResult
        From :class:`drivelash.estimation.estimator.DeadzoneEstimator` (δ̂(t), φ̂(t), ω̂_l(t),
        σ-window(t), Δθ, torques, verdict).
    config : DriveConfig, optional
        The configuration used (parameter table).
    title : str, optional
        Page title; default ``"drivelash estimate — <trace source>"``.
    summary : dict, optional
        The command's JSON: its ``warnings`` (the estimator's, as the terminal prints them;
        without a summary the result's ``warnings``) are shown under the verdict; with
        ``estimate --identify`` its offline δ with the 95 % interval, the agreement verdict and
        the drive the estimator was given (``drivetrain_used``, ``delta1_used``) are shown
        beside the configuration, which then lacks them.
    """
    summary = summary or {}
    u = _units(trace)  # gaps in mrad, or µm on a prismatic axis (positions in m, force in N)
    k = u.per_si
    t = np.asarray(result.t)
    dh = np.asarray(result.delta_hat)
    sw = np.asarray(getattr(result, "sigma_window", np.zeros_like(t)))
    excited = sw > 0.05 * float(np.max(sw)) if sw.size and np.max(sw) > 0 else np.zeros(t.size, bool)
    delta_true = trace["delta_true"] if "delta_true" in trace and len(trace) == t.size else None
    ok = bool(getattr(result, "excitation_ok", False))

    def draw_delta(fig: Any) -> None:
        ax = fig.subplots()
        for a, b in _excited_spans(t, excited):
            ax.axvspan(a, b, color="#bfe3c6", alpha=0.6, lw=0)
        tt, yy = _thin(t, dh * k)
        ax.plot(tt, yy, color="#2a6fb0", lw=1.2, label="δ̂ (estimate)")
        if delta_true is not None:
            tt, yy = _thin(t, delta_true * k)
            ax.plot(tt, yy, "k--", lw=1, label="δ (true)")
        ax.set_xlabel("time [s]")
        ax.set_ylabel(f"deadzone [{u.symbol}]")
        from drivelash.report.estimation_figures import verdict_text

        verdict = verdict_text(result)
        ax.set_title(f"δ̂(t); shaded: informative samples (σ-window > 5 % of max) — {verdict}", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(loc="lower right", fontsize=8)

    dtheta = np.asarray(getattr(result, "dtheta", np.zeros_like(t)))
    tq_meas = np.asarray(getattr(result, "torque_meas", np.zeros_like(t)))
    tq_hat = np.asarray(getattr(result, "torque_hat", np.zeros_like(t)))

    k_s, delta1 = None, None
    if config is not None and getattr(config, "drivetrain", None) is not None:
        k_s = config.drivetrain.K_S
    if k_s is None and isinstance(summary.get("drivetrain_used"), dict):
        k_s = summary["drivetrain_used"].get("K_S")  # identified (estimate --identify)
    if config is not None and getattr(config, "backlash", None) is not None:
        delta1 = config.backlash.delta1
    extra_est = getattr(result, "extra", {}) or {}
    # the lower contact the estimator ended with (the configured δ1, or the one the data gave when
    # the δ1 check switched), and its learned stiffness scale: the line is the model δ̂ belongs to
    d1_used = extra_est.get("delta1_used")
    if isinstance(d1_used, int | float) and np.isfinite(d1_used):
        delta1 = float(d1_used)
    kappa = extra_est.get("stiffness_scale")
    kappa = float(kappa) if isinstance(kappa, int | float) and np.isfinite(kappa) and kappa > 0 else 1.0

    def draw_deadzone(fig: Any) -> None:
        ax = fig.subplots()
        half = slice(t.size // 2, None)  # second half: δ̂ has settled
        x, y1 = _thin(dtheta * k, tq_meas)
        ax.plot(x, y1, ".", ms=1.5, alpha=0.35, color="#888", label="J_l φ̂ (observed)")
        xh, yh = _thin(dtheta[half] * k, tq_hat[half])
        ax.plot(xh, yh, ".", ms=1.5, alpha=0.5, color="#e67e22", label="T_l(x, δ̂), second half")
        if k_s is not None and delta1 is not None and dh.size:
            d_fin = float(getattr(result, "delta", dh[-1]))  # the reported δ̂ (the JSON's)
            k_eff = kappa * k_s
            grid = np.linspace(float(np.min(dtheta)), float(np.max(dtheta)), 800)
            static = np.where(
                grid < -delta1,
                k_eff * (grid + delta1),
                np.where(grid > d_fin - delta1, k_eff * (grid + delta1 - d_fin), 0.0),
            )
            k_txt = "K_S" if kappa == 1.0 else f"κ K_S, κ = {kappa:.2f}"
            label = f"deadzone with final δ̂ ({k_txt}, δ1 = {u.f(delta1)})"
            ax.plot(grid * k, static, color="#c0392b", lw=1.5, label=label)
            ax.axvspan(-delta1 * k, (d_fin - delta1) * k, color="#f3e5c8", alpha=0.4, lw=0)
        lo, hi = np.percentile(np.concatenate([y1, yh]), [0.5, 99.5]) if y1.size else (0.0, 1.0)
        pad = 0.15 * (hi - lo) + 1e-9
        ax.set_ylim(lo - pad, hi + pad)
        ax.axvline(0, color="k", lw=0.5)
        ax.set_xlabel(f"Δθ = θ_m/N − θ_l [{u.symbol}]")
        ax.set_ylabel(f"shaft {u.effort} [{u.torque}]")
        ax.set_title(f"Estimated {u.effort} vs Δθ (deadzone picture)", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)

    n_gear = 1.0
    if config is not None and getattr(config, "drivetrain", None) is not None and config.drivetrain.N:
        n_gear = float(config.drivetrain.N)

    def draw_portraits(fig: Any) -> None:
        axes = fig.subplots(1, 3)
        if "theta_m" in trace and "theta_l" in trace:
            x, y = _thin(trace["theta_m"] / n_gear, trace["theta_l"])
            axes[0].plot(x, y, lw=0.6)
            axes[0].set_xlabel(f"θ_m/N [{u.si}]")
            axes[0].set_ylabel(f"θ_l [{u.si}]")
            axes[0].set_title("motor/load hysteresis", fontsize=10)
        for ax, side in ((axes[1], "m"), (axes[2], "l")):
            if f"theta_{side}" in trace and f"omega_{side}" in trace:
                x, y = _thin(trace[f"theta_{side}"], trace[f"omega_{side}"])
                ax.plot(x, y, lw=0.6, color="#2a6fb0" if side == "m" else "#c0392b")
                ax.set_xlabel(f"θ_{side} [{u.si}]")
                ax.set_ylabel(f"ω_{side} [{u.velocity}]")
                ax.set_title(f"phase portrait, {'motor' if side == 'm' else 'load'}", fontsize=10)
        for ax in axes:
            ax.grid(alpha=0.3)

    def draw_observer(fig: Any) -> None:
        axes = fig.subplots(2, 1, sharex=True)
        tt, ph = _thin(t, np.asarray(result.phi_hat))
        axes[0].plot(tt, ph, lw=0.7)
        axes[0].set_ylabel(f"φ̂ [{u.acceleration}]")
        tt, sws = _thin(t, sw)
        axes[1].plot(tt, sws, lw=0.9, color="#1f7a35")
        axes[1].set_ylabel("∫σ over window [s]")
        axes[1].set_xlabel("time [s]")
        for ax in axes:
            ax.grid(alpha=0.3)

    dt = getattr(config, "drivetrain", None)
    N_cfg = dt.given().get("N") if dt is not None and hasattr(dt, "given") else None
    sec_over = Section("Recording", raw=_recording_html(trace), figures=[_overview_figure(trace, N_cfg)])
    cls = "verdict-ok" if ok else "verdict-bad"
    verdict_html = (
        f'<p class="{cls}">Excitation: {"sufficient" if ok else "insufficient"} — '
        f"{_esc(getattr(result, 'reason', ''))}</p>"
    )
    # the reported estimate (the JSON's δ̂), not the last point of the (decimated) series
    d_final = float(getattr(result, "delta", dh[-1] if dh.size else float("nan")))
    sym = u.symbol
    figs_rows: list[list[Any]] = [[f"final δ̂ [{sym}]", k * d_final]]
    lo, hi = getattr(result, "delta_interval", (float("nan"), float("nan")))
    if np.isfinite(lo) and np.isfinite(hi):
        label = f"95 % interval of δ̂ [{sym}]"
        if not bool(getattr(result, "converged", False)):  # as the terminal says: do not use it
            label += " (statistical only; not converged: do not use)"
        figs_rows.append([label, f"[{k * lo:.3f}, {k * hi:.3f}]"])
    figs_rows += [
        ["converged", str(bool(getattr(result, "converged", False)))],
        [
            "convergence time [s]",
            float(result.convergence_time_s)
            if getattr(result, "convergence_time_s", None) is not None
            else "–",
        ],
        [f"band [{sym}]", k * float(getattr(result, "band", float("nan")))],
    ]
    if delta_true is not None:
        figs_rows.append([f"true δ (final) [{sym}]", k * float(delta_true[-1])])
        figs_rows.append(["error of final δ̂ [%]", 100 * (d_final / float(delta_true[-1]) - 1)])
    ident = summary.get("identification") or {}
    off = ident.get("delta") or {}
    if off.get("identifiable") and off.get("value") is not None:
        figs_rows.append([f"offline δ (identified) [{sym}]", k * float(off["value"])])
        ci = off.get("ci95")
        if ci and all(c is not None for c in ci):
            figs_rows.append([f"95 % interval of offline δ [{sym}]", f"[{k * ci[0]:.3f}, {k * ci[1]:.3f}]"])
    agreement = summary.get("agreement")
    if isinstance(agreement, dict) and agreement.get("disagree") is not None:
        figs_rows.append(
            ["online vs offline", "disagree (beyond the intervals)" if agreement["disagree"] else "agree"]
        )
    # the estimator's own statistics, as in the JSON's "extra" (SI units, not converted)
    extra = getattr(result, "extra", {}) or {}
    diag_rows = [[k, v] for k, v in extra.items() if isinstance(v, int | float | str | bool)]
    # the estimator's warnings, as the terminal and the JSON give them ("… the estimate is not a
    # measurement"); the reader's are shown with the recording
    loaded = set(trace.meta.get("warnings", []))
    said = summary["warnings"] if "warnings" in summary else getattr(result, "warnings", None)
    est_warn = [
        f'<div class="warn">{_esc(w)}</div>' for w in said or [] if isinstance(w, str) and w not in loaded
    ]
    sec_est = Section(
        "Deadzone estimate",
        raw=[verdict_html, *est_warn],
        tables=[
            ("Figures of merit", ["quantity", "value"], figs_rows),
            (
                f"Estimator diagnostics (the JSON's extra), SI units: {u.si}, {u.velocity}, {u.torque}, s",
                ["key", "value"],
                diag_rows,
            ),
        ],
        figures=[
            Figure("delta", "Deadzone estimate over time; green: excitation present.", draw_delta, (10, 3.6)),
            Figure(
                "deadzone",
                f"Observed and modelled shaft {u.effort} against the deflection.",
                draw_deadzone,
                (8, 4.5),
            ),
            Figure("portraits", "Hysteresis and phase portraits.", draw_portraits, (12, 3.8)),
            Figure("observer", "Perturbation estimate and the excitation measure.", draw_observer, (10, 4)),
        ],
    )
    used_tables: list[tuple[str, list[str], list[list[Any]]]] = []
    dt_used = summary.get("drivetrain_used")
    if isinstance(dt_used, dict) and dt_used:
        src = " (identified from the recording)" if ident else ""
        rows = [[k, v] for k, v in dt_used.items() if isinstance(v, int | float)]
        if summary.get("delta1_used") is not None:
            d1_src = summary.get("delta1_source")
            rows.append([f"delta1 (used{', from ' + str(d1_src) if d1_src else ''})", summary["delta1_used"]])
            if summary.get("delta1_std") is not None:  # an identified δ1: carried into δ̂'s interval
                rows.append(["delta1 standard uncertainty", summary["delta1_std"]])
                how = "measured" if summary.get("delta1_sensitivity_measured") else "assumed"
                rows.append([f"dδ̂/d(delta1) ({how})", summary.get("delta1_sensitivity")])
        used_tables.append((f"drive the estimator was given{src}, SI units", ["key", "value"], rows))
    cfg_tables = _param_tables(config, getattr(result, "config", None))
    sec_par = Section("Parameters", tables=used_tables + cfg_tables)
    return render_html(
        title or f"drivelash estimate — {trace.meta.get('source', 'trace')}", [sec_over, sec_est, sec_par]
    )


def _esc(s: Any) -> str:
    import html

    return html.escape(str(s))


def _param_tables(config: Any, est_config: Any = None) -> list[tuple[str, list[str], list[list[Any]]]]:
    tables: list[tuple[str, list[str], list[list[Any]]]] = []
    if config is not None:
        for name in ("drivetrain", "backlash", "estimator", "identification", "sampling"):
            sec = getattr(config, name, None)
            if sec is None:
                continue
            given = getattr(sec, "model_fields_set", None)
            rows = [
                [k, v, "given" if given is None or k in given else "default"]
                for k, v in sec.model_dump().items()
                if v is not None
            ]
            if rows:  # a default the configuration never set is named as such
                tables.append((f"[{name}]", ["key", "value", "source"], rows))
        if getattr(config, "columns", None):
            rows = [
                [src, cm.column, cm.unit, cm.gain if cm.gain is not None else "", cm.counts_per_rev or ""]
                for src, cm in config.columns.items()
            ]
            tables.append(("[columns]", ["source", "Trace column", "unit", "gain", "counts/rev"], rows))
    if est_config is not None and hasattr(est_config, "to_dict"):
        rows = [[k, v] for k, v in est_config.to_dict().items() if isinstance(v, int | float | str | bool)]
        tables.append(("estimator gains used", ["gain", "value"], rows))
    return tables


def write_estimate_report(
    path: str | Path, trace: Any, result: Any, config: Any = None, *, summary: dict | None = None
) -> Path:
    """Write the estimation report (see :func:`render_estimate_report`) atomically; returns the path.

    Parameters
    ----------
    path : str or Path
        The ``.html`` file.
    trace, result, config, summary
        As for :func:`render_estimate_report`.
    """
    return _write(path, render_estimate_report(trace, result, config, summary=summary))


# --------------------------------------------------------------------------- identify
def render_identify_report(
    trace: Any,
    result: Any,
    config: Any = None,
    *,
    cross: Any = None,
    cross_trace: Any = None,
    observer: Any = None,
) -> str:
    """HTML of an identification: an IDIM-LS run (``result`` from :mod:`drivelash.estimation.identify`)
    or what :func:`drivelash.identify_drive` returns (either model), as the command writes it.

    Parameters
    ----------
    trace : Trace
        The recording identified.
    result : IdentifyResult or DriveIdentification
        The identification.
    config : DriveConfig, optional
        Its configuration (drawn as tables).
    cross, cross_trace : optional
        Cross-test result and its recording.
    observer : DisturbanceEstimate, optional
        STSMO disturbance on the same recording with the identified M and F_v; drawn
        against the identified F_c sign q̇ + offset.
    """
    from drivelash.estimation.identify_result import DriveIdentification

    if isinstance(result, DriveIdentification):  # the notebook API's result (identify_drive)
        if result.model != "rigid":
            from drivelash.report.identify_figures import render_two_mass_report

            return render_two_mass_report(trace, result, config)
        result = result.source
    u = _units(trace)
    unit_of = {
        "M": u.mass,
        "J_l": u.mass,
        "F_v": u.viscous,
        "beta_l": u.viscous,
        "F_c": u.torque,
        "T_Cl": u.torque,
        "offset": u.torque,
    }
    rows = [
        [n, unit_of.get(n, ""), float(v), float(s), 100 * float(s) / abs(float(v)) if v else float("nan")]
        for n, v, s in zip(result.names, result.theta, result.std, strict=True)
    ]
    stats = [
        ["relative force error ‖y − Wθ̂‖/‖y‖ [%]", 100 * result.relative_error],
        [f"residual std σ̂ [{u.torque}]", result.sigma],
        ["condition number of W", result.condition],
        ["rows after decimation", result.n_rows],
    ]
    stats += [[f"option {k}", v] for k, v in result.options.items()]
    if cross is not None:
        stats.append(
            [
                f"cross-test error [%] on {cross_trace.meta.get('source', '') if cross_trace else ''}",
                100 * cross.relative_error,
            ]
        )

    def draw_fit(fig: Any) -> None:
        axes = fig.subplots(2, 1, sharex=True, height_ratios=[3, 1])
        axes[0].plot(result.t, result.y, lw=0.9, label="measured (decimated)")
        axes[0].plot(result.t, result.y_hat, "--", lw=0.9, label="IDIM-LS model Wθ̂")
        axes[0].set_ylabel(f"force/torque [{u.torque}]")
        axes[0].legend(fontsize=8, loc="upper right")
        axes[1].plot(result.t, result.y - result.y_hat, lw=0.7, color="k")
        axes[1].set_ylabel(f"residual [{u.torque}]")
        axes[1].set_xlabel("time [s]")
        for ax in axes:
            ax.grid(alpha=0.3)

    def draw_friction(fig: Any) -> None:
        ax = fig.subplots()
        i_m = result.names.index(result.names[0])
        m = float(result.theta[i_m])
        # friction part of the measurement: y − M q̈ against q̇
        fr = result.y - m * result.q_ddot
        ax.plot(result.q_dot, fr, ".", ms=2, alpha=0.4, color="#888", label="y − M q̈ (data)")
        v = np.linspace(float(np.min(result.q_dot)), float(np.max(result.q_dot)), 400)
        model = result.theta[1] * v + result.theta[2] * np.sign(v) + result.theta[3]
        ax.plot(v, model, color="#c0392b", lw=1.5, label="F_v q̇ + F_c sign q̇ + offset")
        ax.set_xlabel(f"velocity [{u.velocity}]")
        ax.set_ylabel(f"friction {u.effort} [{u.torque}]")
        ax.set_title("Friction characteristic", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)

    figs = [
        Figure("fit", "Measured and predicted force/torque (decimated) and residual.", draw_fit, (10, 4.5)),
        Figure("friction", "Identified friction against the data.", draw_friction, (7, 4)),
    ]
    if cross is not None:

        def draw_cross(fig: Any) -> None:
            ax = fig.subplots()
            ax.plot(cross.t, cross.y, lw=0.9, label="measured")
            ax.plot(cross.t, cross.y_hat, "--", lw=0.9, label="model with identified parameters")
            ax.set_xlabel("time [s]")
            ax.set_ylabel(f"{u.effort} [{u.torque}]")
            ax.set_title(f"Cross-test: relative error {100 * cross.relative_error:.2f} %", fontsize=10)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)

        figs.append(Figure("cross", "Cross-test on the validation recording.", draw_cross, (10, 3.5)))
    if observer is not None and result.side == "motor":
        f_c, off = float(result["F_c"]), float(result["offset"])

        def draw_obs(fig: Any) -> None:
            ax = fig.subplots()
            t, d, v, cv = _thin(
                observer.t, observer.disturbance, observer.velocity, observer.constant_velocity
            )
            ax.plot(t, d, lw=0.6, color="#2a6fb0", label="d̂ = −M φ̂ (STSMO)")
            ax.plot(
                t, f_c * np.sign(v) + off, lw=1.2, color="#c0392b", label="identified F_c sign q̇ + offset"
            )
            ax.plot(t[cv], d[cv], ".", ms=1.2, color="#1f7a35", label="constant-velocity samples")
            ax.set_xlabel("time [s]")
            ax.set_ylabel(f"disturbance [{u.torque}]")
            shown = (observer.mean_positive, observer.mean_negative, f_c + off, -f_c + off)
            nd = significant_decimals(shown)
            ax.set_title(
                f"Observer: mean {shown[0]:.{nd}f} / {shown[1]:.{nd}f} {u.torque}"
                f" at constant velocity vs {shown[2]:.{nd}f} / {shown[3]:.{nd}f} identified",
                fontsize=10,
            )
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8, loc="upper right")

        figs.append(
            Figure(
                "observer",
                "Super-twisting disturbance observer against identified friction.",
                draw_obs,
                (10, 3.8),
            )
        )
    sections = [
        Section("Recording", raw=_recording_html(trace), figures=[_overview_figure(trace)]),
        Section(
            f"IDIM-LS, {result.side} side",
            paragraphs=[
                "Model τ = M q̈ + F_v q̇ + F_c sign(q̇) + offset; position low-passed with a zero-phase "
                "Butterworth filter, central differences, parallel decimation of W and τ; "
                "standard deviations σ̂ √diag((WᵀW)⁻¹)."
            ],
            tables=[
                ("Identified parameters", ["parameter", "unit", "value", "std", "std [%]"], rows),
                ("Statistics", ["quantity", "value"], stats),
            ],
            figures=figs,
        ),
        Section("Configuration", tables=_param_tables(config)),
    ]
    return render_html(f"drivelash identify — {trace.meta.get('source', 'trace')}", sections)


def write_identify_report(path: str | Path, trace: Any, result: Any, config: Any = None, **kw: Any) -> Path:
    """Write the identification report atomically; returns the path.

    Parameters
    ----------
    path : str or Path
        The ``.html`` file.
    trace, result, config
        As for :func:`render_identify_report`.
    **kw
        ``cross``, ``cross_trace``, ``observer`` of :func:`render_identify_report`.
    """
    return _write(path, render_identify_report(trace, result, config, **kw))


# --------------------------------------------------------------------------- observe
def render_observe_report(
    trace: Any,
    est: Any,
    config: Any = None,
    *,
    expected: Any = None,
    expected_label: str = "identified friction",
) -> str:
    """HTML of a disturbance-observer run.

    ``est`` comes from :func:`drivelash.estimation.identify.observe_disturbance`.

    Parameters
    ----------
    trace : Trace
        The recording the observer ran on (its units — rotary or linear axis — label the plots).
    est : DisturbanceEstimate
        The observer's output: t [s], velocity, disturbance d̂ [N·m] ([N] on a linear axis).
    config : DriveConfig, optional
        The configuration used (parameter table).
    expected : callable, optional
        ``expected(velocity) -> array``: a reference disturbance (e.g. identified
        F_c sign q̇ + offset) drawn for comparison, labelled ``expected_label``.
    expected_label : str
        Legend label of ``expected``.
    """
    u = _units(trace)
    ref = None
    if expected is not None:
        ref = expected(est.velocity)

    def draw(fig: Any) -> None:
        axes = fig.subplots(2, 1, sharex=True)
        t, d, v, cv = _thin(est.t, est.disturbance, est.velocity, est.constant_velocity)
        axes[0].plot(t, d, lw=0.6, color="#2a6fb0", label="d̂ (STSMO)")
        if ref is not None:
            (r,) = _thin(ref)
            axes[0].plot(t, r, lw=1.0, color="#c0392b", label=expected_label)
        axes[0].plot(t[cv], d[cv], ".", ms=1.5, color="#1f7a35", label="constant-velocity samples")
        axes[0].set_ylabel(f"disturbance [{u.torque}]")
        axes[0].legend(fontsize=8, loc="upper right")
        axes[1].plot(t, v, lw=0.8)
        axes[1].set_ylabel(f"velocity [{u.velocity}]")
        axes[1].set_xlabel("time [s]")
        for ax in axes:
            ax.grid(alpha=0.3)

    labels = {
        "J": f"J, inertia assumed [{u.mass}]",
        "beta": f"β, viscous friction assumed [{u.viscous}]",
        "k1": "k1, STSMO gain",
        "k2": "k2, STSMO gain",
        "mean_disturbance_forward": f"mean d̂, forward constant-velocity stretches [{u.torque}]",
        "mean_disturbance_backward": f"mean d̂, backward constant-velocity stretches [{u.torque}]",
        "constant_velocity_samples": "constant-velocity samples",
    }
    rows = [[labels.get(k, k), v] for k, v in est.as_dict().items()]
    sections = [
        Section("Recording", raw=_recording_html(trace), figures=[_overview_figure(trace)]),
        Section(
            "Disturbance observer (super-twisting)",
            paragraphs=[
                "Model J q̈ = u − β q̇ − d; the STSMO estimates d̂ = −J φ̂: Coulomb friction, "
                "offset and any external load."
            ],
            tables=[("Summary", ["quantity", "value"], rows)],
            figures=[Figure("disturbance", "Estimated disturbance and velocity.", draw, (10, 5))],
        ),
        Section("Configuration", tables=_param_tables(config)),
    ]
    return render_html(f"drivelash observe — {trace.meta.get('source', 'trace')}", sections)


def write_observe_report(path: str | Path, trace: Any, est: Any, config: Any = None, **kw: Any) -> Path:
    """Write the observer report atomically; returns the path.

    Parameters
    ----------
    path : str or Path
        The ``.html`` file.
    trace, est, config
        As for :func:`render_observe_report`.
    **kw
        ``expected``, ``expected_label`` of :func:`render_observe_report`.
    """
    return _write(path, render_observe_report(trace, est, config, **kw))


def _write(path: str | Path, text: str) -> Path:
    from drivelash.io.outputs import write_target

    p = Path(path)
    with write_target(p) as w:
        w.write_text(text, encoding="utf-8")
    return p
