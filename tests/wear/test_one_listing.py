"""One ingest lists each axis's recordings once (session 19's left-alone item): the file checks,
the re-dating, the plan, the note on recordings the glob no longer matches and the alarm refresh
globbed each axis again and stat'ed every file again — five globs per axis and about six stats per
recording, worth one pass on a network share, and each step could see another set of files. Now
:meth:`~drivelash.wear.fleet.Fleet.listed` takes one listing (one glob per axis, one stat per
file) that every step uses. The negative control takes the listing away again and must see the
extra globs."""

from __future__ import annotations

import glob as globmod
import os
import shutil
from pathlib import Path

import pytest

from drivelash.wear import Store, ingest, load_fleet
from drivelash.wear.fleet import Fleet

from .conftest import copy_fleet


def _no_compute(task):  # pragma: no cover - must not be called: everything is stored
    raise AssertionError(f"{task.path} estimated again")


def _counting(monkeypatch, recordings: set[str]) -> dict[str, int]:
    """Count glob.glob calls and os.stat calls on the recordings from here on."""
    n = {"glob": 0, "stat": 0}
    real_glob, real_stat = globmod.glob, os.stat

    def glob_(*a, **k):
        n["glob"] += 1
        return real_glob(*a, **k)

    def stat_(p, *a, **k):
        if os.fspath(p) in recordings:
            n["stat"] += 1
        return real_stat(p, *a, **k)

    monkeypatch.setattr(globmod, "glob", glob_)
    monkeypatch.setattr(os, "stat", stat_)
    return n


@pytest.fixture
def stored(small_fleet, tmp_path):
    """A private copy of the small fleet, ingested into its own store; the files of the failed
    recordings removed (every ingest tries those again)."""
    d = copy_fleet(small_fleet, tmp_path / "fleet")
    fleet = load_fleet(d / "fleet.toml")
    st = Store(tmp_path / "wear.sqlite")
    ingest(fleet, st, workers=1)
    # the recordings that failed are tried again by every ingest: gone here (history only)
    for a in st.axes():
        for r in st.estimates(a["name"]):
            if r["status"] == "failed":
                Path(r["path"]).unlink(missing_ok=True)
    files = {str(p) for a in fleet.axes for p in a.files()}
    return fleet, st, files


def test_an_ingest_globs_each_axis_once_and_stats_each_file_once(stored, monkeypatch):
    fleet, st, files = stored
    n = _counting(monkeypatch, files)
    rep = ingest(fleet, st, workers=1, compute=_no_compute)
    assert rep.planned == 0 and rep.skipped == len(files)
    assert n["glob"] == len(fleet.axes), n
    assert n["stat"] == len(files), n


def test_negative_control_without_the_listing_every_step_globs_again(stored, monkeypatch):
    fleet, st, files = stored
    monkeypatch.setattr(Fleet, "listed", lambda self: self)
    n = _counting(monkeypatch, files)
    rep = ingest(fleet, st, workers=1, compute=_no_compute)
    assert rep.planned == 0
    assert n["glob"] >= 4 * len(fleet.axes), n
    assert n["stat"] >= 4 * len(files), n


def test_every_step_sees_the_one_listing(stored):
    """A recording that appears after the listing was taken (written by the machine while the
    ingest runs) is not half-seen by the later steps: the listed fleet's axes give exactly the
    files of the first glob, also when a new file is there by the time they ask."""
    fleet, _, files = stored
    listed = fleet.listed()
    a = listed.axes[0]
    before = a.files()
    extra = Path(before[0]).with_name("late_20990101T000000.parquet")
    shutil.copy(before[0], extra)
    assert a.files() == before  # the listing
    assert extra in fleet.axes[0].files()  # a fresh glob sees it
    assert [f.path for f in a.entries()] == before
    assert all(f.size == os.stat(f.path).st_size for f in a.entries())
