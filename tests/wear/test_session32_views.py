"""Session 32, tester F: the wear views — F9 (the report's axis plot ticked estimates in the trend
as "not excited"), F3 (why a recording was not excited was stored but never shown), F2 (identical
start stamps: statsmodels' SingularMatrixWarning and "model linear") and F7 (the paper's deadzone A
could not be tracked: any threshold ≥ 0.5 rad was refused as an mrad slip)."""

from __future__ import annotations

import warnings
from datetime import datetime, timedelta
from pathlib import Path

import pytest

from drivelash.errors import ConfigError
from drivelash.wear.alarms import axis_summary
from drivelash.wear.fleet import load_fleet

from .test_fleet_config import DRIVE, GOOD

T0 = datetime(2026, 1, 5, 6, 0)
#: the estimator's reasons, as stored (KR300 axis 1, session 32 tester F, F3)
ONCE = (
    "the motion reverses only once: the gap is crossed once, too few to judge the estimate; "
    "a back-and-forth motion (at least 2 reversals) is needed"
)
FLANK = (
    "the shaft torque reversed 5 times but the gap was never crossed: one flank keeps the load "
    "(a constant load torque such as gravity, or a preload), so the gap cannot be seen"
)


def _row(i: int, delta: float = 0.1, std: float | None = 2e-4, **kw) -> dict:
    r = {
        "status": "ok",
        "excitation_ok": True,
        "converged": True,
        "delta": delta,
        "delta_std": std,
        "start_time": T0 + timedelta(days=i),
        "path": f"rec_{i:03d}.parquet",
        "reason": "18 crossings of the gap; information 0.4 in the last window",
        "samples": 1000 + i,
        "duration_s": 10.0 + i,
        "content_hash": f"h{i}",
    }
    r.update(kw)
    return r


class _Store:
    """Just what :func:`axis_summary` reads of a store (no fleet file: no ``files``)."""

    name = "sqlite:///test.sqlite"

    def __init__(self, rows: list[dict]):
        self.rows = rows

    def current_estimates(self, axis):
        return self.rows

    def close(self):
        pass


def _summary(rows: list[dict], threshold: float = 0.2) -> dict:
    axis = {"name": "M01/X", "threshold_rad": threshold, "horizon_days": 30.0, "not_excited_alarm": 5}
    return axis_summary(_Store(rows), axis, now=T0 + timedelta(days=60))


def _mixed() -> list[dict]:
    """6 converged, 1 unconverged in the trend (±0.4 mrad at 95 %), 1 unconverged left out
    (no usable σ), 2 not excited (two causes), 1 failed."""
    rows = [_row(i, 0.1 + 1e-4 * i) for i in range(6)]
    rows.append(_row(6, 0.1006, std=2e-4, converged=False))
    rows.append(_row(7, 0.1007, std=None, converged=False))
    rows.append(_row(8, 0.1, excitation_ok=False, converged=False, reason=ONCE))
    rows.append(_row(9, 0.1, excitation_ok=False, converged=False, reason=FLANK))
    rows.append(_row(10, None, std=None, status="failed", excitation_ok=None, converged=None, reason="bad"))
    return rows


def _legend(s: dict) -> list[str]:
    from matplotlib.figure import Figure as MplFigure

    from drivelash.report.fleet import _axis_figure

    f = _axis_figure(s, [])
    fig = MplFigure(figsize=f.size)
    f.draw(fig)
    return [t.get_text() for t in fig.axes[0].get_legend().get_texts()]


# --- F9 ------------------------------------------------------------------------------------------


def test_the_axis_plot_ticks_only_unexcited_recordings_as_not_excited():
    """F9: every `ok and not (excited and converged)` row was ticked "not excited" — an
    unconverged estimate in the trend was drawn as a dot *and* a grey tick ("not excited (4)"
    here, the table saying 2). Now: 2 grey ticks, the used unconverged one an open square with its
    95 % interval, the unconverged one left out a tick of its own."""
    s = _summary(_mixed())
    assert s["used"] == 7 and s["unexcited"] == 2 and s["unconverged_used"] == 1
    legend = _legend(s)
    assert "not excited (2)" in legend and "not excited (4)" not in legend, legend
    assert "not converged, in the trend, ±95 % (1)" in legend
    assert "excited, left out of the trend (1)" in legend and "failed file (1)" in legend
    assert "estimate (converged)" in legend
    from drivelash.report.fleet import tick_marks

    marks = tick_marks(s)
    assert marks["not_excited"] == [T0 + timedelta(days=8), T0 + timedelta(days=9)]
    assert marks["left_out"] == [T0 + timedelta(days=7)]  # unconverged, no σ: not in the trend
    assert marks["failed"] == [T0 + timedelta(days=10)]
    used = {r["start_time"] for r in s["used_rows"]}
    assert not used & {t for ts in marks.values() for t in ts}  # an estimate in the trend is never ticked


