"""An axis removed from fleet.toml keeps its history in the store; status, report and forecast
with ``--fleet`` show the fleet's axes only and say, in one line, which stored ones they leave out."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

TRACK = ["track"]


def _without(small_fleet: Path, dst: Path, axis: str) -> Path:
    """A copy of the fleet file (recordings left where they are) without ``axis``'s [[axis]] table."""
    shutil.copytree(small_fleet, dst, ignore=shutil.ignore_patterns("recordings", "wear.sqlite*"))
    toml = dst / "fleet.toml"
    text = toml.read_text()
    tables = re.split(r"(?m)^(?=\[\[axis\]\])", text)
    kept = [t for t in tables if f'id = "{axis}"' not in t]
    assert len(kept) == len(tables) - 1
    toml.write_text("".join(kept))
    return toml


def _rows(stdout: str) -> dict[str, str]:
    """Status table rows by axis (the whole line, whitespace normalised)."""
    out = {}
    for line in stdout.splitlines():
        f = line.split()
        if f and re.fullmatch(r"M\d\d/[A-Z]", f[0]):
            out[f[0]] = " ".join(f)
    return out


def test_an_axis_removed_from_the_fleet_file_is_kept_but_not_shown(
    small_fleet, serial_store, tmp_path, cli250
):
    st, _ = serial_store
    db = str(st.url.database)
    counts = st.counts()
    gone = "M02/Y"
    full = cli250([*TRACK, "status", "--db", db, "--fleet", str(small_fleet / "fleet.toml")])
    assert full.returncode == 0, full.stderr
    before = _rows(full.stdout)
    assert gone in before and len(before) == 4 and "not in fleet.toml" not in full.stdout
    toml = _without(small_fleet, tmp_path / "f", gone)

    r = cli250([*TRACK, "status", "--db", db, "--fleet", str(toml)])
    assert r.returncode == 0, r.stderr
    after = _rows(r.stdout)
    assert gone not in after
    note = "1 axis in the store is not in fleet.toml (M02/Y): its history is kept; it is not shown"
    assert note in " ".join(r.stdout.split())
    # negative control: the remaining axes' figures are those of the full fleet
    assert after == {k: v for k, v in before.items() if k != gone}

    r = cli250([*TRACK, "forecast", gone, "--db", db, "--fleet", str(toml)])
    assert r.returncode == 2 and "Traceback" not in r.stderr and not r.stdout
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"drivelash: error: {toml}: axis 'M02/Y' is in the store")
    assert "not in this fleet file" in lines[0] and "without --fleet" in lines[0]
    assert cli250([*TRACK, "forecast", "M01/X", "--db", db, "--fleet", str(toml)]).returncode == 0

    html = tmp_path / "r.html"
    r = cli250([*TRACK, "report", "--db", db, "--fleet", str(toml), "-o", str(html)])
    assert r.returncode == 0, r.stderr
    assert "wrote" in r.stdout and "(3 axes)" in r.stdout and note in r.stdout
    text = html.read_text()
    assert note in text and text.count(gone) == 1  # in the note only: no row, no figure

    # the history is kept, and without --fleet every stored axis is shown as before
    assert st.counts() == counts
    r = cli250([*TRACK, "status", "--db", db])
    assert r.returncode == 0 and gone in _rows(r.stdout) and "not in fleet" not in r.stdout


