"""Session 31: the ingest summary and the fleet views of axes with few recordings (session 30's
tester B, B-08 and B-10)."""

from __future__ import annotations

import json
import shutil
from datetime import UTC, datetime

from drivelash.report.fleet import NOW_LEGEND
from drivelash.wear import Store, ingest, load_fleet
from drivelash.wear.alarms import stale_notes

from .conftest import ingest_here
from .test_ingest_retry import tiny_with_corrupt
from .test_redate_duplicates import FILENAME_TIME, _tiny


def test_cli_summary_does_not_count_failed_files_as_estimated(small_fleet, tmp_path, capsys):
    """B-10: '5 new recordings estimated (…, 2 failed)' called two unreadable files estimated."""
    f = tiny_with_corrupt(small_fleet, tmp_path)
    r = ingest_here(f, tmp_path / "w.sqlite", capsys)
    out = " ".join(r.stdout.split())
    assert "5 new recordings: 3 estimated, 2 failed (" in out, out
    assert "new recordings estimated" not in out
    # negative control: the retry run reads no new file; its wording is the plain one
    r = ingest_here(f, tmp_path / "w.sqlite", capsys)
    out = " ".join(r.stdout.split())
    assert "0 new recordings estimated" in out and "2 retried, 2 still failing" in out, out


def _status_forecast(f, db, cli250):
    st = cli250(["track", "status", "--fleet", str(f), "--db", str(db)])
    fc = cli250(["track", "forecast", "M01/X", "--fleet", str(f), "--db", str(db)])
    return " ".join(st.stdout.split()), " ".join(fc.stdout.split())


def test_too_few_estimates_show_the_latest_and_say_why_the_alarm(small_fleet, tmp_path, cli250):
    """B-08: an axis with 3 accurate estimates showed 'δ now –', 'fitted now – … 3 in the fit …
    model: none', and its threshold alarm blamed 'a jump or a bad recording'."""
    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    db = tmp_path / "w.sqlite"
    ingest(load_fleet(f), Store(db), workers=1)
    rows = sorted(Store(db, create=False).estimates("M01/X"), key=lambda r: r["start_time"])
    latest = rows[-1]["delta"]
    f.write_text(f.read_text().replace("threshold = 0.2", "threshold = 0.001"))  # far below δ
    status, forecast = _status_forecast(f, db, cli250)
    assert f"M01/X ({1e3 * latest:.2f}) 1.00 –" in status, status
    assert NOW_LEGEND in status
    assert "too few recordings for a trend yet, 3 usable estimates of 5" in status
    assert "a jump or a bad recording" not in status
    assert "3 of 3 recordings usable, none fitted: 5 needed for a trend" in forecast, forecast
    assert "in the fit" not in forecast
    assert f"latest estimate {1e3 * latest:.3f} ± " in forecast and "no trend yet" in forecast
    # negative control: with 5 usable recordings the trend is fitted; no parentheses, no legend
    truth = json.loads((small_fleet / "truth.json").read_text())["axes"]["M01/X"]["recordings"]
    more = [r["file"] for r in truth if r["excited"] and r["corrupt"] is None][3:5]
    for rel in more:
        shutil.copy(small_fleet / rel, tmp_path / "f" / "rec")
    ingest(load_fleet(f), Store(db), workers=1)
    status, forecast = _status_forecast(f, db, cli250)
    assert NOW_LEGEND not in status and "(" + f"{1e3 * latest:.2f}" not in status, status
    assert "5 of 5 recordings usable, 5 in the fit" in forecast and "latest estimate" not in forecast


def _summary(rows):
    return {"axis": "M01/X", "crossed": False, "crossing": datetime(2026, 2, 1), "judged_at": None,
            "last_recording": datetime(2026, 1, 10), "rows": rows}  # fmt: skip


def _failed(written: datetime):
    return {"start_time": None, "status": "failed", "excitation_ok": None, "converged": None,
            "delta": None, "delta_std": None,
            "mtime_ns": int(written.replace(tzinfo=UTC).timestamp() * 1e9)}  # fmt: skip


def test_stale_note_counts_a_later_failed_file_that_could_not_be_dated():
    """B-10: the stale note said 'no recording since' (or left the failed one out of its count)
    when a later file failed before its time could be read; it is dated by its file time."""
    now = datetime(2026, 11, 30)
    ((name, msg),) = stale_notes([_summary([_failed(datetime(2026, 3, 1))])], now)
    assert name == "M01/X" and "1 later recording: 1 failed" in msg and "check the later recordings" in msg, (
        msg
    )
    # negative control: a failed file written before the last usable recording is not later
    ((name, msg),) = stale_notes([_summary([_failed(datetime(2026, 1, 5))])], now)
    assert "with no recording since the last one" in msg, msg
