"""A recording already stored is not estimated again because its file moved, was renamed,
touched or copied (exploration: ``mv`` of the fleet directory re-estimated every recording —
hours for a big fleet — and only the commit noticed the content was known). The content hash
of a file whose (path, size, mtime) is unknown is looked up before it becomes a task."""

from __future__ import annotations

import importlib
import os
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from drivelash.wear import Store, ingest, load_fleet
from drivelash.wear.alarms import fleet_summary
from drivelash.wear.estimate import RecordingTask, estimate_recording
from drivelash.wear.store import EstimateRow

from .conftest import copy_fleet, ingest_here
from .test_ingest_retry import _wrong_format
from .test_redate_duplicates import FILENAME_TIME, _tiny, _write, ingested_with_a_copy

#: The file facts of a recording (where it was seen), not its result.
FACTS = ("path", "size_bytes", "mtime_ns", "id", "created_at", "runtime_s")


class _Counting:
    """A ``compute`` that estimates and remembers which files it was given."""

    def __init__(self, fn: Callable[[RecordingTask], EstimateRow] = estimate_recording) -> None:
        self.fn = fn
        self.paths: list[str] = []

    def __call__(self, task: RecordingTask) -> EstimateRow:
        self.paths.append(task.path)
        return self.fn(task)


def _results(st: Store) -> list[dict[str, Any]]:
    """Every stored estimate without where its file was seen."""
    rows = [{k: v for k, v in r.items() if k not in FACTS} for r in st.estimates()]
    return sorted(rows, key=lambda r: (r["axis"], r["content_hash"]))


def _figures(st: Store, fleet: Any) -> list[dict[str, Any]]:
    """What ``track status`` and ``track forecast`` show: the axes' summaries and alarms."""
    out = []
    for s in fleet_summary(st, fleet):
        d = {k: v for k, v in s.items() if k not in ("trend", "rows", "used_rows", "alarms")}
        d["alarms"] = [(a.kind, a.key, a.message) for a in s["alarms"]]
        out.append(d)
    return out


def _paths(st: Store) -> list[str]:
    return sorted(r["path"] for r in st.estimates())


def test_moving_the_fleet_directory_estimates_nothing_and_changes_no_figure(small_fleet, tmp_path):
    src = copy_fleet(small_fleet, tmp_path / "a" / "fleet")  # relative globs: they move along
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(src / "fleet.toml"), st, workers=1)
    failed = sorted(r["path"] for r in st.estimates() if r["status"] != "ok")
    assert failed  # the corrupt files (and unreadable ones): stored as failed, retried by every ingest
    figures, results, counts = _figures(st, load_fleet(src / "fleet.toml")), _results(st), st.counts()

    dst = tmp_path / "b" / "moved"
    dst.parent.mkdir()
    shutil.move(src, dst)
    fleet = load_fleet(dst / "fleet.toml")
    work = _Counting()
    rep = ingest(fleet, st, workers=1, compute=work)
    # only the failed recordings are estimated again (as without the move)
    assert sorted(work.paths) == sorted(p.replace(str(src), str(dst)) for p in failed)
    ok = counts["recording"] - len(failed)
    n = len(failed)
    assert rep.moved == ok and rep.planned == rep.retried == n and rep.skipped == 0
    assert rep.duplicates == [] and rep.replaced == 0 and rep.stored == n  # the retried ones
    assert st.counts() == counts
    for r in results:  # a failed recording's reason names its file
        r["reason"] = r["reason"].replace(str(src), str(dst))
    assert _results(st) == results
    assert _figures(st, fleet) == figures
    assert all(p.startswith(str(dst)) for p in _paths(st))
    # the next ingest finds every file by its new facts: nothing hashed, nothing estimated
    rep = ingest(fleet, st, workers=1, compute=work)
    assert rep.planned == n and rep.moved == 0 and rep.skipped == ok


