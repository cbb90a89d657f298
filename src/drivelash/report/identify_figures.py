"""HTML report of a two-mass identification (:func:`drivelash.identify_drive`, model "two-mass").

Sections: verdict (can the backlash be seen, warnings), parameter table with 95 % intervals
or the reason a parameter is not identifiable, the deadzone characteristic (shaft torque
seen by the motor against Δθ, with the identified contacts), fit and residuals of both
equations, residual autocorrelation (why the intervals are HAC), correlation matrix, and
optionally the online estimate run with the identified parameters.
"""

from __future__ import annotations

import html
import math
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.report import _overview_figure, _param_tables, _recording_html, _thin, _write
from drivelash.report.html import Figure, Section, render_html
from drivelash.units import gap_unit

#: The fit table's "window chosen" row for a result without ``fit["window_rule"]`` (the window
#: actually used, :func:`drivelash.estimation.identify_two_mass.window_rule`) nor an "auto" choice.
WINDOW_FIXED = "fixed ([identification] window; default 1 ms)"


def _fmt_param(p: Any) -> list[Any]:
    if not p.identifiable:
        bound = ""
        if math.isfinite(p.low) or math.isfinite(p.high):
            bound = p.interval_text(4)
        return [p.name, p.unit, "not identifiable", "", bound, p.reason]
    rel = 100 * p.std / abs(p.value) if p.value else float("nan")
    return [
        p.name,
        p.unit,
        p.value,
        p.std,
        p.interval_text(),
        f"{rel:.3g} %" + (f" — {p.note}" if p.note else ""),
    ]


def _acf(x: np.ndarray, lags: int) -> np.ndarray:
    x = np.asarray(x, dtype=float) - np.mean(x)
    v = float(x @ x)
    if v <= 0 or x.size < 3:
        return np.zeros(lags + 1)
    return np.array([1.0] + [float(x[k:] @ x[:-k]) / v for k in range(1, lags + 1)])