def test_an_axis_of_converged_estimates_has_no_ticks_and_no_unconverged_marks():
    """Negative control: 8 converged, excited estimates — only dots, no tick, no open square."""
    from drivelash.report.fleet import tick_marks

    s = _summary([_row(i, 0.1 + 1e-4 * i) for i in range(8)])
    assert all(not v for v in tick_marks(s).values())
    legend = _legend(s)
    assert "estimate (converged)" in legend
    assert not [t for t in legend if "not converged" in t or "not excited" in t or "left out" in t], legend


# --- F3 ------------------------------------------------------------------------------------------


def test_brief_reason_is_the_cause_at_the_head_of_the_estimators_reason():
    from drivelash.wear.words import brief_reason

    assert brief_reason(ONCE) == "the motion reverses only once"
    assert brief_reason(FLANK) == "the shaft torque reversed 5 times but the gap was never crossed"
    assert brief_reason("the motion never reverses (unidirectional): only one contact side is seen") == (
        "the motion never reverses"
    )
    assert brief_reason("recording of 3.2 s is shorter than the excitation window of 4 s") == (
        "recording of 3.2 s is shorter than the excitation window of 4 s"
    )
    assert brief_reason(None) == brief_reason("") == "no reason stored"


def test_status_forecast_and_report_say_why_recordings_were_not_excited(monkeypatch, capsys):
    """F3: status, forecast and report said "3 not excited" and nothing more; the reason was
    only in `forecast --json`. Now each groups them by cause (most frequent first)."""
    from drivelash.commands import track
    from drivelash.report.fleet import _axis_figure, render_fleet_report

    rows = _mixed() + [_row(11, 0.1, excitation_ok=False, converged=False, reason=ONCE)]
    s = _summary(rows)
    want = (
        "2 × the motion reverses only once; "
        "1 × the shaft torque reversed 5 times but the gap was never crossed"
    )
    track._print_forecast(s)
    out = " ".join(capsys.readouterr().out.split())
    assert f"not excited: {want}" in out, out
    monkeypatch.setattr(track, "_summaries", lambda db, fleet: (_Store([]), [s], None))
    monkeypatch.setenv("COLUMNS", "200")
    track.run_status("sqlite:///x.sqlite")
    out = " ".join(capsys.readouterr().out.split())
    assert (
        "not excited: 2 × the motion reverses only once (M01/X); 1 × the shaft torque reversed 5 times "
        "but the gap was never crossed (M01/X)" in out
    ), out
    assert f"Not excited: {want}." in _axis_figure(s, []).caption
    html = render_fleet_report([s], {}, title="t", store="s")
    assert "Not excited: 2 × the motion reverses only once (M01/X)" in html
    # negative control: an axis whose recordings were all excited gets no such line
    ok = _summary([_row(i, 0.1 + 1e-4 * i) for i in range(6)])
    track._print_forecast(ok)
    assert "not excited:" not in capsys.readouterr().out
    assert "Not excited" not in render_fleet_report([ok], {}, title="t", store="s")


def test_reason_groups_of_a_fleet_count_axes_and_cap_the_groups():
    from drivelash.wear.words import REASON_GROUPS_SHOWN, not_excited_reasons

    rows = [_row(i, excitation_ok=False, reason=f"cause {i % 5}: detail") for i in range(10)]
    axes = ["A/1" if i < 5 else "A/2" for i in range(10)]
    line = not_excited_reasons(rows, axes)
    assert line.count(" × cause") == REASON_GROUPS_SHOWN and line.endswith("4 × other reasons"), line
    assert "2 × cause 0 (on 2 axes)" in line


# --- F2 ------------------------------------------------------------------------------------------


def _same_stamp(n: int = 6) -> list[dict]:
    return [
        _row(0, 0.0585 + 1e-5 * i, path=f"X_{i}.parquet", samples=64000, duration_s=8.0) for i in range(n)
    ]


