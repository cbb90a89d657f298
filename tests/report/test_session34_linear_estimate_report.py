"""``estimate --report`` and ``--plot`` on a linear (prismatic) axis label its gap in µm and its
effort as a force in N (session 34, tester G, G7: the report showed "final δ̂ [mrad] 0.019784" for
19.784 µm — a number in mm labelled mrad —, "deadzone [mrad]", "Δθ [mrad]", "shaft torque
[N·m]", θ [rad], ω [rad/s], φ̂ [rad/s²] and the caption "SI units: rad, rad/s, N·m, s").

Recording: tests/linear_bench.py (bench-0B in units 1e-3, 3 s). The figures are drawn, not
rasterised (the report tests' stand-in, ``_drawn_figures``). Negative control: the same numbers
mapped as angles keep mrad, rad, rad/s, N·m.
"""

from __future__ import annotations

import pytest
from tests.report.test_report import _drawn_figures

from drivelash.report import _thin
from linear_bench import write_linear_bench


@pytest.fixture(scope="module")
def estimates(tmp_path_factory):
    import drivelash as dl

    d = write_linear_bench(tmp_path_factory.mktemp("lin35r"), duration=3.0)
    out = {}
    for name in ("lin", "ang"):
        cfg = dl.load_config(d / f"{name}.toml")
        out[name] = (dl.estimate_backlash(d / "lin.parquet", cfg), cfg)
    return out


LINEAR = {
    "gap": "µm", "per": 1e6, "pos": "m", "vel": "m/s", "acc": "m/s²", "effort": "force", "unit": "N",
}  # fmt: skip
ROTARY = {
    "gap": "mrad", "per": 1e3, "pos": "rad", "vel": "rad/s", "acc": "rad/s²",
    "effort": "torque", "unit": "N·m",
}  # fmt: skip


@pytest.mark.parametrize(("name", "want"), [("lin", LINEAR), ("ang", ROTARY)])
def test_estimate_report_labels_follow_the_axis(monkeypatch, estimates, name, want):
    from drivelash.report import render_estimate_report

    est, cfg = estimates[name]
    assert est.trace.meta["axis"] == ("prismatic" if name == "lin" else "rotary")
    drawn = _drawn_figures(monkeypatch)
    html = render_estimate_report(est.trace, est.result, cfg, summary=est.summary)
    g = want["gap"]
    assert drawn["delta"].axes[0].get_ylabel() == f"deadzone [{g}]"
    dz = drawn["deadzone"].axes[0]
    assert dz.get_xlabel() == f"Δθ = θ_m/N − θ_l [{g}]"
    assert dz.get_ylabel() == f"shaft {want['effort']} [{want['unit']}]"
    line = next(ln for ln in dz.get_lines() if ln.get_label().startswith("deadzone with final δ̂"))
    # the gap unit's own formatting: one decimal, two significant digits below 1 (session 36, I5:
    # the rotary case's δ1 = 0.093 mrad printed "0.1 mrad")
    from drivelash.units import gap_unit

    d1 = gap_unit(est.trace.meta["axis"]).f(est.summary["delta1_used"], ".1f")
    assert f"δ1 = {d1})" in line.get_label() and d1.endswith(f" {g}"), line.get_label()
    # the plotted δ̂ is the reported one in the labelled unit
    y = drawn["delta"].axes[0].get_lines()[0].get_ydata()
    assert y[-1] == pytest.approx(want["per"] * _thin(est.result.delta_hat)[0][-1], rel=1e-12)
    p = drawn["portraits"].axes
    assert (p[0].get_xlabel(), p[1].get_xlabel(), p[1].get_ylabel()) == (
        f"θ_m/N [{want['pos']}]",
        f"θ_m [{want['pos']}]",
        f"ω_m [{want['vel']}]",
    )
    assert drawn["observer"].axes[0].get_ylabel() == f"φ̂ [{want['acc']}]"
    assert f"<td>final δ̂ [{g}]</td>" in html
    assert f"{want['per'] * est.delta:.6g}" in html  # the table's value in that unit
    assert f"SI units: {want['pos']}, {want['vel']}, {want['unit']}, s" in html
    if name == "lin":
        assert "mrad" not in html and "N·m" not in html and "rad/s" not in html


@pytest.mark.parametrize(("name", "want"), [("lin", LINEAR), ("ang", ROTARY)])
def test_estimate_plot_labels_follow_the_axis(monkeypatch, tmp_path, estimates, name, want):
    import drivelash.report.estimation_figures as ef

    est, _ = estimates[name]
    plots = []
    monkeypatch.setattr(ef, "save_figure", lambda fig, path, **kw: plots.append(fig))
    ef.estimate_figure(est.trace, est.result, tmp_path / "p.png")
    a1, a2 = plots[-1].axes
    assert a1.get_ylabel() == f"deadzone [{want['gap']}]"
    assert a1.get_lines()[0].get_ydata()[-1] == pytest.approx(
        want["per"] * est.result.delta_hat[-1], rel=1e-12
    )
    assert a2.get_xlabel() == f"Δθ = θ_m/N − θ_l [{want['gap']}]"
    assert a2.get_ylabel() == f"shaft {want['effort']} [{want['unit']}]"
