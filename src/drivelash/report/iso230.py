"""The ISO 230-2 chart and the self-contained HTML report of ``drivelash iso230``.

Figures:

- the standard's chart: mean unidirectional positional deviations x̄_i↑, x̄_i↓ against the
  target position with the bands x̄ ± 2s per direction, and every approach as a dot;
- the reversal values B_i with their standard uncertainty, B and B̄, beside the deadzone
  at the load when it is given;
- for a time series, the recording with the dwells used, and one dwell in detail
  (settling skipped, averaging window).

Positions are shown in mm (linear axis) or degrees (rotary), deviations in µm or arcsec.
"""

from __future__ import annotations

import html
import math
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.report.html import Figure, Section, common_decimals, render_html

__all__ = ["draw_iso230_chart", "render_iso230_report", "write_iso230_report"]

_UP_COLOR = "#1f5fa8"
_DOWN_COLOR = "#c2461b"


def display_units(unit: str) -> tuple[str, float, str, float]:
    """(position label, factor from SI, deviation label, factor from SI)."""
    if unit == "rad":
        return "deg", 180.0 / math.pi, "arcsec", 648000.0 / math.pi
    return "mm", 1e3, "µm", 1e6


def draw_iso230_chart(fig: Any, result: Any, title: str | None = None) -> None:
    """The standard's chart on a matplotlib figure: x̄↑, x̄↓ with ±2s bands and every approach."""
    pl, pf, dl, df = display_units(result.unit)
    ax = fig.subplots()
    P = result.targets * pf
    ap = result.approaches
    if ap is not None:
        jit = 0.004 * (P.max() - P.min())
        for data, col, off in ((ap.up, _UP_COLOR, -jit), (ap.down, _DOWN_COLOR, jit)):
            xs = np.repeat(P + off, data.shape[1])
            ax.plot(xs, data.ravel() * df, ".", color=col, ms=4, alpha=0.5)
    for mean, s, col, name in (
        (result.mean_up, result.s_up, _UP_COLOR, "↑"),
        (result.mean_down, result.s_down, _DOWN_COLOR, "↓"),
    ):
        ax.plot(P, mean * df, "-o", color=col, lw=1.6, ms=4, label=f"x̄{name} (mean deviation)")
        ax.plot(P, (mean + 2 * s) * df, "--", color=col, lw=0.9, label=f"x̄{name} ± 2s{name}")
        ax.plot(P, (mean - 2 * s) * df, "--", color=col, lw=0.9)
    ax.plot(P, result.mean_bi * df, ":", color="#444", lw=1.0, label="x̄ (bidirectional mean)")
    ax.axhline(0.0, color="#888", lw=0.6)
    k = result.B_index
    right = P[k] > 0.5 * (float(np.min(P)) + float(np.max(P)))  # label inside the frame
    ax.annotate(
        f"B = {result.B * df:.3g} {dl}",
        xy=(P[k], 0.5 * (result.mean_up[k] + result.mean_down[k]) * df),
        xytext=(-12 if right else 12, 0),
        textcoords="offset points",
        fontsize=9,
        va="center",
        ha="right" if right else "left",
    )
    ax.vlines(P[k], result.mean_up[k] * df, result.mean_down[k] * df, color="#6a3d9a", lw=2.2)
    ax.set_xlabel(f"target position P_i [{pl}]")
    ax.set_ylabel(f"positional deviation [{dl}]")
    ax.set_title(
        title
        or f"ISO 230-2: A = {result.A * df:.3g}, B = {result.B * df:.3g}, E = {result.E * df:.3g},"
        f" M = {result.M * df:.3g}, R = {result.R * df:.3g} {dl}",
        fontsize=10,
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=3, loc="best")