def test_touched_and_renamed_files_are_not_estimated_again(small_fleet, tmp_path):
    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(f), st, workers=1)
    results = _results(st)
    a, b, c = sorted((tmp_path / "f" / "rec").glob("*.parquet"))
    os.utime(a)  # touched: a new mtime, the same content
    renamed = b.with_name("old_" + b.name)  # the time stamp in the name is kept
    b.rename(renamed)
    work = _Counting()
    rep = ingest(load_fleet(f), st, workers=1, compute=work)
    assert work.paths == [] and rep.planned == 0 and rep.moved == 2 and rep.skipped == 1
    assert rep.duplicates == [] and rep.stored == 0 and _results(st) == results
    assert _paths(st) == sorted(map(str, (a, renamed, c)))
    facts = {r["path"]: (r["size_bytes"], r["mtime_ns"]) for r in st.estimates()}
    assert facts[str(a)] == (a.stat().st_size, a.stat().st_mtime_ns)
    rep = ingest(load_fleet(f), st, workers=1, compute=work)
    assert work.paths == [] and rep.moved == 0 and rep.skipped == 3


def test_a_file_renamed_to_correct_its_time_stamp_takes_the_new_time(small_fleet, tmp_path, capsys):
    """A recording dated by its file name, renamed to another time stamp (the user corrects a
    wrong date), is not estimated again but takes the new start time — until session 19 it kept
    the stored one, so the trend and the forecast used a date no file said any more. The summary
    counts it. Negative control: a rename that keeps the time stamp keeps the time."""
    from datetime import datetime

    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(f), st, workers=1)
    a, b, c = sorted((tmp_path / "f" / "rec").glob("*.parquet"))
    before = {r["path"]: r["start_time"] for r in st.estimates()}
    stamp = b.name.split("_")[-1].split(".")[0]
    fixed = b.with_name(b.name.replace(stamp, "20991231T235959"))
    b.rename(fixed)
    kept = c.with_name("old_" + c.name)  # the time stamp in the name is kept
    c.rename(kept)
    work = _Counting()
    rep = ingest(load_fleet(f), st, workers=1, compute=work)
    assert work.paths == [] and rep.planned == 0 and rep.moved == 2 and rep.renamed_dated == 1, rep
    after = {r["path"]: r["start_time"] for r in st.estimates()}
    assert after[str(fixed)] == datetime(2099, 12, 31, 23, 59, 59) != before[str(b)]
    assert after[str(kept)] == before[str(c)] and after[str(a)] == before[str(a)]
    rep = ingest(load_fleet(f), st, workers=1, compute=work)  # nothing left to do
    assert work.paths == [] and rep.moved == 0 and rep.renamed_dated == 0 and rep.skipped == 3
    st.close()
    # the command's summary says so (README: "K re-dated by the time stamp in the new name")
    from cli_runner import run_in_process

    fixed.rename(fixed.with_name(fixed.name.replace("20991231T235959", "20991230T120000")))
    code, out, err = run_in_process(
        ["track", "ingest", str(f), "--db", str(tmp_path / "w.sqlite"), "--workers", "1"], capsys
    )
    assert code == 0, err
    assert "0 new recordings estimated" in " ".join(out.split()), out
    assert "1 moved or renamed (not re-estimated; 1 re-dated by the time stamp in the new name)" in " ".join(
        out.split()
    ), out


def test_a_copy_under_another_time_stamp_keeps_the_stored_time(small_fleet, tmp_path):
    """A copy (the stored file still exists) named with another time stamp is a duplicate: the
    recording keeps its path and its time, and nothing counts as re-dated (the rename case
    above is the positive control)."""
    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(f), st, workers=1)
    a = sorted((tmp_path / "f" / "rec").glob("*.parquet"))[0]
    before = {r["path"]: r["start_time"] for r in st.estimates()}
    stamp = a.name.split("_")[-1].split(".")[0]
    copy = a.with_name(a.name.replace(stamp, "20991231T235959"))
    shutil.copy2(a, copy)
    work = _Counting()
    rep = ingest(load_fleet(f), st, workers=1, compute=work)
    assert work.paths == [] and rep.renamed_dated == 0 and rep.moved == 0, rep
    assert rep.duplicates == [f"{copy}: same content as {a} (stored once, estimated once)"]
    assert {r["path"]: r["start_time"] for r in st.estimates()} == before


def test_a_copy_is_a_duplicate_without_being_estimated(small_fleet, tmp_path):
    f, st, orig, copy = ingested_with_a_copy(small_fleet, tmp_path)
    work = _Counting()
    rep = ingest(load_fleet(f), st, workers=1, compute=work)
    assert work.paths == [] and rep.planned == 0 and rep.moved == 0 and rep.stored == 0
    assert rep.duplicates == [f"{copy}: same content as {orig} (stored once, estimated once)"]
    assert len(st.estimates()) == 3 and str(copy) not in _paths(st)