def test_identical_start_stamps_give_no_model_and_no_statsmodels_warning(capsys):
    """F2: six recordings at one start stamp printed statsmodels' SingularMatrixWarning (with a
    source line) and were labelled "model linear" with slope 0. Now: no model, one note."""
    from drivelash.commands.track import _print_forecast

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        s = _summary(_same_stamp())
    assert not [w for w in caught if "rank-deficient" in str(w.message)], [str(w.message) for w in caught]
    assert s["model"] is None and s["current_rad"] is None and s["trend"].forecast is None
    assert s["trend"].unfitted == "all 6 usable estimates start at one time"
    notes = [n for n in s["notes"] if "no growth model" in n]
    assert len(notes) == 1 and "\n" not in notes[0], s["notes"]
    assert notes[0].startswith("M01/X: no growth model — all 6 usable estimates start at one time;")
    _print_forecast(s)
    out = " ".join(capsys.readouterr().out.split())
    assert "none fitted: all 6 usable estimates start at one time" in out and "model: none" in out, out
    assert "model: linear" not in out and "5 needed for a trend" not in out
    # a threshold below the estimates: the alarm says why there is no trend, not "too few"
    s = _summary(_same_stamp(), threshold=0.01)
    (msg,) = [a.message for a in s["alarms"] if a.kind == "threshold"]
    assert "no trend: all 6 usable estimates start at one time" in msg and "too few" not in msg, msg


def test_the_same_estimates_a_day_apart_are_fitted_linear():
    """Negative control: the same six estimates on six days — a linear model, no note."""
    rows = [dict(r, start_time=T0 + timedelta(days=i)) for i, r in enumerate(_same_stamp())]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        s = _summary(rows)
    assert not [w for w in caught if "rank-deficient" in str(w.message)]
    assert s["model"] == "linear" and s["trend"].unfitted is None
    assert not [n for n in s["notes"] if "no growth model" in n]


# --- F7 ------------------------------------------------------------------------------------------


def _fleet(tmp_path: Path, threshold: str, delta1: float) -> Path:
    (tmp_path / "drive.toml").write_text(DRIVE.replace("delta1 = 0.05", f"delta1 = {delta1}"))
    p = tmp_path / "fleet.toml"
    p.write_text(GOOD.replace("threshold = 0.2\n", f"threshold = {threshold}\n", 1))
    return p


def test_a_threshold_of_the_papers_deadzone_a_is_taken_on_its_drive(tmp_path):
    """F7: the bench's deadzone A (δ = 1.027 rad, δ1 = 0.5135) could not be tracked — threshold
    1.10 rad was refused "1.1 mrad is threshold = 0.0011". Its drive file's δ1 sets the limit
    (4 δ1, at most δ_max = 2 rad); the mrad slip of that threshold (1100) is still refused."""
    assert load_fleet(_fleet(tmp_path, "1.10", 0.5135)).axes[0].threshold_rad == 1.10
    for bad in ("1100", "2.0"):
        with pytest.raises(ConfigError) as exc:
            load_fleet(_fleet(tmp_path, bad, 0.5135))
        msg = str(exc.value)
        assert "key 'threshold'" in msg and "(limit 2 rad: the estimator's delta_max" in msg, msg
        assert "\n" not in msg
    # 4 δ1 below δ_max: the limit is 4 δ1
    with pytest.raises(ConfigError, match=r"\(limit 1\.2 rad: 4 × the drive's delta1 0\.3 rad\)"):
        load_fleet(_fleet(tmp_path, "1.25", 0.3))
    assert load_fleet(_fleet(tmp_path, "1.15", 0.3)).axes[0].threshold_rad == 1.15
    # a smaller [estimator] delta_max caps it
    p = _fleet(tmp_path, "1.6", 0.5135)
    (tmp_path / "drive.toml").write_text(
        (tmp_path / "drive.toml").read_text() + "[estimator]\ndelta_max = 1.5\n"
    )
    with pytest.raises(ConfigError, match=r"1\.6 rad .* \(limit 1\.5 rad: the estimator's delta_max"):
        load_fleet(p)


def test_a_small_gap_axis_still_refuses_the_mrad_slip(tmp_path):
    """Negative control (the slip the check was built for): δ1 = 0.05 rad keeps the 0.5 rad limit;
    1.1 and 86.46 are refused naming mrad, 0.499 taken; a 4 δ1 between keeps 0.5 too."""
    with pytest.raises(ConfigError, match=r"1\.1 rad .* \(limit 0\.5 rad\); the key is in rad — 1\.1 mrad"):
        load_fleet(_fleet(tmp_path, "1.1", 0.05))
    with pytest.raises(ConfigError, match=r"86\.46 mrad is threshold = 0\.08646"):
        load_fleet(_fleet(tmp_path, "86.46", 0.05))
    assert load_fleet(_fleet(tmp_path, "0.499", 0.05)).axes[0].threshold_rad == 0.499
    with pytest.raises(ConfigError, match=r"\(limit 0\.5 rad\)"):
        load_fleet(_fleet(tmp_path, "0.5", 0.12))  # 4 δ1 = 0.48 < 0.5
