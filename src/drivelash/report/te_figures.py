"""Figures of the rack-and-pinion transmission-error pipeline (matplotlib, PNG).

* :func:`plot_te_over_position` — the paper's Fig. 2 from a campaign;
* :func:`bode_figure` — Bode plot of the path-error transfer functions (2)–(3);
* :func:`plot_fig6` — stacked model vs its stages and baselines (paper Fig. 6);
* :func:`fig_sine`, :func:`fig_heatmaps`, :func:`fig_monitor` — the validation
  figures (paper Figs 8–9 and the monitoring demo); this module is the ``figures``
  object :func:`drivelash.te.protocol.validate.validate` draws with;
* :func:`fig_update` — before/after of ``te update``.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.report.save import save_figure
from drivelash.te.learn.preprocess import RunData
from drivelash.te.protocol.campaign import Campaign, measured_te
from drivelash.te.protocol.monitoring import SectionReport
from drivelash.te.protocol.validate import reversal_times

__all__ = [
    "bode_figure",
    "fig_heatmaps",
    "fig_monitor",
    "fig_sine",
    "fig_update",
    "plot_fig6",
    "plot_te_over_position",
]


def plot_te_over_position(
    campaign: Campaign, path: str | Path, velocity: float | None = None, step: float = 200e-6
) -> Path:
    """Fig. 2 of the paper from a campaign: TE over position, both directions, all loads.

    Parameters
    ----------
    campaign : Campaign
        The recording.
    path : str or Path
        PNG to write.
    velocity : float, optional
        Velocity of the load runs to show [m/s]; default the lowest recorded.
    step : float
        Plot resolution over position [m].

    Returns
    -------
    Path
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    bench = campaign.bench
    loads = campaign.select(kind="load")
    if velocity is None and loads:
        velocity = min(r.velocity for r in loads)
    fig, ax = plt.subplots(2, 1, figsize=(11, 8), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    cmap = plt.get_cmap("viridis")
    F_max = max([r.load for r in loads] + [1.0])
    geo = {}
    geo_v = sorted({r.velocity for r in campaign.select(kind="geometric")})
    for r in campaign.select(kind="geometric"):
        tr = r.trace()
        x, te = tr["x_T"], measured_te(tr, bench)
        grid = np.arange(x.min(), x.max(), step)
        order = np.argsort(x)
        geo[r.direction] = (grid, np.interp(grid, x[order], te[order]))
        ax[0].plot(grid, geo[r.direction][1] * 1e6, color="k", lw=0.8)
    for r in campaign.select(kind="load", velocity=velocity):
        tr = r.trace()
        x, te = tr["x_T"], measured_te(tr, bench)
        grid = np.arange(x.min(), x.max(), step)
        order = np.argsort(x)
        ax[0].plot(grid, np.interp(grid, x[order], te[order]) * 1e6, color=cmap(r.load / F_max), lw=0.5)
    if 1 in geo and -1 in geo:
        g = geo[1][0]
        lo = np.interp(g, *geo[1])
        hi = np.interp(g, *geo[-1])
        ax[0].fill_between(g, lo * 1e6, hi * 1e6, color="tab:orange", alpha=0.25, label="backlash (no load)")
        ax[1].plot(g, (hi - lo) * 1e6, color="tab:orange")
    ax[0].set_ylabel("TE = x_T − x_M [µm]")
    v_txt = f"{velocity * 1e3:g} mm/s" if velocity else ""
    black = "/".join(f"{v * 1e3:g}" for v in geo_v) + " mm/s, no load" if geo_v else "no load"
    ax[0].set_title(
        f"Transmission error, both directions, loads 0…{F_max:g} N (colour) {v_txt}; black: {black}"
    )
    ax[0].legend(loc="upper right")
    ax[1].set_ylabel("gap [µm]")
    ax[1].set_xlabel("table position x_T [m]")
    fig.tight_layout()
    if loads:  # which colour is which load (beside both panels, so their x axes stay aligned)
        from matplotlib.cm import ScalarMappable
        from matplotlib.colors import Normalize

        sm = ScalarMappable(norm=Normalize(0.0, F_max), cmap=cmap)
        fig.colorbar(sm, ax=list(ax), label=f"load [N] ({v_txt} runs)", shrink=0.9, pad=0.02)
    path = Path(path)
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path


def fig_sine(unc: dict, comp: dict, r_eff: float, path: Path, variant: str = "") -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dec = 8
    t = unc["t"][::dec]
    fig = plt.figure(figsize=(10, 11), layout="constrained")
    gs = fig.add_gridspec(5, 1)
    ax = [fig.add_subplot(gs[0])]
    ax += [fig.add_subplot(gs[i], sharex=ax[0]) for i in (1, 2, 3)]
    ax[0].plot(t, unc["x_d"][::dec] * 1e3, "k")
    ax[0].set_ylabel("x_d [mm]")
    te_u = (unc["x_T"] - r_eff * unc["theta_m"])[::dec]
    te_c = (comp["x_T"] - r_eff * comp["theta_m"])[::dec]
    ax[1].plot(t, (te_u - te_u[0]) * 1e6, label="TE without comp.")
    ax[1].plot(t, (te_c - te_c[0]) * 1e6, label="TE with comp.", alpha=0.8)
    ax[1].set_ylabel("TE − TE(0) [µm]")
    ax[1].legend(loc="upper right", fontsize=8)
    ax[2].plot(t, unc["e"][::dec] * 1e6, label="without compensation", color="tab:red")
    ax[2].plot(t, comp["e"][::dec] * 1e6, label="with compensation", color="tab:green")
    ax[2].set_ylabel("path error x_d − x_T [µm]")
    ax[2].legend(loc="upper right", fontsize=8)
    ax[3].plot(t, comp["v_c"][::dec] * 1e3, label="v_c")
    ax[3].plot(t, comp["v_bl"][::dec] * 1e3, label="v_c,BL", alpha=0.7)
    ax[3].set_ylabel("v_c [mm/s]")
    ax[3].set_xlabel("t [s]")
    ax[3].legend(loc="upper right", fontsize=8)
    # zoom on the first reversal
    z = fig.add_subplot(gs[4])
    tr = reversal_times(unc["t"], unc["v_d"])
    if tr.size:
        m = (unc["t"] > tr[0] - 0.05) & (unc["t"] < tr[0] + 0.2)
        z.plot(unc["t"][m], unc["e"][m] * 1e6, color="tab:red", label="without compensation")
        z.plot(comp["t"][m], comp["e"][m] * 1e6, color="tab:green", label="with compensation")
        z2 = z.twinx()
        z2.plot(comp["t"][m], comp["v_c"][m] * 1e3, color="tab:blue", lw=0.8, alpha=0.6)
        z2.set_ylabel("v_c [mm/s]", color="tab:blue")
        z.axvline(tr[0], color="k", ls=":", lw=0.8)
        z.legend(loc="upper right", fontsize=8)
    z.set_xlabel("t [s] (zoom on the first reversal, dotted: set-point reversal)")
    z.set_ylabel("path error [µm]")
    for a in [*ax, z]:
        a.grid(alpha=0.3)
    # the three sine figures of `te validate` differ by their settings: the title names them
    fig.suptitle(
        "Sinusoidal trajectory: compensation of TE and backlash (cf. paper Fig. 8)"
        + (f"\n{variant}" if variant else "")
    )
    save_figure(fig, path, dpi=100)
    plt.close(fig)


def _cell_edges(centers: np.ndarray) -> np.ndarray:
    """Edges of cells centred on sorted ``centers``: midpoints, half a step beyond the ends."""
    if centers.size == 1:
        return np.array([centers[0] - 250.0, centers[0] + 250.0])
    mid = 0.5 * (centers[1:] + centers[:-1])
    first, last = centers[0] - (mid[0] - centers[0]), centers[-1] + (centers[-1] - mid[-1])
    return np.concatenate(([first], mid, [last]))


def _range_limit(inside: Sequence[float], beyond: Sequence[float]) -> float | None:
    """Where a load axis draws the training-range limit: midway between the largest load inside
    the range and the smallest beyond it (None when either side has no load)."""
    if not inside or not beyond:
        return None
    return 0.5 * (max(inside) + min(beyond))


def fig_heatmaps(rows: list[dict[str, Any]], train_max_load: float, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dirs = sorted({r["direction"] for r in rows}, reverse=True)
    vels = sorted({r["velocity"] for r in rows})
    loads = sorted({r["load"] for r in rows})
    xs = sorted({r["x_start"] for r in rows})
    x_end = {r["x_start"]: r.get("x_end") for r in rows}
    last = x_end.get(xs[-1])
    step = xs[1] - xs[0] if len(xs) > 1 else 0.1
    x_edges = np.array([*xs, last if last is not None and last > xs[-1] else xs[-1] + step])
    load_edges = _cell_edges(np.asarray(loads, float))
    # the training range limit: between the last training load and the first beyond it
    inside, beyond = [f for f in loads if f <= train_max_load], [f for f in loads if f > train_max_load]
    limit_y = _range_limit(inside, beyond)
    fig, axes = plt.subplots(
        len(dirs), len(vels) + 1, figsize=(4.2 * (len(vels) + 1), 4.2 * len(dirs)), squeeze=False,
        layout="constrained",
    )  # fmt: skip
    for i, d in enumerate(dirs):
        summary = np.full((len(vels), len(loads)), np.nan)
        for j, v in enumerate(vels):
            grid = np.full((len(loads), len(xs)), np.nan)
            for r in rows:
                if r["direction"] == d and r["velocity"] == v:
                    grid[loads.index(r["load"]), xs.index(r["x_start"])] = r["improvement"] * 100
            with warnings.catch_warnings():  # a load without a section at this velocity: NaN (blank)
                warnings.simplefilter("ignore", RuntimeWarning)
                summary[j] = np.nanmean(grid, axis=1)
            ax = axes[i, j + 1]
            # each cell spans its section (x_start … x_end) and its load, whatever the load grid
            im = ax.pcolormesh(x_edges * 1e3, load_edges, grid, cmap="RdYlGn", vmin=0, vmax=100)
            if limit_y is not None:
                ax.axhline(limit_y, color="k", lw=1, ls="--")
            ax.set_yticks(loads, [f"{f:g}" for f in loads], fontsize=7)
            ax.set_title(f"dir {d:+d}, v = {v * 1e3:g} mm/s", fontsize=9)
            ax.set_xlabel("x_T [mm] (100 mm sections)")
            ax.set_ylabel("load [N]")
        ax = axes[i, 0]
        im = ax.imshow(summary.T, origin="lower", aspect="auto", cmap="RdYlGn", vmin=0, vmax=100)
        for j in range(len(vels)):
            for k in range(len(loads)):
                ax.text(j, k, f"{summary[j, k]:.0f}", ha="center", va="center", fontsize=7)
        ax.set_xticks(range(len(vels)), [f"{v * 1e3:g}" for v in vels])
        ax.set_yticks(range(len(loads)), [f"{f:g}" for f in loads], fontsize=7)
        ax.axhline(next((k for k, f in enumerate(loads) if f > train_max_load), len(loads)) - 0.5, color="k",
                   lw=1, ls="--")  # fmt: skip
        ax.set_xlabel("velocity [mm/s]")
        ax.set_ylabel("load [N]")
        ax.set_title(f"dir {d:+d}: mean improvement [%]", fontsize=9)
    fig.colorbar(im, ax=axes.ravel().tolist(), label="improvement of path-error MAE [%]", shrink=0.8)
    fig.suptitle("Improvement per 100 mm section (cf. paper Fig. 9); dashed: training range limit")
    save_figure(fig, path, dpi=100)
    plt.close(fig)


def fig_monitor(before: SectionReport, after: SectionReport, defect: tuple[float, float], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    for a, rep, title in (
        (ax[0], before, "defect, old model"),
        (ax[1], after, "after update(stage='trees')"),
    ):
        c = 0.5 * (rep.edges[:-1] + rep.edges[1:]) * 1e3
        w = np.diff(rep.edges) * 1e3 * 0.9
        a.bar(c, rep.judged_value * 1e6, width=w, color=np.where(rep.flagged, "tab:red", "tab:blue"),
              label=f"model path error (3)·(TE_meas − TE_model), {rep.statistic}")  # fmt: skip
        a.plot(c, rep.mae_uncompensated * 1e6, "k.-", label="est. uncompensated path error (3)·TE_meas, MAE")
        a.axhline(rep.threshold * 1e6, color="tab:red", ls="--", label="threshold")
        a.axvspan(defect[0] * 1e3, defect[1] * 1e3, color="orange", alpha=0.3, label="injected defect (±2σ)")
        a.set_ylabel("per section [µm]")
        a.set_title(title, fontsize=9)
        a.grid(alpha=0.3)
    ax[0].legend(fontsize=7, loc="upper left")
    ax[1].set_xlabel("x_T [mm]")
    fig.suptitle("Monitoring with compensation active: flagged sections (red)")
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


def plot_fig6(
    path: str | Path,
    run: RunData,
    p_stage1: np.ndarray,
    p_total: np.ndarray,
    stage1_share: float,
    table: Sequence[Mapping[str, Any]],
    direction: str = "pos",
    span: float = 0.4,
) -> Path:
    """A figure like the paper's Fig. 6 plus the MAE-per-load comparison.

    Parameters
    ----------
    path : str or Path
        PNG to write.
    run : RunData
        A training run (target TE_def [µm] over position [m]).
    p_stage1, p_total : numpy.ndarray
        Stage-1 and stacked predictions [µm] on ``run.x``.
    stage1_share : float
        Stage-1 share of the output over the training data [-].
    table : sequence of dict
        :func:`mae_table` rows.
    direction : str
        ``"pos"`` or ``"neg"`` (rows of the bottom panel).
    span : float
        Travel shown in the top panel [m].
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    p1 = np.asarray(p_stage1)
    p2 = np.asarray(p_total) - p1
    sel = run.x <= run.x[0] + span
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 7.5), constrained_layout=True)
    xm = run.x[sel] * 1e3
    ax1.plot(xm, run.te_def_um[sel], color="0.2", lw=2.2, label="TE_def (processed measurement)")
    ax1.plot(xm, (p1 + p2)[sel], color="tab:orange", lw=1.2, ls="--", label="stacked model (NN + trees)")
    ax1.plot(xm, p1[sel], color="tab:blue", lw=1.0, label="stage 1 (NN) contribution")
    ax1.plot(xm, p2[sel], color="tab:green", lw=0.8, alpha=0.8, label="stage 2 (trees) contribution")
    mae = float(np.mean(np.abs(p1 + p2 - run.te_def_um)))
    ax1.set_title(
        f"Training run {run.meta.get('name', '')}: load {run.meta.get('load', float('nan')):.0f} N, "
        f"direction {direction}\nMAE {mae:.4f} µm, stage-1 share {100 * stage1_share:.0f} %",
        fontsize=11,
    )  # two lines: one was wider than the figure and lost its end
    ax1.set_xlabel("table position x_T [mm]")
    ax1.set_ylabel("TE_def [µm]")
    ax1.grid(alpha=0.3)
    ax1.legend(loc="best", fontsize=8)
    rows = [r for r in table if r["direction"] == direction]
    loads = np.array([r["load"] for r in rows])
    names = list(rows[0]["mae"]) if rows else []
    for n in names:
        ax2.semilogy(loads, [r["mae"][n] for r in rows], marker="o", label=n)
    ax2.semilogy(loads, [0.1 * r["rms"] for r in rows], color="k", ls=":", label="10 % of TE_def RMS")
    held = [r["load"] for r in rows if r["split"] == "held-out"]
    for h in held:
        ax2.axvline(h, color="0.8", lw=6, zorder=0)
    limit = _range_limit(
        [r["load"] for r in rows if r["split"] != "extrapolation"],
        [r["load"] for r in rows if r["split"] == "extrapolation"],
    )
    if limit is not None:  # between the largest load in range and the first beyond it
        ax2.axvline(limit, color="r", ls="--", lw=1, label="training load limit")
    ax2.set_xlabel("load F_load [N] (grey: held-out loads)")
    ax2.set_ylabel("MAE of TE_def [µm]")
    ax2.set_title(f"Direction {direction}: MAE per load, stacked vs baselines")
    ax2.grid(alpha=0.3, which="both")
    ax2.legend(fontsize=8, ncol=2)
    path = Path(path)
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path


def bode_figure(J_s: float, gains: Any, f_min: float = 0.1, f_max: float = 2000.0):  # noqa: ANN201
    """Bode plot of (2) and (3) as a matplotlib figure (frequency in Hz)."""
    import matplotlib.pyplot as plt

    from drivelash.control.path_error import g_d_cl_closed_form, g_pc_ol_closed_form

    f = np.logspace(np.log10(f_min), np.log10(f_max), 600)
    s = 2j * np.pi * f
    fig, ax = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
    for G, name in (
        (g_pc_ol_closed_form(s, J_s, gains), "G_pc,OL (2)"),
        (g_d_cl_closed_form(s, J_s, gains), "G_d,CL (3)"),
    ):
        ax[0].semilogx(f, 20 * np.log10(np.abs(G)), label=name)
        ax[1].semilogx(f, np.degrees(np.unwrap(np.angle(G))), label=name)
    ax[0].set_ylabel("magnitude [dB]")
    ax[1].set_ylabel("phase [deg]")
    ax[1].set_xlabel("frequency [Hz]")
    ax[0].legend()
    ax[0].grid(True, which="both", alpha=0.3)
    ax[1].grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    return fig


def fig_update(
    panels: Sequence[Mapping[str, Any]],
    errors: Mapping[str, Mapping[str, Mapping[str, float]]],
    stage: str,
    path: Path,
) -> Path:
    """Before/after figure of ``te update``: one pass per direction, TE_def measured vs both models.

    Parameters
    ----------
    panels : sequence of dict
        Per direction: ``key``, ``name`` (pass), ``split`` ("held out" / "update"),
        ``x`` [m], ``measured``, ``before``, ``after`` (TE_def [µm]).
    errors : dict
        ``{"update": {key: {"before_um", "after_um"}}, "held_out": {...}}`` (MAE [µm]).
    stage : str
        The updated stage(s), for the title.
    path : Path
        Output PNG (a staging path of :class:`~drivelash.io.outputs.Outputs` works).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from drivelash.report.save import save_figure

    n = max(1, len(panels))
    fig, ax = plt.subplots(2, n, figsize=(7 * n, 6.5), sharex="col", squeeze=False)
    for j, p in enumerate(panels):
        x = np.asarray(p["x"]) * 1e3
        a, b = ax[0, j], ax[1, j]
        a.plot(x, p["before"], color="tab:red", lw=0.9, label="model before the update")
        a.plot(x, p["after"], color="tab:blue", lw=0.9, alpha=0.6, label="model after the update")
        a.plot(x, p["measured"], color="k", lw=1.2, zorder=5,
               label="measured (the model's geometric curve removed)")  # fmt: skip
        a.set_ylabel("TE_def [µm]")
        a.set_title(f"{p['key']}: {p['split']} pass {p['name']}", fontsize=9)
        a.grid(alpha=0.3)
        a.legend(fontsize=7, loc="upper left")
        eb = np.abs(np.asarray(p["before"]) - p["measured"])
        ea = np.abs(np.asarray(p["after"]) - p["measured"])
        b.plot(x, eb, color="tab:red", lw=0.8, label=f"before: MAE {np.mean(eb):.3f} µm")
        b.plot(x, ea, color="tab:blue", lw=0.8, label=f"after: MAE {np.mean(ea):.3f} µm")
        b.set_ylabel("|model − measured| [µm]")
        b.set_xlabel("x_T [mm]")
        b.grid(alpha=0.3)
        b.legend(fontsize=7, loc="upper left")
    lines = [f"te update (stage {'2' if stage == 'trees' else '1 and 2'}), TE_def MAE before → after"]
    for split, label in (("update", "update passes"), ("held_out", "held-out passes")):
        parts = [f"{key} {e['before_um']:.3f} → {e['after_um']:.3f} µm"
                 for key, e in sorted((errors.get(split) or {}).items())]  # fmt: skip
        if parts:
            lines.append(f"{label}: " + ", ".join(parts))
    fig.suptitle("\n".join(lines), fontsize=9)
    fig.tight_layout()
    save_figure(fig, path, dpi=100)
    plt.close(fig)
    return Path(path)
