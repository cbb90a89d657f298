"""Where a trend is judged "now" (s19 tester, finding F5): one recording after a gap (a machine
idle for a month, or a clock/file-name date a month or years late) is left out of the fit as an
outlier, yet ``track status`` extrapolated the straight line to its date — "δ now 429.91 mrad",
"threshold crossed" and a threshold alarm although no estimate ever exceeded 131.9 mrad (with a
2037 date: 38772 mrad). The trend is now judged at the latest estimate that does not contradict
it (``trend.judged_at``), and a recording dated after the clock is left out and named."""

from __future__ import annotations

import json
import shutil
from datetime import datetime
from pathlib import Path

import numpy as np
import pytest

from cli_runner import run_in_process
from drivelash.wear import Store, ingest, load_fleet
from drivelash.wear.alarms import FUTURE_TOLERANCE_DAYS, fleet_summary
from drivelash.wear.trend import _forecast, fit_trend

FLEET = """[fleet]
name = "gap"
time = {{ from = "filename", pattern = '_(\\d{{8}}T\\d{{6}})\\.', format = "%Y%m%dT%H%M%S" }}
[[axis]]
id = "M02/Y"
drive = "drives/M02-Y.toml"
recordings = "rec/*.parquet"
threshold = {thr}
"""


def test_a_late_estimate_far_below_the_trend_is_not_extrapolated_to():
    """Unit level: six daily estimates of linear wear (10 mrad/day) and the seventh a month
    later at its true value (a month of standstill). The fitted line at the late date is far
    above the threshold; the estimate there is below it. Judged at the late date (the old rule,
    negative control) the threshold is "crossed"; now at day 5, not crossed."""
    days = np.array([0.0, 1, 2, 3, 4, 5, 36])
    y = 0.060 + 0.010 * np.array([0.0, 1, 2, 3, 4, 5, 6])  # the 7th: 120 mrad, the line says 420
    thr = 0.150
    tr = fit_trend(days, y, np.full(days.size, 1e-4), thr)
    assert not tr.inlier[-1] and tr.model == "linear"
    assert tr.t_now == pytest.approx(5.0)
    assert not tr.forecast.crossed
    assert float(tr.curve(np.array([tr.t_now]))[0][0]) < thr
    # negative control: the old rule, "now" at the latest recording even though it left the fit
    assert _forecast(tr, float(days[-1]), 5.0, thr).crossed


def _gap_fleet(small_fleet: Path, dst: Path, late: str, thr: float = 0.1493) -> tuple[Path, float]:
    """M02/Y of the small fleet (linear, 10.8 mrad/day): its first 6 recordings as recorded, the
    7th renamed to the date ``late`` (YYYYmmdd): (fleet file, the 7th's true δ [rad])."""
    truth = json.loads((small_fleet / "truth.json").read_text())["axes"]["M02/Y"]["recordings"]
    (dst / "rec").mkdir(parents=True)
    (dst / "drives").mkdir()
    shutil.copy(small_fleet / "drives" / "M02-Y.toml", dst / "drives")
    for r in truth[:6]:
        shutil.copy(small_fleet / r["file"], dst / "rec")
    last = small_fleet / truth[6]["file"]
    shutil.copy(last, dst / "rec" / f"M02-Y_{late}T060500.parquet")
    f = dst / "fleet.toml"
    f.write_text(FLEET.format(thr=thr))
    return f, truth[6]["delta"]


@pytest.mark.parametrize("late", ["20260211", "20370211"])
def test_a_late_or_misdated_recording_raises_no_threshold_alarm(small_fleet, tmp_path, late):
    """The tester's scenario on the small fleet's M02/Y: a month late (2026-02-11) the old code
    said "δ now" ≈ 400 mrad, crossed, threshold alarm; dated 2037 ≈ 42 rad. No estimate is
    above the 149.3 mrad threshold (the 7th: 126 mrad). Now "δ now" is at most the largest
    estimate, no threshold alarm, and a line names the late recording (a month late: far below
    the trend; 2037: dated after the clock, left out of the trend)."""
    f, _ = _gap_fleet(small_fleet, tmp_path / "f", late)
    st = Store(tmp_path / "w.sqlite")
    rep = ingest(load_fleet(f), st, workers=1)
    (s,) = fleet_summary(st, load_fleet(f))
    top = max(r["delta"] for r in s["rows"])
    assert top < 0.1493
    assert s["current_rad"] <= top + 1e-3, s["current_rad"]
    assert not s["crossed"]
    assert [a for a in s["alarms"] if a.kind == "threshold"] == []
    assert [a for a in st.alarms(active_only=True) if a["kind"] == "threshold"] == []  # stored at ingest
    assert len(s["notes"]) == 1
    if late.startswith("2037"):
        assert "dated more than 1 day after now" in s["notes"][0] and "2037-02-11" in s["notes"][0]
        assert s["future"] == 1 and s["used"] == 6 and s["recordings"] == 7
        assert any("2037-02-11" in w and "after the time of this ingest" in w for w in rep.warnings)
    else:
        assert "lies far below the trend" in s["notes"][0]
        assert s["judged_at"] < datetime(2026, 1, 11)


def test_a_recording_dated_after_the_clock_is_named_by_status(small_fleet, tmp_path, monkeypatch, capsys):
    """`track status` prints the note line; a date within the tolerance is no future date
    (the axis judged as before: negative control of the rule, not of the gap)."""
    f, _ = _gap_fleet(small_fleet, tmp_path / "f", "20370211")
    db = tmp_path / "w.sqlite"
    ingest(load_fleet(f), Store(db), workers=1)
    monkeypatch.setenv("COLUMNS", "400")
    capsys.readouterr()  # only the command's output
    code, stdout, stderr = run_in_process(["track", "status", "--fleet", str(f), "--db", str(db)], capsys)
    assert code == 0, stderr
    assert "note M02/Y: 1 recording dated more than 1 day after now" in stdout
    assert "alarm threshold" not in stdout
    # the tolerance: the same store judged as of 2037-02-10 (less than a day before): in the trend
    st = Store(db)
    (s,) = fleet_summary(
        st,
        load_fleet(f),
        now=datetime(2037, 2, 11) - __import__("datetime").timedelta(days=FUTURE_TOLERANCE_DAYS / 2),
    )
    assert s["future"] == 0 and s["used"] == 7
