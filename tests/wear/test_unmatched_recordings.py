"""Stored recordings the fleet file no longer matches (s19 tester, finding F11): an axis's
``recordings`` glob first pointed at another axis's directory and was then corrected; the
wrongly ingested estimates stayed in the axis's trend for good (52 mrad noise, a false threshold
alarm) and nothing could take them out. A stored recording whose file still exists but is no
longer matched by its axis's glob is now left out of that axis's trend, forecast, status,
report and alarms whenever the fleet file is known, with one line saying so; a recording whose
file no longer exists stays in the history (negative control)."""

from __future__ import annotations

import shutil
from pathlib import Path

from cli_runner import run_in_process
from drivelash.wear import Store, ingest, load_fleet
from drivelash.wear.alarms import fleet_summary

FLEET = """[fleet]
name = "wrong glob"
time = {{ from = "filename", pattern = '_(\\d{{8}}T\\d{{6}})\\.', format = "%Y%m%dT%H%M%S" }}
[[axis]]
id = "M01/X"
drive = "drives/M01-X.toml"
recordings = "recordings/{glob}/*.parquet"
threshold = 0.1013
"""


def _fleet(small_fleet: Path, dst: Path, glob: str) -> Path:
    """The small fleet's files with a fleet file of one axis, M01/X (flat at 58.6 mrad,
    threshold 101.3 mrad), whose ``recordings`` point at ``glob`` (``M02/Y``: linear wear
    62 → 138 mrad, another axis's recordings)."""
    if not dst.exists():
        shutil.copytree(small_fleet / "recordings", dst / "recordings")
        shutil.copytree(small_fleet / "drives", dst / "drives")
    f = dst / "fleet.toml"
    f.write_text(FLEET.format(glob=glob))
    return f


def _wrong_then_fixed(small_fleet: Path, tmp_path: Path) -> tuple[Path, Store]:
    d = tmp_path / "f"
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(_fleet(small_fleet, d, "M02/Y")), st, workers=1)
    rep = ingest(load_fleet(_fleet(small_fleet, d, "M01/X")), st, workers=1)
    # the ingest that knows the corrected glob says so in one line
    assert [w for w in rep.warnings if "no longer matched" in w] == [
        next(
            n for n in fleet_summary(st, load_fleet(d / "fleet.toml"))[0]["notes"] if "no longer matched" in n
        )
    ]
    return d / "fleet.toml", st


def test_a_corrected_glob_leaves_the_wrong_recordings_out(small_fleet, tmp_path, monkeypatch, capsys):
    """The tester's scenario: after the correction the old code judged M01/X on 15 estimates
    (8 of M02/Y up to 137 mrad and its own 58.6 mrad ones) and raised a threshold alarm; now
    its own recordings only — no threshold alarm, neither in the summary nor stored by the
    ingest — and one line says 8 were left out and why."""
    f, st = _wrong_then_fixed(small_fleet, tmp_path)
    assert len(st.current_estimates(next(a for a in st.axes() if a["name"] == "M01/X"))) == 18  # all kept
    (s,) = fleet_summary(st, load_fleet(f))
    assert s["unmatched"] == 8
    assert s["recordings"] == 10  # M01/X's 8 + the 2 corrupt files of the fixture
    assert max(r["delta"] for r in s["used_rows"]) < 0.070
    assert [a.kind for a in s["alarms"] if a.kind == "threshold"] == []
    assert [a for a in st.alarms(active_only=True) if a["kind"] == "threshold"] == []
    (note,) = [n for n in s["notes"] if "no longer matched" in n]
    assert note.startswith("M01/X: 8 stored recordings left out: their files still exist")
    assert "count again if the glob matches them again" in note
    # without the fleet file nothing is known about globs: the store's history as it is
    (raw,) = fleet_summary(st)
    assert raw["recordings"] == 18 and raw["unmatched"] == 0
    # status --fleet prints the line
    monkeypatch.setenv("COLUMNS", "400")
    capsys.readouterr()  # only the command's output
    code, stdout, stderr = run_in_process(
        ["track", "status", "--fleet", str(f), "--db", str(tmp_path / "w.sqlite")], capsys
    )
    assert code == 0, stderr
    assert "note M01/X: 8 stored recordings left out" in stdout
    assert "alarm threshold" not in stdout
    # a glob that matches them again counts them again
    f.write_text(FLEET.format(glob="M0*/[XY]"))
    (again,) = fleet_summary(st, load_fleet(f))
    assert again["unmatched"] == 0 and again["recordings"] == 18


def test_deleted_files_stay_in_the_history(small_fleet, tmp_path):
    """Negative control: a recording whose file was deleted (archived) is not "unmatched" — it
    stays in the trend, as before."""
    f, st = _wrong_then_fixed(small_fleet, tmp_path)
    gone = sorted((tmp_path / "f" / "recordings" / "M02" / "Y").glob("*.parquet"))
    for p in gone:
        p.unlink()
    (s,) = fleet_summary(st, load_fleet(f))
    assert s["unmatched"] == 0 and s["recordings"] == 18


def test_a_moved_fleet_directory_changes_no_figure(small_fleet, tmp_path):
    """Negative control: the fleet directory moved (not ingested since): every stored path is
    gone, none is "unmatched"; the figures are those of the store without a fleet file's globs."""
    d = tmp_path / "f"
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(_fleet(small_fleet, d, "M01/X")), st, workers=1)
    before = fleet_summary(st, load_fleet(d / "fleet.toml"))
    shutil.move(d, tmp_path / "moved")
    after = fleet_summary(st, load_fleet(tmp_path / "moved" / "fleet.toml"))
    keys = ("recordings", "used", "current_rad", "crossing", "model", "unmatched", "notes")
    assert [{k: s[k] for k in keys} for s in after] == [{k: s[k] for k in keys} for s in before]
    assert before[0]["unmatched"] == 0
