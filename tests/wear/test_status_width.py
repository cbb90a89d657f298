"""`track status` in a narrow terminal: a 120-axis fleet at 100 columns, one line per axis."""

from __future__ import annotations

from datetime import datetime, timedelta

from cli_runner import run_in_process
from drivelash.wear.alarms import Alarm

TRACK = ["track"]


def _summaries(n: int = 120) -> list[dict]:
    """Worst-case cells of the status table: long models, crossings with intervals (one late
    bound never reached), several alarm kinds, three-digit recording counts."""
    t = datetime(2027, 3, 1, 6, 0)
    out = []
    for i in range(n):
        name = f"M{i // 4 + 1:03d}/{'XYZA'[i % 4]}"
        kinds = ["forecast", "jump", "not_excited"][: 1 + i % 3]
        out.append(
            {
                "axis": name,
                "current_rad": 0.1234 + i * 1e-4,
                "threshold_rad": 0.1672,
                "model": "accelerating" if i % 2 else "linear",
                "crossed": i % 10 == 0,
                "crossing": t + timedelta(days=i),
                "crossing_early": t + timedelta(days=i - 12.3),
                "crossing_late": t + timedelta(days=i + 123.4),
                "crossing_late_never": i % 7 == 0,
                "days_to_threshold": 100.0 + i,
                "used": 118,
                "recordings": 120,
                "unexcited": 11,
                "failed": 3,
                "alarms": [Alarm(k, "k", f"{name}: {k}", t) for k in kinds],
                "last_recording": t - timedelta(days=1),
            }
        )
    return out


class _NoStore:
    name = "sqlite:////data/plant/wear.sqlite"

    def close(self) -> None:
        pass


def _table_lines(text: str, names: list[str]) -> list[str]:
    lines = text.splitlines()
    head = next(i for i, x in enumerate(lines) if x.split()[:1] == ["axis"])
    return lines[head + 1 : head + 1 + len(names)]


def test_status_of_120_axes_at_100_columns_is_one_line_per_axis(monkeypatch, capsys):
    from drivelash.commands import track

    summ = _summaries()
    names = [s["axis"] for s in summ]
    monkeypatch.setattr(track, "_summaries", lambda db, fleet=None: (_NoStore(), summ, None))
    monkeypatch.setenv("COLUMNS", "100")
    track.run_status("unused")
    out = capsys.readouterr().out
    assert max(len(x) for x in out.splitlines()) <= 100, out
    rows = _table_lines(out, names)
    # every data row is one line, starting with its axis name whole, in the summaries' order
    assert [r.split()[0] for r in rows] == names, out
    table = out.split("δ now, thresh.: mrad")[0]  # the table ends where the legend starts
    assert all(table.count(n) == 1 for n in names)
    assert len(table.strip().splitlines()) == 2 + len(names)  # title, header, one line per axis
    # nothing dropped: each row has all 11 cells, the legend spells the short forms out
    assert all(len(r.split()) == 11 for r in rows), rows[:3]
    first = rows[0].split()
    assert first[1:6] == ["123.40", "167.20", "linear", "crossed", "-12…never"], first
    assert rows[1].split()[3:6] == ["accel.", "2027-03-02", "-12…+123"]
    assert rows[2].split()[-1] == "fc,jump,unexc"
    flat = " ".join(out.split())
    assert (
        "90 % int.: its 90 % interval, days before … after it" in flat
        and "fail: failed" in flat
        and "accel.: accelerating" in flat
    )
    assert "crossing: expected threshold crossing (UTC)" in flat and "(times UTC)" in flat


def test_status_at_100_columns_from_the_cli_and_full_headers_when_wide(serial_store, monkeypatch, capsys):
    st, _ = serial_store
    db = str(st.url.database)
    names = [a["name"] for a in st.axes()]

    def status(cols: str) -> str:
        monkeypatch.setenv("COLUMNS", cols)  # the command's Console reads it when created
        capsys.readouterr()  # only this command's output
        code, out, err = run_in_process([*TRACK, "status", "--db", db], capsys)
        assert code == 0, err
        return out

    narrow = status("100")
    assert max(len(x) for x in narrow.splitlines()) <= 100, narrow
    assert sorted(r.split()[0] for r in _table_lines(narrow, names)) == sorted(names), narrow
    assert "thresh." in narrow and "δ now, thresh.: mrad" in " ".join(narrow.split())
    # negative control: wide enough for the report's headers, the full table, no legend (and the
    # units in its headers: "[mrad]" used to be swallowed as rich markup)
    wide = " ".join(status("250").split())
    assert "threshold [mrad]" in wide and "expected crossing (UTC)" in wide and "δ now, thresh.:" not in wide


def _status_at(monkeypatch, capsys, cols: str, n: int = 12) -> tuple[str, list[str]]:
    from drivelash.commands import track

    summ = _summaries(n)
    monkeypatch.setattr(track, "_summaries", lambda db, fleet=None: (_NoStore(), summ, None))
    monkeypatch.setenv("COLUMNS", cols)
    track.run_status("unused")
    return capsys.readouterr().out, [s["axis"] for s in summ]


def test_status_narrower_than_the_narrow_table_keeps_every_axis_name_whole(monkeypatch, capsys):
    """At 60 and 40 columns every cell was cut to "M0…": the axes could not be told apart.
    Columns are left out instead (the legend names them); axis and alarms stay."""
    for cols in (60, 40, 20):
        out, names = _status_at(monkeypatch, capsys, str(cols))
        rows = _table_lines(out, names)
        assert [r.split()[0] for r in rows] == names, out
        assert "…" not in " ".join(r.split()[0] for r in rows)
        assert "not shown at this width:" in " ".join(out.split()), out
        assert rows[2].split()[-1] == "fc,jump,unexc", out  # the alarms column stays
    out, _ = _status_at(monkeypatch, capsys, "100")  # negative control: nothing left out at 100
    assert "not shown at this width" not in " ".join(out.split())


def test_status_with_columns_zero_prints_the_table(monkeypatch, capsys):
    """COLUMNS=0 (a serial console reports 0 × 0) printed nothing at all, exit 0."""
    out, names = _status_at(monkeypatch, capsys, "0")
    assert [r.split()[0] for r in _table_lines(out, names)] == names, out
