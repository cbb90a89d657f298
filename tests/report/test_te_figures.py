"""The TE validation figures show each number where its axes say it is."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

import drivelash.report.te_figures as tf


def _rows(loads, xs=(0.055, 0.155, 0.255, 0.355), x_last=0.445):
    rows = []
    for f in loads:
        for k, x0 in enumerate(xs):
            x1 = xs[k + 1] if k + 1 < len(xs) else x_last
            rows.append({"direction": 1, "velocity": 0.05, "load": f, "x_start": x0, "x_end": x1,
                         "improvement": 0.9 - f / 1e4})  # fmt: skip
    return rows


def _drawn(monkeypatch, rows, train_max_load, tmp_path):
    figs = []
    monkeypatch.setattr(tf, "save_figure", lambda fig, path, **kw: figs.append(fig))
    tf.fig_heatmaps(rows, train_max_load, tmp_path / "fig9.png")
    return figs[0]


def test_section_heatmap_puts_each_load_in_its_own_cell_and_the_limit_between_them(monkeypatch, tmp_path):
    """`te validate --quick` runs loads 0/2000/4000 N: the section panels drew them on a fixed
    500 N grid (2000 N at 1250–2750, 4000 N at 2750–4250) with the training limit at 3250 N."""
    fig = _drawn(monkeypatch, _rows([0.0, 2000.0, 4000.0]), 3000.0, tmp_path)
    ax = fig.axes[1]  # dir +1, v = 50 mm/s
    (mesh,) = ax.collections
    xy = mesh.get_coordinates()  # (n_loads + 1, n_sections + 1, 2)
    y_edges, x_edges = xy[:, 0, 1], xy[0, :, 0]
    for k, f in enumerate((0.0, 2000.0, 4000.0)):
        assert y_edges[k] < f < y_edges[k + 1]
        assert np.isclose(0.5 * (y_edges[k] + y_edges[k + 1]), f)
    np.testing.assert_allclose(x_edges, [55, 155, 255, 355, 445])  # the last section ends at 445 mm
    (limit,) = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
    y = limit.get_ydata()[0]
    assert 2000.0 < y < 4000.0 and np.isclose(y, y_edges[2])  # the cell border between 2000 and 4000 N
    np.testing.assert_allclose(mesh.get_array().reshape(3, 4)[:, 0], [90, 70, 50])


def test_section_heatmap_full_protocol_grid_is_unchanged(monkeypatch, tmp_path):
    """On the full protocol's 500 N grid the limit stays at 3250 N, between 3000 and 3500 N."""
    loads = [500.0 * k for k in range(11)]
    ax = _drawn(monkeypatch, _rows(loads), 3000.0, tmp_path).axes[1]
    (limit,) = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
    assert np.isclose(limit.get_ydata()[0], 3250.0)
    y_edges = ax.collections[0].get_coordinates()[:, 0, 1]
    np.testing.assert_allclose(y_edges, np.arange(-250.0, 5500.0, 500.0))


def test_fig2_says_which_colour_is_which_load_and_the_real_no_load_speed(monkeypatch, tmp_path):
    """`te campaign`'s fig2_te.png coloured the load runs by load with nothing to read the colours
    by, and its title said "black: 10 mm/s" whatever the no-load runs' speed (here 50 mm/s)."""
    from tests.te_bench.helpers import TINY

    from drivelash.sim.rack_campaign import run_campaign
    from drivelash.te.protocol.campaign import load_campaign

    cfg = replace(TINY, sine_loads=())
    run_campaign(tmp_path / "c", seed=5, config=cfg, workers=1)
    figs = []
    monkeypatch.setattr(tf, "save_figure", lambda fig, path, **kw: figs.append(fig))
    tf.plot_te_over_position(load_campaign(tmp_path / "c"), tmp_path / "fig2.png")
    fig = figs[0]
    te_ax = fig.axes[0]
    assert te_ax.get_title().endswith("black: 50 mm/s, no load") and "100 mm/s" in te_ax.get_title()
    (cbar,) = [a for a in fig.axes if a.get_ylabel().startswith("load [N]")]
    assert cbar.get_ylim() == (0.0, 3000.0)


def test_fig6_training_limit_between_the_loads_and_title_inside_the_figure(monkeypatch, tmp_path):
    """`te evaluate` on the quick campaign (loads 0/2500 N trained, 5000 N beyond max_load
    3000 N): the limit was drawn at 2750 N (largest training load + 250, a 500 N grid's half
    step), and the title ran past the figure's right edge ("stage-1 share 94 °")."""
    from types import SimpleNamespace

    x = np.linspace(0.08, 0.42, 500)
    run = SimpleNamespace(
        x=x, te_def_um=np.sin(300 * x), meta={"name": "load_v20mmps_F2500N_pos", "load": 2500.0}
    )
    table = [
        {"direction": "pos", "load": f, "split": sp, "rms": 2.0, "mae": {"stacked": 0.1, "geo-only": 1.0}}
        for f, sp in ((0.0, "train"), (2500.0, "train"), (5000.0, "extrapolation"))
    ]
    figs = []
    monkeypatch.setattr(tf, "save_figure", lambda fig, path, **kw: figs.append(fig))
    tf.plot_fig6(tmp_path / "f6.png", run, 0.9 * run.te_def_um, run.te_def_um, 0.94, table)
    fig = figs[0]
    ax1, ax2 = fig.axes[:2]
    (limit,) = [ln for ln in ax2.get_lines() if ln.get_label() == "training load limit"]
    assert limit.get_xdata()[0] == 3750.0  # midway between 2500 (trained) and 5000 N (beyond)
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    canvas.draw()  # the constrained layout, as when saved
    title = ax1.title.get_window_extent(canvas.get_renderer())
    assert title.x1 <= fig.bbox.x1 and title.x0 >= 0
    assert "stage-1 share 94 %" in ax1.get_title()


def test_the_three_sine_figures_of_te_validate_name_their_settings(monkeypatch, tmp_path):
    """fig8_sine.png, fig8_sine_paper_settings.png and fig8_sine_loaded.png had one and the same
    title: apart from their file names nothing told the validated compensator, the paper's
    settings and the loaded run apart. The title now names the variant."""
    t = np.linspace(0.0, 2.0, 4001)
    x_d = 0.25 - 0.1 * np.cos(np.pi * t)
    run = {"t": t, "x_d": x_d, "v_d": np.gradient(x_d, t), "x_T": x_d - 1e-6, "theta_m": x_d / 0.02,
           "e": np.full_like(t, 1e-6), "v_c": np.zeros_like(t), "v_bl": np.zeros_like(t)}  # fmt: skip
    figs = []
    monkeypatch.setattr(tf, "save_figure", lambda fig, path, **kw: figs.append(fig))
    tf.fig_sine(run, run, 0.02, tmp_path / "s.png", variant="the paper's settings (t_ss = 35 ms)")
    title = figs[0].get_suptitle()
    assert title.startswith("Sinusoidal trajectory") and title.endswith(
        "\nthe paper's settings (t_ss = 35 ms)"
    )
    tf.fig_sine(run, run, 0.02, tmp_path / "s.png")  # no variant: the title alone
    assert (
        figs[1].get_suptitle() == "Sinusoidal trajectory: compensation of TE and backlash (cf. paper Fig. 8)"
    )
