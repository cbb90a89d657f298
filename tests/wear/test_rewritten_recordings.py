"""A recording file rewritten under the same name (a re-export) replaces its stored recording:
one row per file, with the new estimate (before, the old estimate stayed beside the new one and
the trend counted the file twice)."""

from __future__ import annotations

import hashlib
import json
import shutil

from drivelash.wear import Store, ingest, load_fleet

from .conftest import ingest_here
from .test_redate_duplicates import FILENAME_TIME, _tiny, ingested_with_a_copy


def _other_recording(small_fleet, exclude: set[str]) -> bytes:
    """Bytes of another good, excited recording of M01/X (another δ: a different estimate)."""
    truth = json.loads((small_fleet / "truth.json").read_text())["axes"]["M01/X"]["recordings"]
    rel = next(
        r["file"]
        for r in truth[::-1]
        if r["excited"] and r["corrupt"] is None and r["file"].split("/")[-1] not in exclude
    )
    return (small_fleet / rel).read_bytes()


def test_a_file_rewritten_under_its_name_replaces_its_recording(small_fleet, tmp_path, capsys):
    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    db = tmp_path / "w.sqlite"
    st = Store(db)
    ingest(load_fleet(f), st, workers=1)
    files = sorted((tmp_path / "f" / "rec").glob("*.parquet"))
    target = files[0]
    old = {r["path"]: r for r in st.estimates("M01/X")}[str(target)]
    new_bytes = _other_recording(small_fleet, {p.name for p in files})
    target.write_bytes(new_bytes)  # re-exported: same name, other content

    r = ingest_here(f, db, capsys)
    assert r.returncode == 0, r.stderr
    out = " ".join(r.stdout.split())
    assert "1 new recording estimated" in out and "1 replaced (content changed)" in out, out

    rows = st.estimates("M01/X")
    assert len(rows) == 3 and st.counts()["recording"] == 3
    mine = [x for x in rows if x["path"] == str(target)]
    assert len(mine) == 1
    assert mine[0]["content_hash"] == hashlib.sha256(new_bytes).hexdigest() != old["content_hash"]
    assert mine[0]["status"] == "ok" and mine[0]["delta"] != old["delta"]
    with st.engine.connect() as conn:  # no path of the old content is left behind
        left = conn.exec_driver_sql("SELECT count(*) FROM recording_path WHERE path = ?", (str(target),))
        assert left.scalar_one() == 1

    # the next ingest has nothing to do and replaces nothing
    rep = ingest(load_fleet(f), st, workers=1)
    assert rep.planned == 0 and rep.replaced == 0 and len(st.estimates("M01/X")) == 3


def test_a_copy_under_a_new_name_is_still_a_duplicate_not_a_replacement(small_fleet, tmp_path):
    f, st, orig, copy = ingested_with_a_copy(small_fleet, tmp_path)
    rep = ingest(load_fleet(f), st, workers=1)
    assert rep.replaced == 0 and len(rep.duplicates) == 1
    assert len(st.estimates("M01/X")) == 3


def test_a_renamed_file_then_a_new_file_under_the_old_name_keeps_both(small_fleet, tmp_path):
    """The old content moved to a new name (still there): it stays a recording; the new file
    under the old name is a new recording, not a replacement."""
    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(f), st, workers=1)
    files = sorted((tmp_path / "f" / "rec").glob("*.parquet"))
    target = files[0]
    moved = target.with_name(target.stem + "_v1.parquet")
    shutil.copy(target, moved)
    ingest(load_fleet(f), st, workers=1)  # the content is seen under both names
    target.write_bytes(_other_recording(small_fleet, {p.name for p in files}))
    rep = ingest(load_fleet(f), st, workers=1)
    assert rep.replaced == 0 and rep.planned == 1
    paths = sorted(r["path"] for r in st.estimates("M01/X"))
    assert len(paths) == 4 and str(moved) in paths and str(target) in paths


def _one_row_per_file(st: Store) -> list[str]:
    paths = [r["path"] for r in st.estimates("M01/X")]
    assert len(paths) == len(set(paths)), paths
    return paths


def test_a_file_overwritten_by_a_copy_of_another_recording_replaces_its_old_content(small_fleet, tmp_path):
    """``cp b a``: a's old content is gone from disk; it must leave the trend (it stayed, the
    trend kept an estimate of a file that no longer holds it)."""
    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(f), st, workers=1)
    a, b, _ = sorted((tmp_path / "f" / "rec").glob("*.parquet"))
    old_a = hashlib.sha256(a.read_bytes()).hexdigest()
    shutil.copy(b, a)
    rep = ingest(load_fleet(f), st, workers=1)
    assert rep.replaced == 1 and len(rep.duplicates) == 1
    hashes = {r["content_hash"] for r in st.estimates("M01/X")}
    assert old_a not in hashes and len(hashes) == 2 and st.counts()["recording"] == 2
    _one_row_per_file(st)
    rep = ingest(load_fleet(f), st, workers=1)  # nothing left to do
    assert rep.planned == 0 and rep.replaced == 0 and st.counts()["recording"] == 2


def test_a_recording_moved_onto_another_files_name_replaces_that_files_recording(small_fleet, tmp_path):
    """``mv b a``: one recording (b's content) at a's path; two rows with path a were stored."""
    f = _tiny(small_fleet, tmp_path / "f", FILENAME_TIME)
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(f), st, workers=1)
    a, b, _ = sorted((tmp_path / "f" / "rec").glob("*.parquet"))
    new_a = hashlib.sha256(b.read_bytes()).hexdigest()
    b.replace(a)
    rep = ingest(load_fleet(f), st, workers=1)
    assert rep.replaced == 1
    paths = _one_row_per_file(st)
    assert sorted(paths) == sorted(str(p) for p in (tmp_path / "f" / "rec").glob("*.parquet"))
    assert {r["path"]: r["content_hash"] for r in st.estimates("M01/X")}[str(a)] == new_a
