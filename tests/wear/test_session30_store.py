"""Session 30, tester B: the wear store's identity of a recording.

* B-01: the axes' globs pointed at a copy of the recordings while the originals still existed
  (or a fleet directory copied together with its store): every axis showed 0/0 recordings and
  every active alarm was cleared — a recording whose content the glob matches under any path
  stays with its axis; one whose files are truly no longer matched is still left out.
* B-02: a controller overwriting one fixed export file name each day (start time in the file's
  metadata): each ingest replaced the previous day's recording, the store kept 1 of 6 — a
  rewrite with another start time is a new recording; a re-export (same start) still replaces.
* B-06: the latest recordings of an axis all failed (a lost load encoder): status showed the δ
  and forecast of 10 days before as current, with no word — a note (an alarm from
  ``not_excited_alarm`` recordings on) says so and as of when the figures are.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path
from typing import Any

from drivelash.wear import Store, ingest, load_fleet
from drivelash.wear.alarms import fleet_summary

FLEET = """[fleet]
name = "copied recordings"
time = {{ from = "filename", pattern = '_(\\d{{8}}T\\d{{6}})\\.', format = "%Y%m%dT%H%M%S" }}
[[axis]]
id = "M02/Y"
drive = "drives/M02-Y.toml"
recordings = "{rec}/M02/Y/*.parquet"
threshold = 0.1013
"""

#: What status shows of an axis (its figures, not where its files are).
KEYS = ("recordings", "used", "unmatched", "current_rad", "model", "crossing")


def _fleet(small_fleet: Path, d: Path, rec: str = "recordings") -> Path:
    """One axis, M02/Y of the small fleet (linear wear 62 → 138 mrad; its threshold 101.3 mrad
    is crossed: a threshold alarm), whose ``recordings`` glob is under ``d / rec``."""
    if not d.exists():
        shutil.copytree(small_fleet / "recordings" / "M02" / "Y", d / "recordings" / "M02" / "Y")
        shutil.copytree(small_fleet / "drives", d / "drives")
    f = d / "fleet.toml"
    f.write_text(FLEET.format(rec=rec))
    return f


def _figures(st: Store, f: Path) -> tuple[dict[str, Any], list[tuple[str, str]]]:
    (s,) = fleet_summary(st, load_fleet(f))
    return {k: s[k] for k in KEYS}, sorted((a.kind, a.key) for a in s["alarms"])


def _active(st: Store) -> list[tuple[str, str]]:
    return sorted((a["kind"], a["key"]) for a in st.alarms(active_only=True))


def test_globs_pointed_at_a_copy_keep_every_recording_and_alarm(small_fleet, tmp_path):
    d = tmp_path / "f"
    f = _fleet(small_fleet, d)
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(f), st, workers=1)
    before, alarms = _figures(st, f)
    assert before["recordings"] >= 8 and before["unmatched"] == 0 and alarms  # a threshold alarm
    stored = _active(st)
    assert stored
    shutil.copytree(d / "recordings", d / "recordings_new")  # the originals stay
    _fleet(small_fleet, d, "recordings_new")
    # before the next ingest: the copies are recognised by their content
    assert _figures(st, f) == (before, alarms)
    rep = ingest(load_fleet(f), st, workers=1)
    assert not [w for w in rep.warnings if "no longer matched" in w], rep.warnings
    assert _figures(st, f) == (before, alarms)  # was 0/0, no alarm
    assert _active(st) == stored  # was: every alarm cleared


def test_a_fleet_directory_copied_with_its_store_shows_the_same_figures(small_fleet, tmp_path):
    d = tmp_path / "f"
    f = _fleet(small_fleet, d, str(d / "recordings"))
    st = Store(d / "w.sqlite")
    ingest(load_fleet(f), st, workers=1)
    before = _figures(st, f)
    st.close()
    shutil.copytree(d, tmp_path / "g")  # the copy's store names the original's files
    g = _fleet(small_fleet, tmp_path / "g", str(tmp_path / "g" / "recordings"))
    assert _figures(Store(tmp_path / "g" / "w.sqlite"), g) == before


def test_recordings_no_longer_matched_are_still_left_out(small_fleet, tmp_path):
    """Negative control: only half of the recordings copied to the new directory; the other
    half's files still exist and nothing the glob matches holds their content — left out."""
    d = tmp_path / "f"
    f = _fleet(small_fleet, d)
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(f), st, workers=1)
    before, _ = _figures(st, f)
    files = sorted((d / "recordings" / "M02" / "Y").glob("*.parquet"))
    (d / "recordings_new" / "M02" / "Y").mkdir(parents=True)
    for p in files[::2]:
        shutil.copy(p, d / "recordings_new" / "M02" / "Y" / p.name)
    _fleet(small_fleet, d, "recordings_new")
    ingest(load_fleet(f), st, workers=1)
    (s,) = fleet_summary(st, load_fleet(f))
    assert s["unmatched"] == len(files[1::2]) and s["recordings"] == before["recordings"] - s["unmatched"]
    assert any("no longer matched" in n for n in s["notes"])


