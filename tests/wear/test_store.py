"""History store: Alembic schema at head, idempotent and transactional writes, other sources, errors."""

from __future__ import annotations

import dataclasses
import time
from datetime import UTC, datetime
from pathlib import Path

import pytest
import sqlalchemy as sa

from drivelash.wear.store import EstimateRow, Store, StoreError


@dataclasses.dataclass(frozen=True)
class _Axis:
    name: str
    drive_path: Path = Path("/x/drive.toml")
    drive_hash: str = "h" * 64
    threshold_rad: float = 0.2
    transmission: float | None = 2.0
    horizon_days: float = 30.0
    not_excited_alarm: int = 5


def _row(i: int, axis: str = "M01/X", **kw) -> EstimateRow:
    base = dict(
        axis=axis,
        path=f"/r/{i}.parquet",
        size_bytes=100 + i,
        mtime_ns=10**18 + i,
        content_hash=f"{i:064x}",
        start_time=datetime(2026, 1, 1 + i, 6, 0),
        duration_s=8.0,
        sample_rate_hz=8000.0,
        samples=64000,
        method="default",
        code_version="drivelash 0.1.0",
        config_hash="c" * 64,
        status="ok",
        reason="fine",
        delta=0.1 + 1e-3 * i,
        delta1_estimate=0.05,
        delta_std=None,
        excitation_ok=True,
        converged=True,
        runtime_s=0.1,
    )
    base.update(kw)
    return EstimateRow(**base)


def test_schema_is_created_by_the_shipped_migrations(tmp_path):
    st = Store(tmp_path / "w.sqlite")
    assert st.revision() == "0004"
    names = set(sa.inspect(st.engine).get_table_names())
    assert {"axis", "recording", "estimate", "measurement", "alarm", "alembic_version"} <= names
    cols = {c["name"] for c in sa.inspect(st.engine).get_columns("estimate")}
    assert {
        "method",
        "code_version",
        "config_hash",
        "delta",
        "delta1_estimate",
        "delta_std",
        "excitation_ok",
        "reason",
        "converged",
        "runtime_s",
        "status",
        "estimate_rate_hz",
    } <= cols
    with st.engine.connect() as c:
        assert c.exec_driver_sql("PRAGMA journal_mode").scalar() == "wal"
    st.close()
    # reopening does not migrate again and keeps the data
    st2 = Store(tmp_path / "w.sqlite", create=False)
    assert st2.revision() == "0004"


def test_a_store_of_revision_0001_is_migrated_and_keeps_its_rows(tmp_path):
    """A store written before ``estimate_rate_hz`` existed: a read-only open refuses it with the
    command to run, a writing open upgrades it to 0002; its rows stay, the new column NULL."""
    from drivelash.wear.store import StoreError

    from .conftest import old_store

    db = old_store(
        tmp_path / "old.sqlite",
        "0001",
        "INSERT INTO axis (name, machine, horizon_days, not_excited_alarm, updated_at) "
        "VALUES ('M01/X', 'M01', 30, 5, '2026-01-01 00:00:00')",
        "INSERT INTO recording (axis_id, content_hash, path, size_bytes, mtime_ns) "
        "VALUES (1, 'h', '/r.parquet', 1, 1)",
        "INSERT INTO estimate (recording_id, axis_id, method, code_version, config_hash, status, "
        "reason, delta, runtime_s, created_at) VALUES (1, 1, 'default', 'v', 'c', 'ok', '', 0.1, 0, "
        "'2026-01-01 00:00:00')",
    )
    with pytest.raises(StoreError, match="schema revision 0001 is not the current 0004"):
        Store(db, create=False)
    st = Store(db)
    assert st.revision() == "0004"
    (row,) = st.estimates()
    assert row["delta"] == 0.1 and row["estimate_rate_hz"] is None


def test_commit_is_idempotent(tmp_path):
    st = Store(tmp_path / "w.sqlite")
    ids = st.upsert_axes([_Axis("M01/X")])
    rows = [_row(i) for i in range(5)]
    assert st.commit_batch(rows, ids) == 5
    assert st.commit_batch(rows, ids) == 0  # the same results again: nothing new
    # the same content under another path is the same recording
    assert st.commit_batch([dataclasses.replace(rows[0], path="/moved/0.parquet")], ids) == 0
    # another config hash is another estimate of the same recording
    assert st.commit_batch([dataclasses.replace(rows[0], config_hash="d" * 64)], ids) == 1
    assert st.counts()["recording"] == 5 and st.counts()["estimate"] == 6
    got = st.estimates("M01/X")
    assert [r["delta"] for r in got if r["config_hash"] == "c" * 64] == [r.delta for r in rows]


def test_a_batch_is_committed_whole_or_not_at_all(tmp_path):
    st = Store(tmp_path / "w.sqlite")
    ids = st.upsert_axes([_Axis("M01/X")])
    batch = [_row(0), _row(1), _row(2, axis="M09/Q")]  # the last row's axis is unknown: KeyError mid-batch
    with pytest.raises(KeyError):
        st.commit_batch(batch, ids)
    assert st.counts()["recording"] == 0 and st.counts()["estimate"] == 0
    # negative control: without the bad row the same batch is stored
    assert st.commit_batch(batch[:2], ids) == 2


