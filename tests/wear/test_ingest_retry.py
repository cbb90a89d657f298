"""A recording stored as ``failed`` is retried by every ingest (exploration: a wrong time
``format`` on the first ingest stored every recording as failed; after the fix of the format
the ingest said '0 new … 80 already in the store' forever, and a ``touch``-ed file's new
estimate was dropped as a duplicate of the failed row — the only way out was deleting the store).
A time format that dates none of an axis's files is refused before anything is written."""

from __future__ import annotations

import os
import shutil
from dataclasses import replace

from drivelash.wear import Store, ingest, load_fleet
from drivelash.wear.estimate import estimate_recording
from drivelash.wear.fleet import TimeSpec

from .conftest import _add_corrupt, ingest_here
from .test_redate_duplicates import FILENAME_TIME, _tiny

BAD_FORMAT = TimeSpec.model_validate(
    {"from": "filename", "pattern": r"_(\d{8}T\d{6})", "format": "%Y-%m-%dT%H%M%S"}
)


def _wrong_format(task):
    """The worker of an ingest whose fleet.toml had the wrong time format (every file fails)."""
    return estimate_recording(replace(task, time=BAD_FORMAT))


def _statuses(st: Store) -> list[str]:
    return [r["status"] for r in st.estimates("M01/X")]


def test_failed_rows_are_retried_after_the_config_is_fixed(small_fleet, tmp_path):
    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    st = Store(tmp_path / "w.sqlite")
    rep = ingest(load_fleet(f), st, workers=1, compute=_wrong_format)
    assert rep.failed == 3 and _statuses(st) == ["failed"] * 3
    assert all("does not match format" in r["reason"] for r in st.estimates())
    rep = ingest(load_fleet(f), st, workers=1)  # the fixed configuration
    assert rep.planned == 3 and rep.skipped == 0 and rep.retried == 3 and rep.still_failing == 0
    assert rep.failed == 0 and rep.stored == 3
    assert _statuses(st) == ["ok"] * 3 and st.counts()["estimate"] == st.counts()["recording"] == 3
    assert all(r["start_time"] is not None and r["start_time"].month == 1 for r in st.estimates())
    # negative control: an ok estimate is not estimated again
    rep = ingest(load_fleet(f), st, workers=1)
    assert rep.planned == 0 and rep.skipped == 3 and rep.retried == 0 and st.counts()["estimate"] == 3


def test_a_touched_file_replaces_its_failed_row(small_fleet, tmp_path):
    """New file facts (mtime) of the same content: the new estimate replaces the failed one
    (before: dropped as a duplicate of it)."""
    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(f), st, workers=1, compute=_wrong_format)
    for p in (tmp_path / "f" / "rec").iterdir():
        os.utime(p)
    rep = ingest(load_fleet(f), st, workers=1)
    assert rep.retried == 3 and _statuses(st) == ["ok"] * 3 and st.counts()["estimate"] == 3


def tiny_with_corrupt(small_fleet, tmp_path):
    """The tiny fleet (3 good recordings of M01/X) plus 2 unreadable files in its glob."""
    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    d = tmp_path / "f" / "recordings" / "M01" / "X"  # _add_corrupt writes there: then into rec/
    d.mkdir(parents=True)
    shutil.copy(next((tmp_path / "f" / "rec").iterdir()), d)
    for p in _add_corrupt(tmp_path / "f"):
        p.rename(tmp_path / "f" / "rec" / p.name)
    return f


def test_still_failing_recordings_are_counted_and_stay_once(small_fleet, tmp_path):
    f = tiny_with_corrupt(small_fleet, tmp_path)
    st = Store(tmp_path / "w.sqlite")
    rep = ingest(load_fleet(f), st, workers=1)
    assert rep.failed == 2 and rep.retried == 0
    rep = ingest(load_fleet(f), st, workers=1)
    assert rep.planned == 2 and rep.skipped == 3 and rep.retried == 2 and rep.still_failing == 2
    assert sorted(_statuses(st)) == ["failed"] * 2 + ["ok"] * 3 and st.counts()["estimate"] == 5


def test_cli_time_format_that_dates_no_file_is_a_config_error(small_fleet, tmp_path, capsys):
    bad = FILENAME_TIME.replace("%Y%m%dT%H%M%S", "%Y-%m-%dT%H%M%S")
    f = _tiny(small_fleet, tmp_path / "f", bad)
    db = tmp_path / "w.sqlite"
    r = ingest_here(f, db, capsys)
    assert r.returncode == 2, r.stderr
    err = r.stderr.strip()
    assert "\n" not in err and str(f) in err and "key 'time'" in err and "M01/X" in err
    assert "does not match format '%Y-%m-%dT%H%M%S'" in err and "nothing was written" in err
    assert not db.exists()
    # negative control: the right format ingests (exit 0); summary without a retry count
    f.write_text(f.read_text().replace(bad, FILENAME_TIME))
    r = ingest_here(f, db, capsys)
    assert r.returncode == 0, r.stderr
    assert "retried" not in r.stdout and len(Store(db, create=False).estimates()) == 3


def test_cli_summary_counts_retried(small_fleet, tmp_path, capsys):
    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    db = tmp_path / "w.sqlite"
    ingest(load_fleet(f), Store(db), workers=1, compute=_wrong_format)
    r = ingest_here(f, db, capsys)
    assert r.returncode == 0, r.stderr
    out = " ".join(r.stdout.split())
    assert "0 new recordings estimated" in out and "3 retried, 0 still failing" in out