# -- B-02: one export file name overwritten each day ------------------------------------------------

METADATA_FLEET = """[fleet]
name = "fixed export name"
time = { from = "metadata" }
[[axis]]
id = "M01/X"
drive = "drives/M01-X.toml"
recordings = "rec/*.parquet"
threshold = 0.2
"""


def _daily_exports(small_fleet: Path, n: int) -> list[Path]:
    """The first ``n`` good, excited recordings of M01/X (one a day)."""
    truth = json.loads((small_fleet / "truth.json").read_text())["axes"]["M01/X"]["recordings"]
    return [small_fleet / r["file"] for r in truth if r["excited"] and r["corrupt"] is None][:n]


def _fixed_name_fleet(small_fleet: Path, d: Path) -> Path:
    (d / "rec").mkdir(parents=True)
    shutil.copytree(small_fleet / "drives", d / "drives")
    f = d / "fleet.toml"
    f.write_text(METADATA_FLEET)
    return f


def test_a_fixed_export_name_overwritten_each_day_keeps_every_days_recording(small_fleet, tmp_path):
    """Each day's recording (start time in its metadata) copied over one file name and ingested:
    each ingest replaced the previous day's recording; after 5 days the store held 1 (no trend)."""
    f = _fixed_name_fleet(small_fleet, tmp_path / "f")
    st = Store(tmp_path / "w.sqlite")
    target = tmp_path / "f" / "rec" / "X_trace.parquet"
    days = _daily_exports(small_fleet, 5)
    for k, src in enumerate(days):
        shutil.copy(src, target)
        rep = ingest(load_fleet(f), st, workers=1)
        assert rep.replaced == 0  # was 1 each day after the first
        assert rep.rewritten_new == (1 if k else 0)
    rows = st.estimates("M01/X")
    assert len(rows) == 5 and len({r["start_time"] for r in rows}) == 5
    assert {hashlib.sha256(p.read_bytes()).hexdigest() for p in days} == {r["content_hash"] for r in rows}
    (s,) = fleet_summary(st, load_fleet(f))
    assert s["recordings"] == 5 and s["used"] == 5 and s["unmatched"] == 0 and s["model"] is not None
    # nothing new: nothing to do, nothing replaced
    rep = ingest(load_fleet(f), st, workers=1)
    assert rep.planned == 0 and rep.replaced == 0 and rep.rewritten_new == 0


def test_a_re_export_of_the_same_measurement_still_replaces_it(small_fleet, tmp_path):
    """Negative control: the latest day's file written again with other bytes (zstd) but the
    same start time is a re-export: it replaces that recording, the earlier days stay."""
    import pyarrow.parquet as pq

    f = _fixed_name_fleet(small_fleet, tmp_path / "f")
    st = Store(tmp_path / "w.sqlite")
    target = tmp_path / "f" / "rec" / "X_trace.parquet"
    for src in _daily_exports(small_fleet, 2):
        shutil.copy(src, target)
        ingest(load_fleet(f), st, workers=1)
    old = hashlib.sha256(target.read_bytes()).hexdigest()
    pq.write_table(pq.read_table(target), target, compression="zstd")
    assert hashlib.sha256(target.read_bytes()).hexdigest() != old
    rep = ingest(load_fleet(f), st, workers=1)
    assert rep.replaced == 1
    assert rep.rewritten_new == 0
    rows = st.estimates("M01/X")
    assert len(rows) == 2 and old not in {r["content_hash"] for r in rows}
    assert len({r["start_time"] for r in rows}) == 2


