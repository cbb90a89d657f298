"""HTML reports: self-contained, figures rendered (non-blank), and clean in headless Chromium."""

from __future__ import annotations

import base64
import io
import re
import shutil
import subprocess

import numpy as np
import pytest
from PIL import Image

from drivelash.io.config import parse_config
from drivelash.report import render_identify_report, write_estimate_report

_IMG = re.compile(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"')


def _images(html: str) -> list[Image.Image]:
    return [Image.open(io.BytesIO(base64.b64decode(b))).convert("RGB") for b in _IMG.findall(html)]


def _non_blank(img: Image.Image) -> float:
    """Fraction of pixels that are not (near-)white."""
    a = np.asarray(img, dtype=np.int16)
    return float(np.mean(np.any(a < 235, axis=2)))


def _assert_self_contained(html: str) -> None:
    low = html.lower()
    assert "<script" not in low
    assert "http://" not in low and "https://" not in low
    assert not re.search(r'(src|href)="(?!data:)', low), "external resource referenced"


@pytest.fixture(scope="module")
def estimate_run():
    """bench-0A (2 s) and the deadzone estimator of the estimation package."""
    from drivelash.estimation.estimator import DeadzoneEstimator
    from drivelash.params import BacklashParams, DrivetrainParams
    from identify.helpers import simulated_trace

    tr = simulated_trace(2.0)
    drivetrain = DrivetrainParams(**tr.meta["estimator_drivetrain"])
    bl = BacklashParams(**tr.meta["estimator_backlash"])
    result = DeadzoneEstimator(drivetrain, bl, T_s=tr.T_s).run(tr)
    cfg = parse_config(
        {"drivetrain": drivetrain.to_dict(), "backlash": {"delta1": bl.delta1, "alpha": bl.alpha}}
    )
    return tr, result, cfg


def test_estimate_report_is_self_contained_with_rendered_figures(tmp_path, estimate_run):
    tr, result, cfg = estimate_run
    path = write_estimate_report(tmp_path / "est.html", tr, result, cfg)
    html = path.read_text()
    _assert_self_contained(html)
    imgs = _images(html)
    assert len(imgs) >= 5  # overview, δ̂(t), deadzone picture, portraits, observer
    for img in imgs:
        assert img.width > 300 and img.height > 200
        assert _non_blank(img) > 0.01
    for key in ("overview", "delta", "deadzone", "portraits"):
        assert f'id="fig-{key}"' in html
    assert "Excitation:" in html and ("sufficient" in html)
    assert "[drivetrain]" in html and "K_S" in html
    assert sorted(p.name for p in tmp_path.iterdir()) == ["est.html"]


def test_report_states_the_recording_start_from_its_time_stamps(tmp_path, estimate_run, monkeypatch):
    """A recording whose time column held stamps (a logger's clock) names its start in the
    report's Recording section; one without stamps does not invent one."""
    from dataclasses import replace

    tr, result, cfg = estimate_run
    _drawn_figures(monkeypatch)  # the page's text is the subject: figures drawn, not rasterised
    plain = write_estimate_report(tmp_path / "plain.html", tr, result, cfg).read_text()
    assert "Recorded from" not in plain
    stamped = replace(tr, meta={**tr.meta, "time_origin": {"Zeit": "2026-11-05T07:03:00+00:00"}})
    html = write_estimate_report(tmp_path / "stamped.html", stamped, result, cfg).read_text()
    assert "Recorded from 2026-11-05T07:03:00+00:00 — the first time stamp of column &#x27;Zeit&#x27;" in html
    naive = replace(tr, meta={**tr.meta, "time_origin": {"Zeit": "2026-11-05T07:03:00"}})
    html = write_estimate_report(tmp_path / "naive.html", naive, result, cfg).read_text()
    assert "Recorded from 2026-11-05T07:03:00 (no time zone in the file) — the first" in html


def test_excitation_shading_follows_sigma_window(estimate_run):
    """The δ̂(t) figure shades excited stretches: with σ-window zeroed, no green shading is drawn."""
    import dataclasses

    tr, result, cfg = estimate_run
    from drivelash.report import render_estimate_report

    def green_fraction(res) -> float:
        html = render_estimate_report(tr, res, cfg)
        img = next(
            i for k, i in zip(re.findall(r'id="fig-(\w+)"', html), _images(html), strict=True) if k == "delta"
        )
        a = np.asarray(img, dtype=np.int16)
        # shading colour #bfe3c6 at alpha 0.6 over white ≈ (216, 238, 221)
        return float(np.mean((np.abs(a - np.array([216, 238, 221])) < 12).all(axis=2)))

    flat = dataclasses.replace(result, sigma_window=np.zeros_like(result.sigma_window))
    assert green_fraction(result) > 0.05
    assert green_fraction(flat) < 0.001


@pytest.fixture(scope="module")
def bench_0c_two_mass():
    """bench-0C, 4 s, seed 1, and its two-mass identification (read by three report checks)."""
    import drivelash as dl
    from drivelash.sim import get_scenario

    run = get_scenario("bench-0C").simulate(duration=4.0, seed=1)
    return run, dl.identify_drive(run, model="two-mass", N=1.0)


def test_identify_report_tables(tmp_path):
    from drivelash.estimation.identify import identify_rigid
    from drivelash.io import Trace

    t = np.arange(6000) * 1e-3
    q = np.sin(2 * np.pi * 0.5 * t) + 0.2 * np.sin(2 * np.pi * 2.1 * t)
    dq = np.gradient(q, 1e-3)
    tau = 3 * np.gradient(dq, 1e-3) + 0.5 * dq + 0.2 * np.sign(dq)
    tr = Trace({"t": t, "theta_m": q, "torque_m": tau}, {"source": "synthetic.csv"})
    html = render_identify_report(tr, identify_rigid(tr), None)
    _assert_self_contained(html)
    assert "Identified parameters" in html and "kg·m²" in html
    assert all(_non_blank(i) > 0.01 for i in _images(html))


def test_identify_report_takes_what_identify_drive_returns(tmp_path, bench_0c_two_mass):
    """Tester finding (session 14): ``write_identify_report(path, trace, identify_drive(...))``
    raised ``AttributeError: 'DriveIdentification' object has no attribute 'theta'`` for both
    models. It now writes the report the command writes: the rigid one from the IDIM-LS result
    the API's result was built from, the two-mass one through its own renderer.

    The footer's "generated" minute is fixed by tests/conftest.py (``SOURCE_DATE_EPOCH``): the
    two renders compared here once straddled a minute boundary under load (session 15)."""
    import drivelash as dl
    from drivelash.estimation.identify import identify_rigid
    from drivelash.io import Trace
    from drivelash.report import write_identify_report
    from drivelash.report.identify_figures import render_two_mass_report

    t = np.arange(6000) * 1e-3
    q = np.sin(2 * np.pi * 0.5 * t) + 0.2 * np.sin(2 * np.pi * 2.1 * t)
    dq = np.gradient(q, 1e-3)
    tau = 3 * np.gradient(dq, 1e-3) + 0.5 * dq + 0.2 * np.sign(dq)
    tr = Trace({"t": t, "theta_m": q, "torque_m": tau}, {"source": "synthetic.csv"})
    api = dl.identify_drive(tr, model="rigid")
    p = write_identify_report(tmp_path / "rigid.html", tr, api)
    assert p.read_text(encoding="utf-8") == render_identify_report(tr, identify_rigid(tr), None)
    run, two = bench_0c_two_mass
    html = write_identify_report(tmp_path / "two.html", run, two).read_text(encoding="utf-8")
    assert html == render_two_mass_report(run, two, None)
    assert "generated 2026-01-01 12:00 UTC" in html  # SOURCE_DATE_EPOCH of tests/conftest.py
    _assert_self_contained(html)


def _chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")


def _shoot(exe: str, html_path, png_path, tmp_path) -> str:
    r = subprocess.run(
        [
            exe,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            f"--user-data-dir={tmp_path / ('profile-' + png_path.stem)}",
            "--window-size=1200,3000",
            f"--screenshot={png_path}",
            "--enable-logging=stderr",
            "--v=0",
            html_path.as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert png_path.exists(), r.stderr[-2000:]
    return r.stderr


@pytest.mark.browser
def test_report_in_headless_chromium(tmp_path, estimate_run):
    exe = _chromium()
    if exe is None:
        pytest.skip("chromium not installed (make test installs it when run as root)")
    # control: the console-error detection must see a deliberate console.error
    neg = tmp_path / "neg.html"
    neg.write_text('<!DOCTYPE html><html><body><script>console.error("marker-7731")</script></body></html>')
    log = _shoot(exe, neg, tmp_path / "neg.png", tmp_path)
    assert "CONSOLE" in log and "marker-7731" in log

    tr, result, cfg = estimate_run
    page = write_estimate_report(tmp_path / "report.html", tr, result, cfg)
    shot = tmp_path / "report.png"
    log = _shoot(exe, page, shot, tmp_path)
    console = [ln for ln in log.splitlines() if "CONSOLE" in ln]
    assert console == [], console
    img = Image.open(shot).convert("RGB")
    a = np.asarray(img, dtype=np.int16)
    # Figures drawn: matplotlib's default blue lines (31, 119, 180) appear in the overview
    # and δ̂(t) plots — the page's own CSS has no such colour; broken images would show none.
    blue = (np.abs(a - np.array([31, 119, 180])) < 30).all(axis=2)
    assert blue.sum() > 2000, blue.sum()
    # and the figure area is far from blank
    assert _non_blank(img) > 0.05
    shutil.copy(shot, tmp_path / "last-report-screenshot.png")


def test_two_mass_report_of_a_geared_motor_only_fit_says_what_was_fitted():
    """Found by an exploratory tester (session 13) on the KUKA report (axis 1, rec_B, N = 257,
    ``equations = "motor"``, ``torque_offset = 0``): the overview drew θ_m (±130 rad) beside θ_l
    (0.5 rad, a flat line), the text said "and a torque offset" (fixed at 0), and the load
    equation was drawn (model ω̇_l ≡ 0 against the measured one) though it was not fitted. Now the
    motor side is drawn at the load (θ_m/N), the text says what was fixed and left out, and only
    the fitted equation is drawn. Negative control: a bench fit (N = 1, both equations, offset
    fitted) keeps its text and both equations."""
    from tests.identify.helpers import REPO

    import drivelash as dl
    from drivelash.report import _overview_figure
    from drivelash.report.identify_figures import render_two_mass_report
    from drivelash.sim.scenarios import get_scenario
    from realdata import shared_data

    mat = shared_data("kuka-kr300", "rec_B.mat")
    cfg = dl.load_config(REPO / "examples" / "kuka" / "axis1.toml")
    trace = dl.load_trace(mat, cfg, required=["theta_m", "theta_l", "torque_m"])
    r = dl.identify_drive(trace, cfg)
    html = render_two_mass_report(trace, r, cfg)
    assert "torque offset fixed at 0 N·m" in html and "and a torque offset" not in html
    assert "motor equation only" in html
    assert _images(html)  # rendered
    from matplotlib.figure import Figure as MplFigure

    fig = MplFigure()
    _overview_figure(trace, r.N).draw(fig)
    pos = fig.axes[0]
    spans = {ln.get_label(): float(np.ptp(ln.get_ydata())) for ln in pos.get_lines()}
    m_label = next(k for k in spans if k.startswith("theta_m / N"))
    assert spans[m_label] == pytest.approx(spans["theta_l"], rel=0.05)  # both at the load
    assert "load side" in pos.get_ylabel()
    # negative control: without N the motor side dwarfs the link by N
    fig = MplFigure()
    _overview_figure(trace).draw(fig)
    spans = {ln.get_label(): float(np.ptp(ln.get_ydata())) for ln in fig.axes[0].get_lines()}
    assert spans["theta_m"] > 100 * spans["theta_l"]

    bench = get_scenario("bench-0B").simulate(duration=6.0)
    rb = dl.identify_drive(bench, model="two-mass", N=1.0)
    hb = render_two_mass_report(bench, rb, None)
    assert "and a torque offset" in hb and "motor equation only" not in hb


def test_report_time_is_now_or_source_date_epoch(monkeypatch):
    """The footer's time: SOURCE_DATE_EPOCH when set (reproducible reports), now otherwise
    (negative control), and a malformed value is one ParameterError line, not a silent now."""
    from datetime import UTC, datetime, timedelta

    from drivelash.errors import ParameterError
    from drivelash.report.html import generated_at

    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1767268800")
    assert generated_at() == datetime(2026, 1, 1, 12, 0, tzinfo=UTC)
    monkeypatch.delenv("SOURCE_DATE_EPOCH")
    assert abs(generated_at() - datetime.now(UTC)) < timedelta(seconds=5)
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "2026-01-01")
    with pytest.raises(ParameterError, match="SOURCE_DATE_EPOCH: must be whole seconds since 1970"):
        generated_at()


def _drawn_figures(monkeypatch) -> dict[str, object]:
    """Capture the matplotlib figures a report draws (key → Figure) instead of its PNGs: the
    checks using it read the figures' titles, labels and lines and the page's text, never its
    pictures, so each figure is drawn but not rasterised (a 1×1 PNG stands in; session 33: the
    rasterising was ≈ 0.5 s a figure of `make test`'s budget). The pictures themselves are checked
    by the tests that render whole reports (test_estimate_report_is_self_contained_…, the
    headless-Chromium check)."""
    from matplotlib.figure import Figure as MplFigure

    import drivelash.report.html as rhtml

    drawn: dict[str, object] = {}
    buf = io.BytesIO()
    Image.new("RGB", (1, 1), "white").save(buf, format="PNG")
    stand_in = buf.getvalue()

    def capture(spec, dpi=90):
        fig = MplFigure(figsize=spec.size, dpi=dpi, layout="constrained")
        spec.draw(fig)
        drawn[spec.key] = fig
        return stand_in

    monkeypatch.setattr(rhtml, "png_bytes", capture)
    return drawn


def test_deadzone_picture_draws_the_gap_the_estimator_ended_with(monkeypatch, estimate_run):
    """The deadzone picture's model line and shaded gap use the δ1 the estimator used (the data's,
    when the δ1 check switched) and the reported δ̂ and stiffness scale — not the configured δ1:
    on bench-0A with δ1 = 93 mrad configured, the data's lower contact at −513.6 mrad had been drawn
    at −93 mrad, the gap shaded from −93 to +934 mrad where the estimate put it at ±513."""
    import dataclasses

    from drivelash.report import render_estimate_report

    tr, result, cfg = estimate_run
    d1_used, kappa = 0.5136, 0.75
    res = dataclasses.replace(
        result, extra={**result.extra, "delta1_used": d1_used, "stiffness_scale": kappa}
    )
    drawn = _drawn_figures(monkeypatch)
    render_estimate_report(tr, res, cfg)
    ax = drawn["deadzone"].axes[0]
    line = next(ln for ln in ax.get_lines() if ln.get_label().startswith("deadzone with final δ̂"))
    assert "δ1 = 513.6 mrad" in line.get_label() and "κ = 0.75" in line.get_label()
    x, y = (np.asarray(v, float) for v in line.get_data())
    flat = x[np.abs(y) < 1e-12]
    lo, hi = -1e3 * d1_used, 1e3 * (res.delta - d1_used)
    grid_step = float(np.diff(x).max())
    clipped_lo, clipped_hi = max(lo, x.min()), min(hi, x.max())
    assert abs(flat.min() - clipped_lo) <= grid_step and abs(flat.max() - clipped_hi) <= grid_step
    outside = x > hi + grid_step
    if outside.any():
        slope = np.diff(y[outside]) / np.diff(x[outside] * 1e-3)
        np.testing.assert_allclose(slope, kappa * cfg.drivetrain.K_S, rtol=1e-6)
    (span,) = ax.patches  # the shaded gap (an axvspan: a Rectangle in data x)
    x0 = span.get_x()
    assert np.isclose(x0, lo) and np.isclose(x0 + span.get_width(), hi)


def test_identify_reports_residual_axes_state_their_unit(monkeypatch, bench_0c_two_mass):
    """The residual panels under the measured-vs-model plots had a bare "residual" y label: the
    rigid report's is in the force unit (N·m here), the two-mass one's in rad/s² like the
    acceleration above it."""
    from drivelash.estimation.identify import identify_rigid
    from drivelash.io import Trace
    from drivelash.report.identify_figures import render_two_mass_report

    t = np.arange(6000) * 1e-3
    q = np.sin(2 * np.pi * 0.5 * t) + 0.2 * np.sin(2 * np.pi * 2.1 * t)
    dq = np.gradient(q, 1e-3)
    tau = 3 * np.gradient(dq, 1e-3) + 0.5 * dq + 0.2 * np.sign(dq)
    tr = Trace({"t": t, "theta_m": q, "torque_m": tau}, {"source": "synthetic.csv"})
    drawn = _drawn_figures(monkeypatch)
    render_identify_report(tr, identify_rigid(tr), None)
    labels = [ax.get_ylabel() for f in drawn.values() for ax in f.axes]
    assert "residual [N·m]" in labels and "residual" not in labels
    run, two = bench_0c_two_mass
    drawn.clear()
    render_two_mass_report(run, two, None)
    labels = [ax.get_ylabel() for f in drawn.values() for ax in f.axes]
    assert labels.count("residual [rad/s²]") == 2 and "residual" not in labels


def test_interval_text_has_no_bare_trailing_point():
    """The KUKA two-mass report printed D_S's interval as ``[-19538., 14461.]``: the ``#`` format
    that keeps trailing zeros also kept a bare decimal point on whole numbers."""
    from drivelash.estimation.identify_result import ParameterEstimate as P

    assert P.normal("D_S", -2538.55, 8673.34).interval_text() == "[-19538, 14461]"
    assert P.normal("K_S", 869917.0, 342651.0).interval_text() == "[1.9833e+05, 1.5415e+06]"
    assert P("delta1", 0.513497, 1.38e-5, 0.51347, 0.513524).interval_text() == "[0.513470, 0.513524]"


def test_two_mass_characteristic_does_not_show_an_undetermined_backlash_as_identified(
    monkeypatch, bench_0c_two_mass
):
    """KUKA rec_A, axis 1: the table says δ and δ1 are not identifiable (overlapping contacts,
    encoder delay), yet the characteristic drew "identified K_S·dz(Δθ)" with "contact −δ1 =
    1.5085 mrad" and a caption "and the identified deadzone". The fit's contacts stay as a
    diagnostic, named as the fit's and not reported. Negative control: a determined bench fit."""
    from tests.identify.helpers import REPO

    import drivelash as dl
    from drivelash.report.identify_figures import render_two_mass_report
    from realdata import shared_data

    def labels_and_caption(trace, r, cfg):
        drawn = _drawn_figures(monkeypatch)
        html = render_two_mass_report(trace, r, cfg)
        ax = drawn["characteristic"].axes[0]
        return [ln.get_label() for ln in ax.get_lines()], html

    mat = shared_data("kuka-kr300", "rec_A.mat")
    cfg = dl.load_config(REPO / "examples" / "kuka" / "axis1.toml")
    trace = dl.load_trace(mat, cfg, required=["theta_m", "theta_l", "torque_m"])
    r = dl.identify_drive(trace, cfg)
    assert not r.parameters["delta"].identifiable
    labels, html = labels_and_caption(trace, r, cfg)
    assert not any(lb.startswith(("identified", "contact")) for lb in labels)
    assert any(lb.startswith("fit's K_S·dz(Δθ) (δ") and "not determined" in lb for lb in labels)
    assert any(lb.startswith("fit's contact −δ1") and lb.endswith("(not reported)") for lb in labels)
    assert "and the identified deadzone" not in html
    assert "not reported: the backlash was not determined" in html

    run, rb = bench_0c_two_mass
    assert rb.parameters["delta"].identifiable
    labels, html = labels_and_caption(run, rb, None)
    assert "identified K_S·dz(Δθ)" in labels and any(lb.startswith("contact −δ1 = ") for lb in labels)
    assert "and the identified deadzone." in html


def test_estimate_identify_report_shows_the_offline_delta_and_the_drive_used(monkeypatch, tmp_path):
    """`estimate --identify` on a config with only N: the report showed the configured
    [drivetrain] (T_Cm 0, no K_S) as if it were the drive, left out the offline δ and its interval
    the command prints and the JSON holds, and drew no deadzone line (no K_S in the config)."""
    import json

    from typer.testing import CliRunner

    from drivelash.cli import app
    from drivelash.sim.scenarios import get_scenario

    rec = tmp_path / "b0b.parquet"
    get_scenario("bench-0B").simulate(duration=8.0).to_parquet(rec)
    cfg = tmp_path / "n.toml"
    cfg.write_text("[drivetrain]\nN = 1.0\n")
    drawn = _drawn_figures(monkeypatch)
    out = CliRunner().invoke(
        app,
        ["estimate", str(rec), "--config", str(cfg), "--identify", "--json", str(tmp_path / "e.json"),
         "--report", str(tmp_path / "e.html")],
    )  # fmt: skip
    assert out.exit_code == 0, out.output
    s = json.loads((tmp_path / "e.json").read_text())
    html = (tmp_path / "e.html").read_text()
    off = s["identification"]["delta"]
    assert f"{1e3 * off['value']:.6g}" in html  # offline δ [mrad], as the table rounds it
    assert f"[{1e3 * off['ci95'][0]:.3f}, {1e3 * off['ci95'][1]:.3f}]" in html
    assert "drive the estimator was given (identified from the recording)" in html
    assert f"{s['drivetrain_used']['K_S']:.6g}" in html
    labels = [ln.get_label() for ln in drawn["deadzone"].axes[0].get_lines()]
    assert any(lb.startswith("deadzone with final δ̂") for lb in labels)


def test_delta_figures_state_a_run_that_did_not_converge(monkeypatch, tmp_path, estimate_run):
    """bench-0A for 4 s: δ̂ stalls at 607 of 1027 mrad, the JSON says converged = false and the
    terminal "not converged — do not use this estimate", but the --plot and the report's δ̂(t)
    titles said only "excitation sufficient". Both now say "NOT converged"; a converged run
    says "converged", an unexcited one only "excitation INSUFFICIENT"."""
    import dataclasses

    import drivelash.report.estimation_figures as ef
    from drivelash.report import render_estimate_report

    tr, result, cfg = estimate_run
    drawn = _drawn_figures(monkeypatch)
    plots = []
    monkeypatch.setattr(ef, "save_figure", lambda fig, path, **kw: plots.append(fig))
    for conv, exc, want in (
        (False, True, "excitation sufficient, NOT converged"),
        (True, True, "excitation sufficient, converged"),
        (False, False, "excitation INSUFFICIENT"),
    ):
        res = dataclasses.replace(result, converged=conv, excitation_ok=exc)
        render_estimate_report(tr, res, cfg)
        assert drawn["delta"].axes[0].get_title().endswith(f"— {want}")
        ef.estimate_figure(tr, res, tmp_path / "p.png")
        assert plots[-1].axes[0].get_title() == f"deadzone estimate — {want}"


def test_estimate_report_without_an_online_run_says_so_first(tmp_path, capsys):
    """KUKA rec_A with `estimate --identify --report`: the online law cannot run; the page the
    user asked for as an estimate report was the identification report alone — nothing on it
    said that there is no online δ̂ or why (only the JSON's warnings did)."""
    from tests.identify.helpers import REPO

    from cli_runner import run_in_process
    from realdata import shared_data

    mat = shared_data("kuka-kr300", "rec_A.mat")
    cfg = REPO / "examples" / "kuka" / "axis1.toml"
    rep, js = tmp_path / "r.html", tmp_path / "r.json"
    argv = ["estimate", str(mat), "-c", str(cfg), "--identify", "--report", str(rep), "--json", str(js)]
    code, _, err = run_in_process(argv, capsys)
    assert code == 0, err
    import html as h
    import json

    s = json.loads(js.read_text())
    page = rep.read_text(encoding="utf-8")
    first = page.index("No online deadzone estimate: ")
    assert first < page.index("Identified parameters")
    why = s["reason"].removeprefix("online estimate not run: ")
    assert page[first:].startswith(f"No online deadzone estimate: {h.escape(why)}.")
    assert "This report holds the offline identification only." in page


def test_interval_of_an_unconverged_run_is_not_shown_as_usable(estimate_run):
    """bench-0A for 4 s: δ̂ = 606.6 mrad of a true 1027, "not converged — do not use this
    estimate" on the terminal, but the report's figures of merit gave "95 % interval of δ̂
    [605.582, 607.581]" with no caveat. The row now says it is statistical only and not to be
    used; a converged run keeps the plain label."""
    import dataclasses

    from drivelash.report import render_estimate_report

    tr, result, cfg = estimate_run
    result = dataclasses.replace(result, delta_std=0.00051)  # a stated interval, ±1 mrad
    lo, hi = result.delta_interval
    caveat = "95 % interval of δ̂ [mrad] (statistical only; not converged: do not use)"
    html = render_estimate_report(tr, dataclasses.replace(result, converged=False), cfg)
    assert caveat in html and f"[{1e3 * lo:.3f}, {1e3 * hi:.3f}]" in html
    html = render_estimate_report(tr, dataclasses.replace(result, converged=True), cfg)
    assert "95 % interval of δ̂ [mrad]" in html and "not converged: do not use" not in html


def test_configuration_table_names_the_defaults_the_file_never_set(tmp_path, estimate_run):
    """The configuration tables listed every key with a value — 32 [estimator] keys for a file
    that set two — as if the user had written them (session 17's report audit, left then). Each
    row now says whether the configuration gave the value or it is the default (the estimator's
    own defaults are derived and shown in "estimator gains used")."""
    from drivelash.io import load_config

    tr, result, _ = estimate_run
    cfg = load_config("examples/drive_bench.toml")  # sets delta_max and delta0 of [estimator]
    html = write_estimate_report(tmp_path / "est.html", tr, result, cfg).read_text()

    def source(table: str, key: str) -> str:
        body = html[html.index(f"<caption>[{table}]</caption>") :]
        m = re.search(rf"<tr><td[^>]*>{key}</td><td[^>]*>[^<]*</td><td[^>]*>(\w+)</td></tr>", body)
        assert m is not None, (table, key)
        return m.group(1)

    assert source("drivetrain", "K_S") == "given" and source("backlash", "delta1") == "given"
    assert source("estimator", "delta_max") == "given" and source("estimator", "delta0") == "given"
    assert source("backlash", "alpha") == "default"  # not in the file
    for table in ("drivetrain", "backlash", "estimator"):
        sec = getattr(cfg, table)
        unset = {k for k, v in sec.model_dump().items() if v is not None} - sec.model_fields_set
        assert all(source(table, k) == "default" for k in unset), table


def test_estimate_report_shows_every_warning_the_json_gives(tmp_path, capsys):
    """Found by an exploratory tester (s19 F19): `estimate b0c.parquet --config drive_bench.toml
    --report` — the terminal and the JSON warn "δ̂ = 145.4 mrad exceeds the whole Δθ range
    observed … the estimate is not a measurement", the page had no warning at all (the renderer
    showed only the reader's). Now every JSON warning is on the page, under the verdict. On the
    old code none of them is."""
    import html as h
    import json

    from cli_runner import run_in_process
    from drivelash.sim.scenarios import get_scenario
    from identify.helpers import REPO

    rec = tmp_path / "b0c.parquet"
    get_scenario("bench-0C").simulate(duration=6.0, seed=1).to_parquet(rec)
    rep, js = tmp_path / "e.html", tmp_path / "e.json"
    cfg = REPO / "examples" / "drive_bench.toml"
    code, _, err = run_in_process(
        ["estimate", str(rec), "-c", str(cfg), "--report", str(rep), "--json", str(js)], capsys
    )
    assert code == 0, err
    warnings = json.loads(js.read_text())["warnings"]
    assert any("not a measurement" in w for w in warnings), warnings  # the case the tester filed
    page = rep.read_text(encoding="utf-8")
    for w in warnings:
        assert f'<div class="warn">{h.escape(w)}</div>' in page, w
    # each once: the estimator's under the verdict, the reader's (none here) with the recording
    from drivelash.io import load_trace

    assert page.count('<div class="warn">') == len(warnings) + len(load_trace(rec).meta.get("warnings", []))
