"""Fleet report: self-contained HTML, one non-blank trend figure per axis, clean in headless Chromium."""

from __future__ import annotations

import subprocess
import sys
from datetime import datetime

import pytest

from report.test_report import _assert_self_contained, _chromium, _images, _non_blank, _shoot


@pytest.fixture(scope="module")
def report_html(serial_store, tmp_path_factory):
    st, _ = serial_store
    st.add_measurement(
        "M01/Y", datetime(2026, 1, 8, 12), value=0.05, std=0.002, unit="rad", source="iso230-2"
    )
    out = tmp_path_factory.mktemp("rep") / "fleet.html"
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "drivelash.cli",
            "track",
            "report",
            "-o",
            str(out),
            "--db",
            str(st.url.database),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr
    return out


def test_report_is_self_contained_with_one_figure_per_axis(report_html, serial_store):
    st, _ = serial_store
    html = report_html.read_text()
    _assert_self_contained(html)
    assert html.startswith("<!DOCTYPE html>")
    for a in st.axes():
        assert f'id="fig-axis-{a["name"].replace("/", "-")}"' in html
    imgs = _images(html)
    assert len(imgs) >= len(st.axes())
    for img in imgs:
        assert img.width > 300 and img.height > 150 and _non_blank(img) > 0.01
    assert "Fleet overview" in html and "Alarms" in html and "iso230-2" in html


@pytest.mark.browser
def test_fleet_report_in_headless_chromium(report_html, tmp_path):
    exe = _chromium()
    if exe is None:
        pytest.skip("chromium not installed (make test installs it when run as root)")
    log = _shoot(exe, report_html, tmp_path / "fleet.png", tmp_path)
    assert "CONSOLE" not in log, log[-2000:]
    from PIL import Image

    img = Image.open(tmp_path / "fleet.png").convert("RGB")
    assert _non_blank(img) > 0.05


def test_measurements_are_shown_in_readable_units():
    """Laser checks (stored in m) read in µm, angles in mrad — not 8.13922e-05 m."""
    from drivelash.report.fleet import _readable

    assert _readable(8.13922e-05, 1.03e-07, "m") == ("81.39", "0.10", "µm")
    assert _readable(0.05, None, "rad") == ("50.00", "–", "mrad")
    assert _readable(0.012, 0.001, "mm") == ("12.00", "1.00", "µm")


def test_report_names_the_store_by_its_label_when_given(serial_store, tmp_path):
    """The demo builds its store in a staging directory that is renamed afterwards: the report
    and the status title then name the store by a label, never by the vanished staging URL."""
    from drivelash.commands.track import run_report

    st, _ = serial_store
    db = str(st.url.database)
    label = "fleet/wear.sqlite (SQLite, in this output directory)"
    labelled = run_report(db, tmp_path / "a.html", quiet=True, label=label).read_text()
    assert label in labelled and db not in labelled
    plain = run_report(db, tmp_path / "b.html", quiet=True).read_text()  # negative control
    assert db in plain and label not in plain


def test_report_says_at_which_rate_delta_was_estimated(report_html):
    """The small fleet's 8 kHz recordings were estimated at the 1 kHz default: the overview says
    so (a reader comparing with `drivelash estimate` on one file needs to know)."""
    html = report_html.read_text()
    assert "δ was estimated at 1000 Hz (every 8th sample of 8000 Hz recordings)" in html


def test_rate_sentence_full_mixed_and_old_rows():
    from drivelash.report.fleet import rate_sentence

    def rows(*pairs):
        return [{"rows": [{"status": "ok", "sample_rate_hz": f, "estimate_rate_hz": e} for f, e in pairs]}]

    assert "on every sample (8000 Hz)" in rate_sentence(rows((8000.0, 8000.0)))
    mixed = rate_sentence(rows((8000.0, 1000.0), (8000.0, 1000.0), (4000.0, 4000.0), (8000.0, None)))
    assert "at 1000 Hz (every 8th sample of 8000 Hz recordings): 2 recordings" in mixed
    assert "on every sample (4000 Hz): 1 recording;" in mixed and "not recorded" in mixed
    assert "every 2nd sample of 2000 Hz" in rate_sentence(rows((2000.0, 1000.0)))
    assert "every 3rd sample" in rate_sentence(rows((3000.0, 1000.0)))
    assert "every 12th sample" in rate_sentence(rows((12000.0, 1000.0)))
    assert rate_sentence([{"rows": [{"status": "failed"}]}]) == ""


