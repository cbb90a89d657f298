"""The ISO 230-2 HTML report: self-contained, the standard's chart drawn with both directions,
and clean in headless Chromium."""

from __future__ import annotations

import base64
import io
import re
import shutil
import subprocess

import numpy as np
import pytest
from PIL import Image

from drivelash.iso230 import evaluate
from drivelash.iso230.compare import Deadzone, Transmission, compare
from drivelash.iso230.dwell import detect_dwells, estimate_drift
from drivelash.iso230.inputs import Measurement
from drivelash.iso230.synthetic import SyntheticAxis, synthetic_recording
from drivelash.report.iso230 import render_iso230_report

_IMG = re.compile(
    r'<figure id="fig-([\w-]+)"><img class="figure" alt="[^"]*" src="data:image/png;base64,([A-Za-z0-9+/=]+)"'
)
UP = np.array([0x1F, 0x5F, 0xA8])
DOWN = np.array([0xC2, 0x46, 0x1B])


def _colour_pixels(img: Image.Image, rgb: np.ndarray) -> int:
    a = np.asarray(img.convert("RGB"), dtype=np.int16)
    return int((np.abs(a - rgb) < 25).all(axis=2).sum())


#: The file as a command sees it while its outputs are staged (``drivelash demo`` evaluates its own
#: recording inside the staging directory): the report must name the file, not that directory.
STAGED = "/tmp/.demo-output.drivelash-1-abc.part/synthetic.csv"


@pytest.fixture(scope="module")
def page() -> str:
    cols, _ = synthetic_recording(SyntheticAxis(), m=9, n=3, seed=11, dwell=0.8)
    d = detect_dwells(cols["t"], cols["P_cmd"], cols["P_actual"], cols["P_axis"])
    dr = estimate_drift(d)
    meas = Measurement("timeseries", "m", d.approaches, d.approaches_axis, d, cols, STAGED, d.warnings, dr)
    res = evaluate(d.approaches)
    cmp_ = compare(res, Deadzone(12e-6 / 0.01, 0.3e-6 / 0.01, "est.json"), Transmission(pinion_radius=0.01),
                   drift=dr, corrected=evaluate(dr.corrected))  # fmt: skip
    return render_iso230_report(res, meas, cmp_, axis_result=evaluate(d.approaches_axis))


def test_self_contained_with_every_figure(page):
    low = page.lower()
    assert "<script" not in low and "http://" not in low and "https://" not in low
    figs = dict(_IMG.findall(page))
    assert set(figs) == {"reversal", "iso-chart", "recording", "dwell"}
    chart = Image.open(io.BytesIO(base64.b64decode(figs["iso-chart"])))
    # the standard's chart shows both directions (x̄↑ blue, x̄↓ orange, with their bands)
    assert _colour_pixels(chart, UP) > 1500 and _colour_pixels(chart, DOWN) > 1500
    assert "synthetic.csv" in page and ".part" not in page  # the file by name, no staging path
    for key in ("A (bidirectional accuracy)", "B̄ (mean reversal value)", "Reversal value beside", "Drift of"):
        assert key in page


def test_every_column_of_the_axis_values_table_has_a_header(page):
    """The axis-values table pairs two quantity/value columns; the second "quantity" header was
    blank (session 16, read in the rendered demo report)."""
    m = re.search(r"<caption>ISO 230-2:2014 axis values \[µm\]</caption><thead><tr>(.*?)</tr>", page)
    assert m is not None
    heads = re.findall(r"<th[^>]*>(.*?)</th>", m.group(1))
    assert heads == ["quantity", "value", "quantity", "value"]


@pytest.mark.browser
def test_report_in_headless_chromium(page, tmp_path):
    exe = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    if exe is None:
        pytest.skip("chromium not installed (make test installs it when run as root)")
    html_path = tmp_path / "iso.html"
    html_path.write_text(page, encoding="utf-8")
    shot = tmp_path / "iso.png"
    r = subprocess.run(
        [exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         f"--user-data-dir={tmp_path / 'profile'}", "--window-size=1200,3000", f"--screenshot={shot}",
         "--enable-logging=stderr", "--v=0", html_path.as_uri()],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert shot.exists(), r.stderr[-2000:]
    assert [ln for ln in r.stderr.splitlines() if "CONSOLE" in ln] == []
    img = Image.open(shot)
    assert _colour_pixels(img, UP) > 1000 and _colour_pixels(img, DOWN) > 1000


def test_dwell_detail_names_its_y_axis():
    """The one-dwell figure's y axis read only "[µm]": it is the deviation from the target."""
    from matplotlib.figure import Figure as MplFigure

    from drivelash.report.iso230 import _dwell_zoom

    cols, _ = synthetic_recording(SyntheticAxis(), m=5, n=2, seed=3, dwell=0.8)
    d = detect_dwells(cols["t"], cols["P_cmd"], cols["P_actual"], cols["P_axis"])
    meas = Measurement("timeseries", "m", d.approaches, d.approaches_axis, d, cols, STAGED, d.warnings, None)
    fig = MplFigure()
    _dwell_zoom(meas).draw(fig)
    assert fig.axes[0].get_ylabel() == "deviation from P_i [µm]"


def test_per_target_positions_share_one_number_of_decimals(page):
    """The per-target table printed P_i with ``.6g`` — "0", "62.5", "125" in one column (session
    17's report audit, left then as cosmetic); one column now has one number of decimals, the
    fewest that show every target to 1 µm (the dwell-detected targets of this recording are
    irregular: 53.214255 mm is printed 53.214)."""
    m = re.search(r"<h2>Per target</h2>.*?<tbody>(.*?)</tbody>", page, re.S)
    assert m is not None
    first = re.findall(r"<tr><t[dh][^>]*>(.*?)</t[dh]>", m.group(1))
    assert len(first) == 9
    decimals = {len(c.split(".")[1]) if "." in c else 0 for c in first}
    assert len(decimals) == 1, first
    assert decimals == {3} and first[0] == "0.000" and first[1] == "53.214", first


def test_common_and_significant_decimals():
    from drivelash.report.html import common_decimals, significant_decimals

    assert common_decimals([0.0, 62.5, 125.0]) == 1
    assert common_decimals([0.0, 100.0, 200.0]) == 0
    assert common_decimals([0.125, 0.25]) == 3
    assert common_decimals([1 / 3]) == 6  # never more than max_nd
    assert significant_decimals([17.04, -24.2]) == 1  # "17.0 / -24.2"
    assert significant_decimals([0.0512, -0.02]) == 4  # "0.0512 / -0.0200" for a small rotary axis
    assert significant_decimals([1234.0]) == 0
    assert significant_decimals([0.0, float("nan")]) == 2