def test_a_moved_failed_recording_or_a_new_config_is_estimated(small_fleet, tmp_path):
    """Only an estimate that did not fail, of this method, drive and code version, is reused."""
    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(f), st, workers=1, compute=_wrong_format)  # every recording failed
    g = tmp_path / "g"
    shutil.move(tmp_path / "f", g)
    work = _Counting()
    rep = ingest(load_fleet(g / "fleet.toml"), st, workers=1, compute=work)
    assert len(work.paths) == 3 and rep.retried == 3 and rep.moved == 0
    assert [r["status"] for r in st.estimates()] == ["ok"] * 3
    # another configuration (estimation rate): a new estimate of the same recordings, moved too
    h = tmp_path / "h"
    shutil.move(g, h)
    _write(h, FILENAME_TIME + "\nestimate_rate_hz = 2000")
    work = _Counting()
    rep = ingest(load_fleet(h / "fleet.toml"), st, workers=1, compute=work)
    assert len(work.paths) == 3 and rep.moved == 0 and rep.stored == 3 and len(st.estimates()) == 6


def test_only_files_of_unknown_facts_and_a_stored_size_are_hashed(small_fleet, tmp_path, monkeypatch):
    hashed: list[str] = []
    ingest_mod = importlib.import_module("drivelash.wear.ingest")  # `wear.ingest` is the function
    real = ingest_mod.content_hash

    def counting_hash(path: str | Path) -> tuple[str, OSError | None]:
        hashed.append(str(path))
        return real(path)

    monkeypatch.setattr(ingest_mod, "content_hash", counting_hash)
    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(f), st, workers=1)
    assert hashed == []  # an empty store holds no content: the first ingest hashes nothing extra
    ingest(load_fleet(f), st, workers=1)
    assert hashed == []  # every file known by its facts
    a = sorted((tmp_path / "f" / "rec").glob("*.parquet"))[0]
    os.utime(a)
    ingest(load_fleet(f), st, workers=1)
    assert hashed == [str(a)]


def test_cli_summary_counts_the_moved_recordings(small_fleet, tmp_path, capsys):
    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    db = tmp_path / "w.sqlite"
    ingest(load_fleet(f), Store(db), workers=1)
    shutil.move(tmp_path / "f", tmp_path / "g")
    r = ingest_here(tmp_path / "g" / "fleet.toml", db, capsys)
    assert r.returncode == 0, r.stderr
    out = " ".join(r.stdout.split())
    assert "0 new recordings estimated" in out and "3 moved or renamed (not re-estimated)" in out, out


@pytest.mark.parametrize("same_size", [False, True])
def test_a_rewritten_file_is_still_estimated_and_replaces_its_recording(small_fleet, tmp_path, same_size):
    """New content under a stored path (of a stored size or not) is estimated and replaces it."""
    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(f), st, workers=1)
    a, b, _ = sorted((tmp_path / "f" / "rec").glob("*.parquet"))
    data = b.read_bytes()
    if same_size:  # the size of a stored recording: hashed, and the hash is new
        a.write_bytes(data[:100] + bytes([data[100] ^ 1]) + data[101:])
    else:
        a.write_bytes(data + b"\0")
    work = _Counting()
    rep = ingest(load_fleet(f), st, workers=1, compute=work)
    assert work.paths == [str(a)] and rep.moved == 0 and rep.replaced == 1
    assert len(st.estimates()) == 3


def test_plan_hashes_in_threads_the_same_rows(small_fleet, tmp_path):
    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(f), st, workers=1)
    shutil.move(tmp_path / "f", tmp_path / "g")
    fleet = load_fleet(tmp_path / "g" / "fleet.toml")
    plan = importlib.import_module("drivelash.wear.ingest").plan
    one: list[EstimateRow] = []
    two: list[EstimateRow] = []
    assert plan(fleet, st, known=one)[1:] == ([], 0) == plan(fleet, st, known=two, hash_threads=2)[1:]
    assert one == two and len(one) == 3 and {r.path for r in one} == set(map(str, fleet.axes[0].files()))
    assert len(plan(fleet, st)[1]) == 3  # without ``known``: tasks, as before
