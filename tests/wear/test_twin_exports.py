"""The same recording exported as CSV and as Parquet (s19 tester, finding F12): the content
hashes differ, so both were estimated and counted in the trend without a word (the days with
both weighted twice, the intervals narrower than the data justify). Two recordings of an axis
with the same start time, duration and sample count but different content are now named in
one line — at ingest and in status/forecast/report (``alarms.twin_groups``)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from drivelash.wear import Store, ingest, load_fleet
from drivelash.wear.alarms import fleet_summary

FLEET = """[fleet]
name = "twins"
time = { from = "filename", pattern = '_(\\d{8}T\\d{6})\\.', format = "%Y%m%dT%H%M%S" }
[[axis]]
id = "M01/Y"
drive = "drives/M01-Y.toml"
recordings = "rec/*"
threshold = 0.2
"""


def _fleet(small_fleet: Path, dst: Path, twin: bool) -> tuple[Path, list[Path]]:
    """M01/Y's first 3 recordings; with ``twin`` the first also as CSV."""
    (dst / "rec").mkdir(parents=True)
    shutil.copytree(small_fleet / "drives", dst / "drives")
    files = sorted((small_fleet / "recordings" / "M01" / "Y").glob("*.parquet"))[:3]
    for p in files:
        shutil.copy(p, dst / "rec")
    if twin:
        pacsv.write_csv(pq.read_table(files[0]), dst / "rec" / (files[0].stem + ".csv"))
    (dst / "fleet.toml").write_text(FLEET)
    return dst / "fleet.toml", files


def test_a_recording_exported_twice_is_named(small_fleet, tmp_path):
    """Old code: 4 recordings estimated, no warning, 4/4 used. Now one ingest warning and one
    status note name both files; the trend is unchanged (both still count: a warning only)."""
    f, files = _fleet(small_fleet, tmp_path / "f", twin=True)
    st = Store(tmp_path / "w.sqlite")
    rep = ingest(load_fleet(f), st, workers=1)
    (w,) = [w for w in rep.warnings if "exported twice" in w]
    assert w.startswith("M01/Y: 2 recordings start at 2026-01-05 ")
    assert files[0].stem + ".csv" in w and files[0].name in w
    (s,) = fleet_summary(st, load_fleet(f))
    assert s["used"] == 4
    assert [n for n in s["notes"] if "exported twice" in n] == [w]


def test_distinct_recordings_are_not_twins(small_fleet, tmp_path):
    """Negative control: the same files without the CSV copy: no warning, no note."""
    f, _ = _fleet(small_fleet, tmp_path / "f", twin=False)
    st = Store(tmp_path / "w.sqlite")
    rep = ingest(load_fleet(f), st, workers=1)
    assert not [w for w in rep.warnings if "exported twice" in w]
    (s,) = fleet_summary(st, load_fleet(f))
    assert s["notes"] == [] and s["used"] == 3