def render_two_mass_report(
    trace: Any, result: Any, config: Any = None, *, online: Any = None, online_not_run: str | None = None
) -> str:
    """HTML of a two-mass identification.

    Parameters
    ----------
    trace : Trace
        The recording identified.
    result : DriveIdentification
        From :func:`drivelash.identify_drive` with ``model="two-mass"``.
    config : DriveConfig, optional
        Shown as tables.
    online : EstimationResult, optional
        Online deadzone estimate run with the identified parameters (drawn against the
        offline δ and its interval).
    online_not_run : str, optional
        ``estimate --identify --report`` when the online law could not run: why (the JSON's
        reason). The page then says first that there is no online estimate and why, and that
        it holds the offline identification only.
    """
    sig = result.signals
    p = result.parameters
    # Δθ, δ in mrad and torques in N·m — or µm and N on a linear axis (session 34, G1)
    gu = gap_unit(getattr(result, "axis", None))
    acc = gu.acceleration
    verdict_cls = "verdict-ok" if result.backlash_visible else "verdict-bad"
    raw = _recording_html(trace)
    if online_not_run:
        online_not_run = online_not_run.removeprefix("online estimate not run: ")  # said once
        raw.insert(
            0,
            '<p class="verdict-bad">No online deadzone estimate: '
            f"{html.escape(online_not_run)}. This report holds the offline identification only.</p>",
        )
    raw.append(f'<p class="{verdict_cls}">{html.escape(result.verdict[:1].upper() + result.verdict[1:])}</p>')
    raw += [f'<div class="warn">{html.escape(w)}</div>' for w in result.warnings]
    raw += [f'<div class="warn">{html.escape(n)}</div>' for n in result.fit.get("notes", [])]
    rows = [_fmt_param(q) for q in p.values()]
    fit = result.fit

    def pair(a: str, b: str, fmt: str = "{:.4g}") -> str:
        va, vb = fit.get(a), fit.get(b)
        return " / ".join("–" if v is None else fmt.format(v) for v in (va, vb))

    # L3 (session 30): the window actually used and why ("default 1 ms" was said of 2 and 8 ms)
    window_row = (fit.get("window_choice") or {}).get("reason", fit.get("window_rule", WINDOW_FIXED))
    stats = [
        ["method", result.method],
        ["gear ratio N (given)", result.N],
        ["windows used, motor / load equation", pair("motor_windows_used", "load_windows_used", "{}")],
        ["window length [s]", fit.get("window_s")],
        ["window chosen", window_row],
        [f"RMS residual, motor / load acceleration [{acc}]", pair("motor_accel_rms", "load_accel_rms")],
        ["relative error, motor / load equation", pair("relative_error_motor", "relative_error_load")],
        ["HAC lags (Bartlett, Andrews plug-in)", fit.get("hac_lags")],
        [
            f"velocity noise σ_ω, motor / load [{gu.velocity}]",
            pair("sigma_omega_m", "sigma_omega_l", "{:.3g}"),
        ],
        [f"encoder count, motor / load [{gu.si}] (0 = continuous)", pair("count_m", "count_l", "{:.3g}")],
    ]
    cp = fit.get("contact_points", {})
    c_lo, c_hi = cp.get("c_lo", -math.inf), cp.get("c_hi", math.inf)

    K_S = p["K_S"].value if p.get("K_S") is not None and p["K_S"].identifiable else float("nan")
    contacts = [(c, name) for c, name in ((c_lo, "−δ1"), (c_hi, "δ − δ1")) if math.isfinite(c)]
    # the fit's contacts are drawn as a diagnostic even when δ or δ1 is not determined, but then
    # they say so: the figure must not show as identified what the table reports as not identifiable
    undetermined = [n for n in ("delta", "delta1") if p.get(n) is not None and not p[n].identifiable]
    dz_label = "identified K_S·dz(Δθ)"
    if undetermined:
        what = " and ".join({"delta": "δ", "delta1": "δ1"}[n] for n in undetermined)
        dz_label = f"fit's K_S·dz(Δθ) ({what} not determined)"

    def characteristic(ax: Any, xlim: tuple[float, float] | None = None) -> None:
        ok = sig["ok_m"]
        x, y = sig["dtheta"][ok], sig["shaft_torque_motor"][ok]
        if xlim is not None:
            sel = (x >= xlim[0]) & (x <= xlim[1])
            x, y = x[sel], y[sel]
        xt, yt = _thin(x, y)
        ax.plot(gu.per_si * xt, yt, ".", ms=2, alpha=0.3, color="#999", label="N (u − u₀ − T_F,m − J_m ω̇_m)")
        if x.size > 50:  # binned median: the characteristic through the noise
            edges = np.quantile(x, np.linspace(0, 1, 61))
            idx = np.clip(np.searchsorted(edges, x) - 1, 0, 59)
            xm = np.array([np.median(x[idx == k]) if np.any(idx == k) else np.nan for k in range(60)])
            ym = np.array([np.median(y[idx == k]) if np.any(idx == k) else np.nan for k in range(60)])
            ax.plot(gu.per_si * xm, ym, "o", ms=3, color="#1d232a", label="binned median")
        lo, hi = (float(np.min(sig["dtheta"])), float(np.max(sig["dtheta"]))) if xlim is None else xlim
        if math.isfinite(K_S):
            g = np.linspace(lo, hi, 800)
            dz = np.minimum(g - c_lo, 0) + np.maximum(g - c_hi, 0)
            ax.plot(gu.per_si * g, K_S * dz, color="#c0392b", lw=1.6, label=dz_label)
        for c, name in contacts:
            if lo <= c <= hi:
                label = f"contact {name} = {gu.f(c, '.5g')}"
                if undetermined:
                    label = f"fit's contact {name} = {gu.f(c, '.5g')} (not reported)"
                ax.axvline(gu.per_si * c, color="#2a6fb0", ls="--", lw=1, label=label)
        ax.set_xlabel(f"Δθ = θ_m/N − θ_l [{gu}]")
        ax.grid(alpha=0.3)

    def draw_characteristic(fig: Any) -> None:
        n = 1 + len(contacts)
        axes = fig.subplots(1, n, squeeze=False, width_ratios=[2] + [1] * (n - 1))[0]
        characteristic(axes[0])
        axes[0].set_ylabel(f"shaft {gu.effort} [{gu.torque}]")
        axes[0].set_title("whole range", fontsize=9)
        axes[0].legend(fontsize=7, loc="best")
        x = sig["dtheta"][sig["ok_m"]]
        for ax, (c, name) in zip(axes[1:], contacts, strict=True):
            defl = (x - c) if c == c_hi else (c - x)  # deflection into this contact
            defl = defl[defl > 0]
            # at least 0.2 display units (0.2 mrad; 0.2 µm on a linear axis, whose Δθ spans ~50 µm)
            w = max(2.0 * float(np.quantile(defl, 0.95)), 0.2 / gu.per_si) if defl.size else 1.0 / gu.per_si
            characteristic(ax, (c - w, c + w))
            ax.set_title(f"zoom on the contact {name}", fontsize=9)

    # the load equation is drawn only when it was fitted ([identification] equations = "motor"
    # leaves it out: its "model" would be a flat line against a measured ω̇_l)
    load_used = bool(fit.get("load_windows_used") or 0)
    sides = [("m", sig["ok_m"])] + ([("l", sig["ok_l"])] if load_used else [])

    def draw_fit(fig: Any) -> None:
        axes = fig.subplots(2 * len(sides), 1, sharex=True, height_ratios=[3, 1] * len(sides))
        for k, (side, mask) in enumerate(sides):
            a, ah = sig[f"a_{side}"], sig[f"a_{side}_hat"]
            t, a_t, ah_t, m_t = _thin(sig["t"], a, ah, mask)
            ax, axr = axes[2 * k], axes[2 * k + 1]
            ax.plot(t, a_t, lw=0.6, color="#888", label="measured (window mean)")
            ax.plot(t, ah_t, lw=0.8, color="#c0392b", label="model")
            ax.set_ylabel(f"ω̇_{side} [{acc}]")
            ax.legend(fontsize=8, loc="upper right")
            res = np.where(m_t, a_t - ah_t, np.nan)
            axr.plot(t, res, lw=0.5, color="k")
            axr.set_ylabel(f"residual [{acc}]")
            for a_ in (ax, axr):
                a_.grid(alpha=0.3)
        axes[-1].set_xlabel("time [s] (gaps: standstill windows left out)")

    def draw_acf(fig: Any) -> None:
        ax = fig.subplots()
        lags = 40
        for side, color in (("m", "#2a6fb0"), ("l", "#c0392b"))[: len(sides)]:
            mask = sig[f"ok_{side}"]
            if mask.sum() > lags + 2:
                r = (sig[f"a_{side}"] - sig[f"a_{side}_hat"])[mask]
                ax.stem(
                    np.arange(lags + 1) + (0.15 if side == "l" else 0.0),
                    _acf(r, lags),
                    linefmt=color,
                    markerfmt=" ",
                    basefmt=" ",
                    label=f"{'motor' if side == 'm' else 'load'} equation",
                )
        n = max(int(sig["ok_m"].sum()), 1)
        ax.axhline(1.96 / math.sqrt(n), color="#999", ls=":", lw=1)
        ax.axhline(-1.96 / math.sqrt(n), color="#999", ls=":", lw=1)
        ax.set_xlabel("lag [windows]")
        ax.set_ylabel("autocorrelation")
        ax.set_title("Residual autocorrelation (coloured residuals → HAC intervals)", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)

    def draw_corr(fig: Any) -> None:
        ax = fig.subplots()
        c = np.asarray(result.correlation)
        im = ax.imshow(c, vmin=-1, vmax=1, cmap="RdBu_r")
        names = list(result.names)
        ax.set_xticks(range(len(names)), names, rotation=60, fontsize=8)
        ax.set_yticks(range(len(names)), names, fontsize=8)
        for i in range(c.shape[0]):
            for j in range(c.shape[1]):
                ax.text(j, i, f"{c[i, j]:.2f}", ha="center", va="center", fontsize=6.5)
        fig.colorbar(im, ax=ax, shrink=0.8)
        ax.set_title("Parameter correlation", fontsize=10)

    figs = [
        Figure(
            "characteristic",
            "Shaft torque seen by the motor vs Δθ (window means)"
            + (
                "; no deadzone identified."
                if not math.isfinite(K_S)
                else ", and the fit's deadzone, not reported: the backlash was not determined (table)."
                if undetermined
                else ", and the identified deadzone."
            ),
            draw_characteristic,
            (12, 4.5),
        ),
        Figure(
            "fit",
            "Integral equations: measured and model accelerations, and residuals"
            + ("." if load_used else " (motor equation only: the load equation was not fitted)."),
            draw_fit,
            (10, 6.5 if load_used else 3.6),
        ),
        Figure("acf", "Autocorrelation of the residuals.", draw_acf, (8, 3.2)),
    ]
    if len(result.names) > 1:
        figs.append(
            Figure("correlation", "Correlation matrix of the identified parameters.", draw_corr, (7, 6))
        )
    ident = getattr(config, "identification", None)
    offset_text = (
        f"{float(getattr(ident, 'torque_offset', 0.0) or 0.0):g} {gu.torque} ([identification] torque_offset)"
    )
    sections = [
        Section("Recording", raw=raw, figures=[_overview_figure(trace, result.N)]),
        Section(
            "Identified parameters (95 % intervals)",
            paragraphs=[
                "Two-mass model with deadzone (spec 01 eqs 1–7, 10)"
                + (
                    " and a torque offset"
                    if "torque_offset" in p
                    else f"; torque offset fixed at {offset_text}"
                )
                + ("" if load_used else "; motor equation only (the load equation was not fitted)")
                + "; integral equation error on short windows with positions fused from encoder and "
                "velocity; scipy least_squares; heteroscedasticity- and autocorrelation-consistent "
                "(Newey–West) covariance. A parameter the recording cannot determine carries the reason "
                "instead of a number."
            ],
            tables=[
                ("Parameters", ["parameter", "unit", "value", "std", "95 % interval", "std / note"], rows),
                ("Fit", ["quantity", "value"], stats),
            ],
            figures=figs,
        ),
    ]
    if online is not None:
        d = p.get("delta")

        def draw_online(fig: Any) -> None:
            ax = fig.subplots()
            t, dh = _thin(online.t, online.delta_hat)
            ax.plot(t, gu.per_si * dh, lw=1, label="online δ̂ (identified parameters)")
            if d is not None and d.identifiable:
                ax.axhspan(
                    gu.per_si * d.low,
                    gu.per_si * d.high,
                    color="#c0392b",
                    alpha=0.2,
                    label="offline δ, 95 % interval",
                )
                ax.axhline(gu.per_si * d.value, color="#c0392b", lw=1)
            ax.set_xlabel("time [s]")
            ax.set_ylabel(f"δ [{gu}]")
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)

        sections.append(
            Section(
                "Online estimate with the identified parameters",
                paragraphs=[f"online δ̂ = {gu.f(online.delta, '.4g')}; excitation: {online.reason}"],
                figures=[
                    Figure(
                        "online", "Online deadzone estimate vs the offline interval.", draw_online, (10, 3.5)
                    )
                ],
            )
        )
    sections.append(Section("Configuration", tables=_param_tables(config)))
    return render_html(f"drivelash identify (two-mass) — {trace.meta.get('source', 'trace')}", sections)


def write_two_mass_report(path: str | Path, trace: Any, result: Any, config: Any = None, **kw: Any) -> Path:
    """Write :func:`render_two_mass_report` atomically; returns the path."""
    return _write(path, render_two_mass_report(trace, result, config, **kw))