def test_one_alarm_is_singular_and_text_columns_are_left_aligned(serial_store):
    """The overview said "1 active alarms" and the alarm messages (and every other text column:
    axis names, kinds, models, dates) were right-aligned like the numbers; now "1 active alarm",
    "1 axis", text cells carry class "t" (left-aligned) and numbers stay right-aligned."""
    import re

    from drivelash.report.fleet import render_fleet_report
    from drivelash.wear.alarms import fleet_summary

    st, _ = serial_store
    s = next(s for s in fleet_summary(st) if s["alarms"])
    s["alarms"] = s["alarms"][:1]
    html = render_fleet_report([s], {}, title="t", store="wear.sqlite")
    assert re.search(r"1 axis, \d+ recordings in wear\.sqlite; 1 active alarm\. ", html), html[:3000]
    assert "alarms." not in html.split("Only recordings")[0]
    tables = re.findall(r"<table>.*?</table>", html, re.S)
    alarm_table = next(t for t in tables if "<th" in t and ">message</th>" in t)
    cells = re.findall(r"<td( class=\"t\")?>(.*?)</td>", alarm_table)
    assert cells and all(cls for cls, _ in cells), cells  # axis, kind, date, message: text
    assert s["alarms"][0].message.split(":")[0] in alarm_table
    overview = tables[0]
    head = re.findall(r"<th( class=\"t\")?>(.*?)</th>", overview)
    row = re.findall(r"<td( class=\"t\")?>(.*?)</td>", overview)
    aligned = {h: bool(c) for (c, h) in head}
    assert aligned["alarms"] and aligned["model"] and aligned["axis"]
    assert not aligned["failed"] and not aligned["used/recordings"] and not aligned["unexcited"]
    assert bool(row[-1][0]) and not row[-2][0]  # the alarm kinds are text, the failed count a number
    # CSS: the class is what left-aligns
    assert "td.t,th.t{text-align:left}" in html


def test_counted_nouns_of_the_wear_outputs():
    """ "1 … s" slips of the wear outputs (report overview, ingest summary, forecast line,
    alarm messages) go through one helper."""
    from drivelash.wear.words import count

    assert count(1, "active alarm") == "1 active alarm"
    assert count(0, "active alarm") == "0 active alarms"
    assert count(1, "axis", "axes") == "1 axis" and count(2, "axis", "axes") == "2 axes"


def test_a_short_crossing_interval_is_printed_to_the_minute():
    """A 90 % crossing interval minutes wide read "2026-01-13 … 2026-01-13" in the overview (status
    and report), which hides its width; under 2 days it is printed to the minute, longer ones as
    dates (negative control). In HTML a date never breaks at its hyphens (it wrapped as
    "2026-01-" / "13" in the interval column)."""
    from drivelash.report.fleet import _interval
    from drivelash.report.html import _fmt

    def s(early, late, never=False):
        return {"crossing_early": early, "crossing_late": late, "crossing_late_never": never}

    t = datetime(2026, 1, 13, 9, 19)
    assert _interval(s(t, datetime(2026, 1, 13, 9, 24))) == "2026-01-13 09:19 … 09:24"
    assert _interval(s(t, datetime(2026, 1, 14, 20, 5))) == "2026-01-13 09:19 … 2026-01-14 20:05"
    assert _interval(s(t, datetime(2026, 1, 23, 9, 19))) == "2026-01-13 … 2026-01-23"  # 10 days
    assert _interval(s(t, None, never=True)) == "2026-01-13 … never"
    assert _interval(s(None, None)) == "–"
    cell = _fmt("2026-01-13 09:19 … 2026-01-14 20:05")
    assert cell == '<span class="nw">2026-01-13 09:19</span> … <span class="nw">2026-01-14 20:05</span>'


def test_crossing_chart_keeps_the_first_and_last_axis_off_the_frame():
    """The fleet report's crossing chart put the first and last axis's marker on the top and
    bottom frame (matplotlib's 5 % margin: 0.1 row on three rows, a few pixels): half a row of
    margin each side now, soonest on top."""
    from matplotlib.figure import Figure as MplFigure

    from drivelash.report.fleet import _crossing_chart

    def summ(name, day):
        t = datetime(2026, 1, day, 12)
        return {"axis": name, "crossing": t, "crossed": False, "alarms": [], "crossing_early": t,
                "crossing_late": t, "crossing_late_never": False}  # fmt: skip

    spec = _crossing_chart([summ("M01/X", 15), summ("M02/Y", 22), summ("M02/X", 24)])
    fig = MplFigure()
    spec.draw(fig)
    ax = fig.axes[0]
    bottom, top = ax.get_ylim()
    assert (bottom, top) == (2.5, -0.5)  # rows 0, 1, 2 with half a row each side; row 0 on top
    assert [t.get_text() for t in ax.get_yticklabels()] == ["M01/X", "M02/Y", "M02/X"]


def test_forecast_names_a_stale_forecast_as_status_and_report_do(serial_store, capsys):
    """`track forecast M02/Y` (data ending 2026-01-16, crossing 2026-01-22, read in November)
    printed the crossing and "6.5 days after the last recording" with no word that it has passed,
    while `track status` and the report name the forecast stale. It now prints the same note and
    the JSON carries it ("stale": the message, null when not stale)."""
    from drivelash.commands.track import run_forecast
    from drivelash.wear.alarms import fleet_summary, stale_notes

    st, _ = serial_store
    stale = dict(stale_notes(fleet_summary(st)))
    assert stale, "the small fleet's forecasts lie in the past"
    name = next(iter(stale))
    doc = run_forecast(name, str(st.url))
    out = " ".join(capsys.readouterr().out.split())
    assert doc["stale"] == stale[name]
    assert f"stale: {' '.join(stale[name].split())}" in out
    fresh = next(s["axis"] for s in fleet_summary(st) if s["axis"] not in stale)
    assert run_forecast(fresh, str(st.url), quiet=True)["stale"] is None