def _reversal_figure(result: Any, comparison: Any | None) -> Figure:
    pl, pf, dl, df = display_units(result.unit)

    def draw(fig: Any) -> None:
        ax = fig.subplots()
        P = result.targets * pf
        L = -result.B_i * df
        ax.errorbar(P, L, yerr=2 * result.u_B_i * df, fmt="o", color="#6a3d9a", ms=4, capsize=3,
                    label="−B_i ± 2u(B_i) (lost motion at each target)")  # fmt: skip
        lm = -result.B_mean * df
        ax.axhline(lm, color="#6a3d9a", lw=1.2, label=f"−B̄ = {lm:.3g} {dl}")
        ax.axhspan(
            -result.B_mean_interval[1] * df, -result.B_mean_interval[0] * df, color="#6a3d9a", alpha=0.12
        )
        ax.axhline(
            result.B * df, color="#6a3d9a", lw=1.0, ls="--", label=f"B = max|B_i| = {result.B * df:.3g} {dl}"
        )
        if comparison is not None:
            c = comparison
            ax.axhline(
                c.L_delta * df,
                color="#1b7a3a",
                lw=1.6,
                label=f"estimated deadzone at the load = {c.L_delta * df:.3g} {dl}",
            )
            if c.u_L_delta is not None:
                lo, hi = (c.L_delta - 2 * c.u_L_delta) * df, (c.L_delta + 2 * c.u_L_delta) * df
                ax.axhspan(lo, hi, color="#1b7a3a", alpha=0.12)
            if c.compensation or c.drift_correction:
                what = " + ".join(
                    w
                    for w, on in (("compensation", c.compensation), ("drift removed", c.drift_correction))
                    if on
                )
                ax.axhline(
                    c.L_iso * df,
                    color="#6a3d9a",
                    lw=1.4,
                    ls=":",
                    label=f"−B̄ ({what}) = {c.L_iso * df:.3g} {dl}",
                )
        ax.set_xlabel(f"target position P_i [{pl}]")
        ax.set_ylabel(f"lost motion [{dl}]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="best")

    return Figure(
        "reversal",
        "Reversal value at each target (as lost motion −B_i) with B, B̄"
        + (" and the estimated deadzone" if comparison is not None else ""),
        draw,
        (10.0, 3.6),
    )


def _series_figure(meas: Any) -> Figure:
    s, d = meas.series, meas.dwells
    pl, pf, dl, df = display_units(meas.unit)

    def draw(fig: Any) -> None:
        ax1, ax2 = fig.subplots(2, 1, sharex=True, height_ratios=[2, 1])
        t = s["t"]
        k = max(1, t.size // 8000)
        ax1.plot(t[::k], s["P_cmd"][::k] * pf, lw=0.8, color="#333", label="P_cmd (commanded)")
        for a, b in zip(d.t_avg_start, d.t_avg_end, strict=True):
            ax1.axvspan(a, b, color="#1b7a3a", alpha=0.25, lw=0)
        ax1.set_ylabel(f"position [{pl}]")
        ax1.legend(fontsize=8, loc="upper right")
        ax1.set_title(f"{d.t_start.size} dwells found (green: averaging windows)", fontsize=10)
        err = (s["P_actual"] - s["P_cmd"]) * df
        inside = np.zeros(t.size, dtype=bool)
        for a, b in zip(d.t_avg_start, d.t_avg_end, strict=True):
            inside[np.searchsorted(t, a) : np.searchsorted(t, b, side="right")] = True
        ax2.plot(t[::k], np.where(inside, err, np.nan)[::k], lw=0.6, color="#888", label="during averaging")
        up = d.direction > 0
        ax2.plot(
            0.5 * (d.t_avg_start + d.t_avg_end)[up],
            d.deviation[up] * df,
            ".",
            color=_UP_COLOR,
            ms=4,
            label="↑",
        )
        ax2.plot(
            0.5 * (d.t_avg_start + d.t_avg_end)[~up],
            d.deviation[~up] * df,
            ".",
            color=_DOWN_COLOR,
            ms=4,
            label="↓",
        )
        span = np.ptp(d.deviation * df)
        ax2.set_ylim(d.deviation.min() * df - 0.3 * span - 1e-9, d.deviation.max() * df + 0.3 * span + 1e-9)
        ax2.set_ylabel(f"P_actual − P_cmd [{dl}]")
        ax2.set_xlabel("time [s]")
        ax2.legend(fontsize=8, loc="upper left")
        for a in (ax1, ax2):
            a.grid(alpha=0.3)

    return Figure(
        "recording",
        "The recording: commanded position with the dwells, deviation during the dwells",
        draw,
        (10.0, 5.0),
    )


def _dwell_zoom(meas: Any) -> Figure:
    s, d = meas.series, meas.dwells
    pl, pf, dl, df = display_units(meas.unit)
    i = int(np.argmin(np.abs(d.run - d.run.max()) + (d.direction < 0)))  # a late ↑ dwell

    def draw(fig: Any) -> None:
        ax = fig.subplots()
        t = s["t"]
        pad = 0.3
        sel = (t >= d.t_start[i] - pad) & (t <= d.t_end[i] + pad)
        ax.plot(
            t[sel], (s["P_actual"][sel] - d.target[i]) * df, lw=0.7, color=_UP_COLOR, label="P_actual − P_i"
        )
        if "P_axis" in s:
            ax.plot(t[sel], (s["P_axis"][sel] - d.target[i]) * df, lw=0.9, color="#999", label="P_axis − P_i")
        ax.axvspan(
            d.t_start[i], d.t_avg_start[i], color="#e0a400", alpha=0.2, lw=0, label="settling (skipped)"
        )
        ax.axvspan(d.t_avg_start[i], d.t_avg_end[i], color="#1b7a3a", alpha=0.2, lw=0, label="averaged")
        ax.axhline(d.deviation[i] * df, color="#1b7a3a", lw=1.2, label=f"x = {d.deviation[i] * df:.3g} {dl}")
        lim = max(
            20 * np.std(s["P_actual"][(t >= d.t_avg_start[i]) & (t <= d.t_avg_end[i])]) * df,
            3 * abs(d.deviation[i] * df),
            1e-3,
        )
        ax.set_ylim(d.deviation[i] * df - lim, d.deviation[i] * df + lim)
        ax.set_xlabel("time [s]")
        ax.set_ylabel(f"deviation from P_i [{dl}]")
        ax.set_title(
            f"One dwell: target {d.target[i] * pf:.6g} {pl}, direction ↑, run {int(d.run[i])}", fontsize=10
        )
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="upper right")

    return Figure(
        "dwell", "One dwell in detail: the settling time is skipped, the rest averaged", draw, (10.0, 3.2)
    )


def _f(v: float | None, df: float, nd: int = 3) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "–"
    return f"{v * df:.{nd}f}"


def render_iso230_report(
    result: Any,
    meas: Any,
    comparison: Any | None = None,
    *,
    axis_result: Any | None = None,
    title: str | None = None,
    warnings: list[str] | None = None,
) -> str:
    """The HTML report of an ISO 230-2 evaluation (self-contained, no scripts).

    Parameters
    ----------
    result : Iso230Result
        The evaluation (positions in m or rad).
    meas : Measurement
        What was read (source, kind, dwells, drift).
    comparison : Comparison, optional
        B beside the deadzone; a deadzone with a ``note`` (an unconverged estimate) is
        flagged next to its number.
    axis_result : Iso230Result, optional
        The reference against the axis's own encoder.
    title : str, optional
        Page title.
    warnings : list of str, optional
        Every warning of the run, as the terminal and the JSON give them (the reader's, the
        deadzone's, the drift's, the history's); None: the reader's (``meas.warnings``).
    """
    pl, pf, dl, df = display_units(result.unit)
    sections: list[Section] = []
    esc = html.escape
    head = Section("Result")
    kind = "table of approaches" if meas.kind == "table" else "time series, dwells detected"
    head.paragraphs.append(
        f"{esc(Path(meas.source).name)}: {kind};"
        f" {result.m} targets, {result.n} runs per direction; deviations x = P_actual − P_target in {dl}."
    )
    rows = [
        [
            "A (bidirectional accuracy)",
            _f(result.A, df),
            "A↑ / A↓",
            f"{_f(result.A_up, df)} / {_f(result.A_down, df)}",
        ],
        ["B (reversal value, max|B_i|)", _f(result.B, df), "B̄ (mean reversal value)", _f(result.B_mean, df)],
        [
            "E (bidirectional systematic deviation)",
            _f(result.E, df),
            "E↑ / E↓",
            f"{_f(result.E_up, df)} / {_f(result.E_down, df)}",
        ],
        ["M (range of mean bidirectional deviation)", _f(result.M, df), "", ""],
        [
            "R (bidirectional repeatability)",
            _f(result.R, df),
            "R↑ / R↓",
            f"{_f(result.R_up, df)} / {_f(result.R_down, df)}",
        ],
    ]
    header = ["quantity", "value", "quantity", "value"]
    head.tables.append((f"ISO 230-2:2014 axis values [{dl}]", header, rows))
    lo, hi = result.B_interval
    mlo, mhi = result.B_mean_interval
    head.tables.append(
        (
            f"Statistical uncertainty of the reversal values [{dl}], coverage {result.coverage:.0%}",
            ["quantity", "value", "standard uncertainty", "interval"],
            [
                [
                    "B",
                    _f(result.B, df),
                    _f(result.u_B, df),
                    f"[{_f(lo, df)}, {_f(hi, df)}] (simultaneous over targets)",
                ],
                [
                    "B̄",
                    _f(result.B_mean, df),
                    _f(result.u_B_mean, df),
                    f"[{_f(mlo, df)}, {_f(mhi, df)}] (t, ν = {result.nu_B_mean:.1f})",
                ],
            ],
        )
    )
    if axis_result is not None:
        head.paragraphs.append(
            f"Reference against the axis's own encoder (P_actual − P_axis): B = {_f(axis_result.B, df)} {dl},"
            f" B̄ = {_f(axis_result.B_mean, df)} ± {_f(axis_result.u_B_mean, df)} {dl} —"
            " the lost motion between the encoder the control closes its loop on and the tool."
        )
    sections.append(head)

    if comparison is not None:
        c = comparison
        cs = Section("Reversal value beside the estimated deadzone")
        verdict = (
            '<p class="verdict-ok">agree (|E_n| ≤ 1)</p>'
            if c.agree
            else '<p class="verdict-bad">disagree (|E_n| &gt; 1)</p>'
        )
        cs.raw.append(verdict)
        dz = c.deadzone
        if dz.note:  # an estimate the estimator did not call converged: said next to its number
            cs.raw.append(f'<div class="warn">{esc(dz.note)}</div>')
        cs.tables.append(
            (
                f"Lost motion at the load [{dl}] (expanded uncertainty U = 2u)",
                ["source", "value", "u", "U (B: 95 % interval)"],
                [
                    [
                        f"ISO test: {c.iso_label}",
                        _f(c.L_iso, df),
                        _f(c.u_L_iso, df),
                        _f(2 * c.u_L_iso, df),
                    ],
                    [
                        "ISO test: B = max|B_i|",
                        _f(c.B, df),
                        _f(c.u_B, df),
                        f"[{_f(c.B_interval[0], df)}, {_f(c.B_interval[1], df)}]",
                    ],
                    [
                        (
                            f"estimated deadzone δ = {dz.delta * 1e6:.4g} µm (a prismatic axis: at the table)"
                            if dz.prismatic
                            else f"estimated deadzone δ = {dz.delta * 1e3:.4g} mrad"
                            f" × {c.factor * df:.5g} {dl}/rad"
                        )
                        + (" (not converged: see above)" if dz.note else ""),
                        _f(c.L_delta, df),
                        _f(c.u_L_delta, df),
                        _f(None if c.u_L_delta is None else 2 * c.u_L_delta, df),
                    ],
                ],
            )
        )
        cs.paragraphs.append(
            f"E_n = |L_ISO − L_δ| / √(U_ISO² + U_δ²) = {c.E_n:.2f}. Deadzone from {dz.source}"
            + (f" (recorded {dz.time})" if dz.time else "")
            + (". The estimator gave no uncertainty: U_δ = 0 in E_n." if dz.u_delta is None else ".")
            + " Both uncertainties are statistical only. The reversal at the tool also contains the elastic"
            " wind-up of the drive under guideway friction and any reversal compensation of the control;"
            " the deadzone estimate is the gap alone."
        )
        cs.figures.append(_reversal_figure(result, c))
        sections.append(cs)

    chart = Section("The ISO 230-2 chart")
    chart.figures.append(
        Figure(
            "iso-chart",
            "Mean unidirectional positional deviations with ±2s bands per direction; dots: every approach",
            lambda fig: draw_iso230_chart(fig, result),
            (10.0, 5.0),
        )
    )
    if comparison is None:
        chart.figures.append(_reversal_figure(result, None))
    sections.append(chart)

    tgt = Section("Per target")
    trows = []
    # to 1 µm (mm) or 0.0001° (deg): finer than any target a measurement sets
    p_nd = common_decimals([result.targets[i] * pf for i in range(result.m)], max_nd=3 if pl == "mm" else 4)
    for i in range(result.m):
        trows.append(
            [
                f"{result.targets[i] * pf:.{p_nd}f}",
                _f(result.mean_up[i], df),
                _f(result.mean_down[i], df),
                _f(result.s_up[i], df),
                _f(result.s_down[i], df),
                _f(result.B_i[i], df),
                _f(result.u_B_i[i], df),
                _f(result.R_i_up[i], df),
                _f(result.R_i_down[i], df),
                _f(result.R_i[i], df),
                _f(result.mean_bi[i], df),
            ]
        )
    tgt.tables.append(
        (
            f"Positions in {pl}, deviations in {dl}",
            ["P_i", "x̄↑", "x̄↓", "s↑", "s↓", "B_i", "u(B_i)", "R↑", "R↓", "R_i", "x̄_i"],
            trows,
        )
    )
    sections.append(tgt)

    if meas.kind == "timeseries" and meas.dwells is not None:
        ds = Section("Dwells")
        d = meas.dwells
        ds.paragraphs.append(
            f"Feed speed {d.v_feed * pf:.4g} {pl}/s; a sample is still below {d.v_threshold * pf:.3g} {pl}/s."
            " A dwell is a stop of the commanded position of at least the minimum dwell time;"
            " its settling time is"
            " skipped and the rest averaged; the approach direction is that of the last motion before it."
        )
        if meas.drift is not None:
            dr = meas.drift
            ds.paragraphs.append(
                f"Drift of the reference across the runs: {dr.rate * df * 3600:.3g}"
                f" ± {dr.u_rate * df * 3600:.2g} {dl}/h (common slope of the deviations against time at"
                f" each target and direction). It shifts B̄ by {_f(dr.bias_B_mean, df)} {dl}, as the ↓"
                " approach to a target comes later than the ↑ one."
                " The ISO values above are not corrected (the standard does not); the deadzone comparison is."
            )
        ds.figures.append(_series_figure(meas))
        ds.figures.append(_dwell_zoom(meas))
        sections.append(ds)

    shown = list(meas.warnings) if warnings is None else list(warnings)
    if shown:
        ws = Section("Warnings")
        ws.raw.extend(f'<div class="warn">{esc(w)}</div>' for w in shown)
        sections.append(ws)

    defs = Section("Definitions (ISO 230-2:2014)")
    defs.paragraphs.extend(
        [
            "x_ij = P_ij − P_i; x̄_i↑ = mean over the n approaches in the positive direction (↓ likewise);"
            " s_i↑ = √(Σ(x_ij↑ − x̄_i↑)²/(n−1)); R_i↑ = 4s_i↑.",
            "B_i = x̄_i↑ − x̄_i↓; B = max|B_i|; B̄ = mean of B_i; R_i = max(2s_i↑ + 2s_i↓ + |B_i|, R_i↑, R_i↓);"
            " R = max R_i.",
            "E↑ = max x̄_i↑ − min x̄_i↑; E = max(x̄_i↑, x̄_i↓) − min(x̄_i↑, x̄_i↓); x̄_i = (x̄_i↑ + x̄_i↓)/2;"
            " M = max x̄_i − min x̄_i; A = max(x̄_i↑ + 2s_i↑, x̄_i↓ + 2s_i↓) − min(x̄_i↑ − 2s_i↑, x̄_i↓ − 2s_i↓).",
            "Uncertainty (beyond the standard): u(B_i)² = s_i↑²/n + s_i↓²/n; u(B̄)² = Σu(B_i)²/m²."
            " The interval of"
            " B holds for all targets at once (Šidák), as B is the largest of m noisy values.",
        ]
    )
    sections.append(defs)
    return render_html(title or f"ISO 230-2 positioning test — {Path(meas.source).name}", sections)


def write_iso230_report(
    path: str | Path, result: Any, meas: Any, comparison: Any | None = None, **kw: Any
) -> Path:
    """Write :func:`render_iso230_report` to ``path``: a staging path of ``Outputs`` directly,
    any other path atomically (a failed write leaves an existing file as it was)."""
    from drivelash.report import _write

    return _write(path, render_iso230_report(result, meas, comparison, **kw))
