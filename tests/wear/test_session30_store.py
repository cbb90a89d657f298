"""Session 30, tester B: the wear store's identity of a recording.

* B-01: the axes' globs pointed at a copy of the recordings while the originals still existed
  (or a fleet directory copied together with its store): every axis showed 0/0 recordings and
  every active alarm was cleared — a recording whose content the glob matches under any path
  stays with its axis; one whose files are truly no longer matched is still left out.
"""

from __future__ import annotations

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