def test_an_axis_renamed_in_the_fleet_file_names_both_the_old_and_the_new_name(
    small_fleet, serial_store, tmp_path, cli250
):
    """M02/Y renamed to M02/W: the old history is "not in fleet.toml"; the new name, not in the
    store yet, was left out of status and report without a word."""
    st, _ = serial_store
    db = str(st.url.database)
    toml = _without(small_fleet, tmp_path / "f", "M02/Y")
    spec = re.split(r"(?m)^(?=\[\[axis\]\])", (small_fleet / "fleet.toml").read_text())
    mine = next(t for t in spec if 'id = "M02/Y"' in t).replace('id = "M02/Y"', 'id = "M02/W"')
    toml.write_text(toml.read_text() + "\n" + mine)

    r = cli250([*TRACK, "status", "--db", db, "--fleet", str(toml)])
    assert r.returncode == 0, r.stderr
    flat = " ".join(r.stdout.split())
    assert "1 axis in the store is not in fleet.toml (M02/Y)" in flat
    assert "1 axis of fleet.toml is not in the store yet (M02/W)" in flat and "track ingest" in flat

    html = tmp_path / "r.html"
    r = cli250([*TRACK, "report", "--db", db, "--fleet", str(toml), "-o", str(html)])
    assert r.returncode == 0 and "not in the store yet (M02/W)" in r.stdout
    assert "not in the store yet (M02/W)" in html.read_text()
    r = cli250([*TRACK, "forecast", "M02/W", "--db", db, "--fleet", str(toml)])
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "did you mean" not in lines[0], r.stderr
    assert "axis 'M02/W' is in this fleet file but not in the store" in lines[0]
    # negative control: the full fleet file names no missing axis
    r = cli250([*TRACK, "status", "--db", db, "--fleet", str(small_fleet / "fleet.toml")])
    assert "not in the store yet" not in r.stdout


def test_alarms_of_a_removed_axis_are_not_counted_and_the_note_says_how_many(
    small_fleet, serial_store, tmp_path, cli250
):
    """The store keeps a removed axis's active alarms (it is no longer re-judged). With
    ``--fleet`` neither status nor the report shows them, the report's "N active alarms"
    counts only the alarms shown, and the one-line note says how many the hidden axis has."""
    st, _ = serial_store
    db = str(st.url.database)
    stored = st.alarms(active_only=True)
    by_axis: dict[str, int] = {}
    for a in stored:
        by_axis[a["axis"]] = by_axis.get(a["axis"], 0) + 1
    gone = max(by_axis, key=lambda k: (by_axis[k], k))  # an axis with stored active alarms
    n_gone = by_axis[gone]
    toml = _without(small_fleet, tmp_path / "f", gone)

    def report(fleet: Path) -> tuple[str, int, int]:
        html = tmp_path / f"{fleet.parent.name}.html"
        r = cli250([*TRACK, "report", "--db", db, "--fleet", str(fleet), "-o", str(html)])
        assert r.returncode == 0, r.stderr
        text = html.read_text()
        said = int(re.search(r"; (\d+) active alarms?\. ", text).group(1))
        alarms = text.split("<h2>Alarms</h2>")[1].split("</section>")[0]
        return " ".join(r.stdout.split()), said, max(alarms.count("<tr>") - 1, 0)  # minus the header

    _, said_full, shown_full = report(small_fleet / "fleet.toml")
    out, said, shown = report(toml)
    assert said == shown and said_full == shown_full
    assert said == shown_full - sum(1 for a in stored if a["axis"] == gone)
    plural = "" if n_gone == 1 else "s"
    note = (
        f"1 axis in the store is not in fleet.toml ({gone}): its history is kept; it is not shown, "
        f"nor its {n_gone} active alarm{plural} (as of its last ingest)"
    )
    assert note in out, out
    r = cli250([*TRACK, "status", "--db", db, "--fleet", str(toml)])
    flat = " ".join(r.stdout.split())
    assert r.returncode == 0 and note in flat, flat
    assert not any(line.startswith("alarm") and gone in line for line in r.stdout.splitlines())

    # negative control: a removed axis without stored alarms says so
    quiet = next((a["name"] for a in st.axes() if a["name"] not in by_axis), None)
    if quiet is not None:
        toml = _without(small_fleet, tmp_path / "g", quiet)
        r = cli250([*TRACK, "status", "--db", db, "--fleet", str(toml)])
        assert f"({quiet}): its history is kept; it is not shown (no active alarm as of its last ingest)" in (
            " ".join(r.stdout.split())
        )