# -- B-06: the latest recordings of an axis all fail ---------------------------------------------

FAILING_FLEET = """[fleet]
name = "lost encoder"
time = {{ from = "filename", pattern = '_(\\d{{8}}T\\d{{6}})', format = "%Y%m%dT%H%M%S" }}
not_excited_alarm = {n}
[[axis]]
id = "M01/X"
drive = "drives/M01-X.toml"
recordings = "rec/*.parquet"
threshold = 0.2
"""


def _lost_encoder(src: Path, dst: Path, row: int) -> None:
    """``src`` with the load encoder lost after about 0.5 s (NaN from ``row`` of ``theta_l``:
    each day's file another content)."""
    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq

    t = pq.read_table(src)
    col = t.column("theta_l").to_numpy().copy()
    col[row:] = np.nan
    pq.write_table(t.set_column(t.column_names.index("theta_l"), "theta_l", pa.array(col)), dst)


def _failing_fleet(small_fleet: Path, d: Path, n_alarm: int = 3) -> tuple[Path, Path]:
    """M01/X's first 5 good recordings (a trend), under their own names; (fleet file, last one)."""
    (d / "rec").mkdir(parents=True)
    shutil.copytree(small_fleet / "drives", d / "drives")
    days = _daily_exports(small_fleet, 5)
    for p in days:
        shutil.copy(p, d / "rec" / p.name)
    f = d / "fleet.toml"
    f.write_text(FAILING_FLEET.format(n=n_alarm))
    return f, days[-1]


def _failing(s: dict[str, Any]) -> tuple[list[str], list[str]]:
    return [n for n in s["notes"] if "failed" in n], [a.message for a in s["alarms"] if a.kind == "failed"]


def test_latest_recordings_that_all_fail_are_named_with_the_date_of_the_figures(small_fleet, tmp_path):
    f, last = _failing_fleet(small_fleet, tmp_path / "f")
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(f), st, workers=1)
    (s,) = fleet_summary(st, load_fleet(f))
    assert _failing(s) == ([], [])  # negative control: every recording usable
    judged = s["judged_at"]
    for day in (1, 2):
        _lost_encoder(last, tmp_path / "f" / "rec" / f"M01-X_202604{day:02d}T060000.parquet", 5000 + day)
    rep = ingest(load_fleet(f), st, workers=1)
    assert rep.failed == 2
    (s,) = fleet_summary(st, load_fleet(f))
    (note,), alarms = _failing(s)  # fewer than not_excited_alarm: a note, no alarm
    assert alarms == []
    assert note.startswith("M01/X: the last 2 recordings failed (2026-04-01 UTC … 2026-04-02 UTC; latest: ")
    assert "theta_l" in note and f"as of {judged:%Y-%m-%d} UTC" in note
    _lost_encoder(last, tmp_path / "f" / "rec" / "M01-X_20260403T060000.parquet", 5003)
    ingest(load_fleet(f), st, workers=1)
    (s,) = fleet_summary(st, load_fleet(f))
    notes, (alarm,) = _failing(s)  # the alarm says it; no note repeating it
    assert notes == [] and alarm.startswith("M01/X: the last 3 recordings failed")
    assert [a["kind"] for a in st.alarms(active_only=True) if a["kind"] == "failed"] == ["failed"]
    # a good recording after them ends it (negative control): the alarm is cleared
    good = _daily_exports(small_fleet, 6)[5]  # not yet stored (a copy would be a duplicate)
    shutil.copy(good, tmp_path / "f" / "rec" / "M01-X_20260404T060000.parquet")
    ingest(load_fleet(f), st, workers=1)
    (s,) = fleet_summary(st, load_fleet(f))
    assert _failing(s) == ([], [])
    assert not [a for a in st.alarms(active_only=True) if a["kind"] == "failed"]