def test_failed_recording_row_and_unknown_uncertainty_stay_null(tmp_path):
    st = Store(tmp_path / "w.sqlite")
    ids = st.upsert_axes([_Axis("M01/X")])
    bad = _row(
        7,
        status="failed",
        reason="/r/7.parquet: not a recording",
        delta=None,
        excitation_ok=None,
        converged=None,
        start_time=None,
        duration_s=None,
    )
    st.commit_batch([_row(1), bad], ids)
    rows = {r["path"]: r for r in st.estimates()}
    assert rows["/r/7.parquet"]["status"] == "failed" and rows["/r/7.parquet"]["reason"].endswith(
        "not a recording"
    )
    assert rows["/r/7.parquet"]["delta"] is None
    assert rows["/r/1.parquet"]["delta_std"] is None  # never made up


def test_measurement_api_for_iso230_converts_mm_to_rad(tmp_path):
    st = Store(tmp_path / "w.sqlite")
    st.upsert_axes([_Axis("M01/X", transmission=2.0), _Axis("M01/Y", transmission=None)])
    t = datetime(2026, 2, 1, 9, 0, tzinfo=UTC)
    i1 = st.add_measurement(
        "M01/X", t, value=0.012, std=0.002, unit="mm", source="iso230-2", reference="laser.csv"
    )
    assert st.add_measurement("M01/X", t, value=0.012, std=0.002, unit="mm") == i1  # idempotent
    st.add_measurement("M01/Y", t, value=12.0, std=None, unit="um")
    m = {x["axis"]: x for x in st.measurements()}
    assert m["M01/X"]["value_rad"] == pytest.approx(0.006) and m["M01/X"]["std_rad"] == pytest.approx(0.001)
    assert m["M01/X"]["time"] == datetime(2026, 2, 1, 9, 0) and m["M01/X"]["source"] == "iso230-2"
    assert m["M01/Y"]["value_rad"] is None and m["M01/Y"]["value"] == 12.0  # no transmission: kept in um
    with pytest.raises(StoreError, match="no axis 'M01/Z'; did you mean"):
        st.add_measurement("M01/Z", t, value=1.0, std=None, unit="mm")
    # a name sharing only the "M0" and "/" of the axis ids is no slip (session 30, B-10)
    with pytest.raises(StoreError, match=r"^.*no axis 'M09/Q' \(2 axes in the store\)$"):
        st.add_measurement("M09/Q", t, value=1.0, std=None, unit="mm")
    with pytest.raises(StoreError, match="unit 'inch'"):
        st.add_measurement("M01/X", t, value=1.0, std=None, unit="inch")


def test_unreachable_database_is_one_line_and_quick(tmp_path):
    t0 = time.monotonic()
    with pytest.raises(StoreError) as exc:
        Store("postgresql+psycopg://nobody:secret@127.0.0.1:1/none", connect_timeout=2)
    msg = str(exc.value)
    assert "\n" not in msg and "cannot open the store" in msg and "secret" not in msg
    assert time.monotonic() - t0 < 30
    with pytest.raises(StoreError, match="not a database URL|unsupported database"):
        Store("nosuchdb://x/y")
    with pytest.raises(StoreError, match="directory .* does not exist"):
        Store(tmp_path / "no" / "dir" / "w.sqlite")


def test_read_only_open_never_creates_a_store(tmp_path):
    with pytest.raises(StoreError, match="no such store"):
        Store(tmp_path / "none.sqlite", create=False)
    assert not (tmp_path / "none.sqlite").exists()


def test_postgresql_skip_reason_says_why():
    """Without the server binaries the PostgreSQL tests skip naming what is missing and why
    ``make test`` did not install it (not root / apt-get failed / no apt-get)."""
    from .conftest import pg_missing_reason

    texts = [pg_missing_reason(1000, True), pg_missing_reason(0, True), pg_missing_reason(0, False)]
    assert all("initdb" in t for t in texts)
    assert "not root" in texts[0] and "apt-get install postgresql" in texts[1] and "no apt-get" in texts[2]
    assert len(set(texts)) == 3


def test_non_finite_uncertainty_is_stored_as_null():
    """The estimator's NaN 'no uncertainty' is NULL in every backend (SQLite would turn a NaN
    into NULL, PostgreSQL would keep NaN)."""
    from drivelash.wear.estimate import _std_or_none

    assert _std_or_none(float("nan")) is None and _std_or_none(None) is None
    assert _std_or_none(0.0) is None and _std_or_none(float("inf")) is None
    assert _std_or_none(2.5e-4) == 2.5e-4


def test_a_store_is_named_by_its_path_as_written(tmp_path):
    """``track ingest --db "sp ace ü/w ü.sqlite"`` named the store ``…/sp ace %C3%BC/w
    %C3%BC.sqlite`` in its summary and messages (SQLAlchemy's URL rendering)."""
    d = tmp_path / "sp ace ü"
    d.mkdir()
    with Store(d / "w ü.sqlite") as st:
        assert st.name == f"sqlite:///{d / 'w ü.sqlite'}"
    (d / "mine ü.json").write_text("{}\n")
    with pytest.raises(StoreError) as ei:
        Store(d / "mine ü.json")
    shown = f"sqlite:///{d / 'mine ü.json'}"
    assert str(ei.value) == f"--db {shown}: cannot open the store (file is not a database)"
    assert (d / "mine ü.json").read_text() == "{}\n"


@pytest.mark.parametrize("create", [True, False], ids=["ingest", "status"])
def test_a_directory_given_as_the_store_is_named_as_one(tmp_path, create):
    """``--db DIR``: "cannot open the store (unable to open database file)" (ingest) or "no such
    store (run track ingest first …)" (status, forecast, report)."""
    d = tmp_path / "history"
    d.mkdir()
    with pytest.raises(StoreError) as ei:
        Store(d, create=create)
    assert str(ei.value) == f"{d}: is a directory, not a store file; give a file, e.g. {d / 'wear.sqlite'}"
    assert list(d.iterdir()) == []
