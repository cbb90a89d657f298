"""``time = {from = "column"}`` on a relative time column (s19 tester, finding F2): every drive
trace's ``t`` starts at 0 s, and ingest dated every recording 1970-01-01 00:00:00 without a word
(the forecast then said "too few estimates"). A first value before 2000-01-01
(``estimate.EARLIEST_COLUMN_START``) is a relative time: a one-line error naming the fleet file,
the axis, the key and the file, exit 2, nothing written; POSIX stamps are read as before."""

from __future__ import annotations

import shutil
from datetime import UTC, datetime
from pathlib import Path

import pyarrow.parquet as pq

from drivelash.wear import Store, ingest, load_fleet

FLEET = """[fleet]
name = "column time"
db = "wear.sqlite"
time = { from = "column", column = "t" }
[[axis]]
id = "M01/Y"
drive = "drives/M01-Y.toml"
recordings = "rec/*.parquet"
threshold = 0.2
"""


def _fleet(small_fleet: Path, dst: Path, offset_s: float) -> Path:
    """Two recordings of M01/Y whose ``t`` column is shifted by ``offset_s`` (the second by a
    day more when ``offset_s`` is not 0)."""
    (dst / "rec").mkdir(parents=True)
    shutil.copytree(small_fleet / "drives", dst / "drives")
    for j, p in enumerate(sorted((small_fleet / "recordings" / "M01" / "Y").glob("*.parquet"))[:2]):
        tab = pq.read_table(p)
        k = tab.schema.get_field_index("t")
        t = tab.column("t").to_numpy() + offset_s + (86400.0 * j if offset_s else 0.0)
        pq.write_table(tab.set_column(k, "t", [t]), dst / "rec" / p.name)
    (dst / "fleet.toml").write_text(FLEET)
    return dst / "fleet.toml"


def test_a_relative_time_column_is_a_one_line_error(small_fleet, tmp_path, cli250):
    """Old code: exit 0, both recordings dated 1970-01-01 00:00:00. Now exit 2, one line naming
    the fleet file, [[axis]] #1 (id 'M01/Y'), key 'time.column' = 't', the file, its first
    value and the threshold; no store written."""
    f = _fleet(small_fleet, tmp_path / "f", 0.0)
    out = cli250(["track", "ingest", str(f), "--workers", "1"])
    assert out.returncode == 2, out.stdout + out.stderr
    err = out.stderr.strip()
    assert "\n" not in err and "Traceback" not in err
    assert err.startswith(f"drivelash: error: {f}: table [[axis]] #1 (id 'M01/Y'), key 'time.column' = 't': ")
    assert "M01-Y_20260105T061200.parquet" in err
    assert "starts at 0 s, before 2000-01-01: a relative time" in err
    assert not (tmp_path / "f" / "wear.sqlite").exists()


def test_posix_stamps_in_the_column_still_date_the_recordings(small_fleet, tmp_path):
    """Negative control: the same files with POSIX stamps (2026-01-05 06:12 UTC onwards) are
    dated by them."""
    t0 = datetime(2026, 1, 5, 6, 12, tzinfo=UTC).timestamp()
    f = _fleet(small_fleet, tmp_path / "f", t0)
    st = Store(tmp_path / "w.sqlite")
    ingest(load_fleet(f), st, workers=1)
    assert [r["start_time"] for r in st.estimates("M01/Y")] == [
        datetime(2026, 1, 5, 6, 12),
        datetime(2026, 1, 6, 6, 12),
    ]
