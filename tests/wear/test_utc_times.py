"""The store keeps UTC; status, forecast (text and JSON) and the HTML report say so."""

from __future__ import annotations

import json
from datetime import UTC, datetime

TRACK = ["track"]


def _ok(r):
    assert r.returncode == 0, r.stderr
    return r


def _dated_axis(st) -> str:
    """An axis of the store with a forecast crossing (dates in every line of its forecast)."""
    from drivelash.wear.alarms import fleet_summary

    return next(s["axis"] for s in fleet_summary(st) if s["crossing"] is not None)


def test_status_and_forecast_text_say_utc(serial_store, cli250):
    st, _ = serial_store
    db = str(st.url.database)
    axis = _dated_axis(st)
    out = " ".join(_ok(cli250([*TRACK, "status", "--db", db])).stdout.split())
    assert "(times UTC)" in out and "expected crossing (UTC)" in out and "90 % interval (UTC)" in out
    text = _ok(cli250([*TRACK, "forecast", axis, "--db", db])).stdout
    dated = [x for x in text.splitlines() if "forecast crossing" in x or "threshold crossed" in x]
    assert dated and all(" UTC" in x for x in dated), text


def test_forecast_json_times_are_explicit_utc(serial_store, tmp_path, cli250):
    st, _ = serial_store
    db = str(st.url.database)
    axis = _dated_axis(st)
    out = tmp_path / "f.json"
    _ok(cli250([*TRACK, "forecast", axis, "--db", db, "--json", str(out)]))
    doc = json.loads(out.read_text())
    assert doc["time_zone"] == "UTC"
    stamps = [doc["last_recording"], doc["t0"], doc["crossing"], *doc["crossing_90"]]
    stamps += [e["time"] for e in doc["estimates"]] + [c["time"] for c in doc["change_points"]]
    stamps = [t for t in stamps if t is not None]
    assert doc["crossing"] is not None and len(stamps) > 5 and all(t.endswith("+00:00") for t in stamps), (
        stamps
    )
    # the same instants the store holds (naive UTC)
    stored = {r["path"]: r["start_time"] for r in st.estimates(axis)}
    for e in doc["estimates"]:
        if e["time"] is not None:
            assert datetime.fromisoformat(e["time"]) == stored[e["path"]].replace(tzinfo=UTC)


def test_report_says_utc_in_the_overview(serial_store, tmp_path, cli250):
    from drivelash.report.fleet import TIMES_UTC

    st, _ = serial_store
    html = tmp_path / "r.html"
    _ok(cli250([*TRACK, "report", "--db", str(st.url.database), "-o", str(html)]))
    text = html.read_text()
    assert TIMES_UTC in text and "All dates and times are UTC" in text
    assert "expected crossing (UTC)" in text and "90 % interval (UTC)" in text
