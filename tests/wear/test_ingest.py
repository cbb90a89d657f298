"""Ingest of a simulated fleet: accuracy against truth.json, failed rows, idempotence, identical
results serial / processes / Dask, SIGKILL and resume, a real PostgreSQL server, CLI errors."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import sqlite3
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from cli_runner import run_in_process
from drivelash.wear import Store, ingest, load_fleet
from drivelash.wear.alarms import fleet_summary

from .conftest import copy_fleet


def _truth(fleet_dir: Path) -> dict[str, dict]:
    t = json.loads((fleet_dir / "truth.json").read_text())
    return {
        str(fleet_dir / r["file"]): {**r, "axis": ax} for ax, a in t["axes"].items() for r in a["recordings"]
    }


def _values(store: Store) -> list[dict]:
    keys = (
        "axis",
        "content_hash",
        "method",
        "config_hash",
        "code_version",
        "status",
        "reason",
        "delta",
        "delta1_estimate",
        "delta_std",
        "excitation_ok",
        "converged",
        "start_time",
        "samples",
        "estimate_rate_hz",
    )
    return sorted(
        ({k: r[k] for k in keys} for r in store.estimates()), key=lambda r: (r["axis"], r["content_hash"])
    )


def test_estimates_match_truth_and_failures_are_rows(small_fleet, serial_store):
    st, rep = serial_store
    truth = _truth(small_fleet)
    rows = st.estimates()
    n_files = len(list((small_fleet / "recordings").rglob("*.parquet")))
    assert len(rows) == n_files == rep.planned and rep.batches >= n_files // 5
    failed = [r for r in rows if r["status"] == "failed"]
    corrupt = {Path(p).name for p, r in truth.items() if r["corrupt"]}
    added = {"M01-X_20260301T060000.parquet", "M01-X_20260302T060000.parquet"}
    assert {Path(r["path"]).name for r in failed} == corrupt | added
    for r in failed:  # one line naming the file and the problem
        assert r["reason"].startswith(r["path"]) and "\n" not in r["reason"] and len(r["reason"]) < 300
    excited = [r for r in rows if r["status"] == "ok" and r["excitation_ok"]]
    assert len(excited) >= 0.8 * (n_files - len(failed))
    for r in excited:
        assert abs(r["delta"] - truth[r["path"]]["delta"]) <= 1e-3, r["path"]
    for r in rows:
        if r["path"] in truth and not truth[r["path"]]["excited"]:
            assert r["status"] == "ok" and not r["excitation_ok"], r["path"]
    for r in rows:  # the estimator's own uncertainty is stored with every excited estimate, else NULL
        if r["status"] == "ok" and r["excitation_ok"]:
            assert r["delta_std"] is not None and 0 < r["delta_std"] < 5e-3, r["path"]
        else:
            assert r["delta_std"] is None, r["path"]


def test_stored_figures_are_those_of_drivelash_estimate(small_fleet, serial_store):
    """The ingest runs the estimator without keeping its output series (``keep="decimated"``, to
    spare the copies) on every k-th sample (the fleet's ``estimate_rate_hz``, 1 kHz by default:
    k = 8 for these 8 kHz recordings); every stored figure equals the one the estimator computes
    on the same samples with the full series kept, bit for bit, and the recording row keeps the
    file's own rate and length."""
    import math

    from drivelash.estimation.estimator import INPUT_COLUMNS
    from drivelash.estimation.pipeline import estimate_trace
    from drivelash.io import load_trace

    st, _ = serial_store
    fleet = {a.name: a for a in load_fleet(small_fleet / "fleet.toml").axes}
    rows = [r for r in st.estimates() if r["status"] == "ok"][:12]
    assert any(r["excitation_ok"] for r in rows)
    for r in rows:
        ax = fleet[r["axis"]]
        assert ax.estimate_rate_hz == 1000.0
        tr = load_trace(r["path"], ax.drive, required=INPUT_COLUMNS, max_rate_hz=ax.estimate_rate_hz)
        res, _ = estimate_trace(ax.drive, tr)
        assert r["sample_rate_hz"] == pytest.approx(8000.0) and r["samples"] == 64000  # the file's
        assert res.t.size == len(range(0, r["samples"], 8)) == 8000  # the full series of the kept samples
        assert r["estimate_rate_hz"] == pytest.approx(1000.0, rel=1e-9)
        assert r["delta"] == res.delta and r["excitation_ok"] == res.excitation_ok, r["path"]
        assert r["converged"] == res.converged and r["reason"] == res.reason
        std = res.delta_std if math.isfinite(res.delta_std) and res.delta_std > 0 else None
        assert r["delta_std"] == std
        d1 = res.extra.get("delta1_estimate", res.extra.get("delta1_check"))
        assert r["delta1_estimate"] == (None if d1 is None else float(d1))


def test_full_rate_on_request_is_another_estimate(small_fleet, serial_store, tmp_path):
    """``estimate_rate_hz = "full"``: every sample, the figure ``drivelash estimate`` gives
    (negative control of the 1 kHz default: the rate is applied, so the figures differ — by less
    than the 1 mrad goal — and they are stored as another estimate of the same recordings)."""
    from dataclasses import replace

    from drivelash.estimation.estimator import INPUT_COLUMNS
    from drivelash.estimation.pipeline import estimate_trace
    from drivelash.io import load_trace

    st, _ = serial_store
    d = copy_fleet(small_fleet, tmp_path / "f")
    toml = d / "fleet.toml"
    text = toml.read_text()
    assert "\nestimate_rate_hz = 1000 " in text  # as `simulate fleet` writes it
    toml.write_text(text.replace("\nestimate_rate_hz = 1000 ", '\nestimate_rate_hz = "full" ', 1))
    fleet = load_fleet(toml)
    ax = next(a for a in fleet.axes if a.name == "M01/Y")  # M01/X holds the added corrupt files
    one = replace(fleet, axes=(ax,))
    full = Store(tmp_path / "full.sqlite")
    ingest(one, full, workers=1)
    by_hash = {r["content_hash"]: r for r in st.estimates() if r["axis"] == ax.name}
    rows = [r for r in full.estimates() if r["status"] == "ok" and r["excitation_ok"]]
    assert len(rows) >= 5
    for r in rows:
        assert r["estimate_rate_hz"] == pytest.approx(8000.0, rel=1e-9)
        res, _ = estimate_trace(ax.drive, load_trace(r["path"], ax.drive, required=INPUT_COLUMNS))
        assert r["delta"] == res.delta and res.t.size == r["samples"]
        k = by_hash[r["content_hash"]]
        assert k["config_hash"] != r["config_hash"]
        assert k["delta"] != r["delta"] and abs(k["delta"] - r["delta"]) < 1e-3


def test_unexcited_never_enter_the_trend(serial_store):
    st, _ = serial_store
    for s in fleet_summary(st):
        used = {r["path"] for r in s["used_rows"]}
        for r in s["rows"]:
            if r["path"] in used:
                assert r["status"] == "ok" and r["excitation_ok"] and r["converged"]
        assert s["used"] + s["unexcited"] + s["failed"] == s["recordings"]


def test_second_ingest_stores_nothing_new(small_fleet, serial_store):
    st, _ = serial_store
    before = st.counts()
    failed = sum(r["status"] == "failed" for r in st.estimates())
    rep = ingest(load_fleet(small_fleet / "fleet.toml"), st, workers=1)
    # only the failed (corrupt) recordings are read again, and they fail again in place
    assert failed > 0 and rep.planned == rep.retried == rep.still_failing == failed
    assert rep.skipped == before["estimate"] - failed and st.counts() == before


def test_process_pool_results_identical_to_serial(small_fleet, serial_store, tmp_path):
    st, _ = serial_store
    st2 = Store(tmp_path / "p.sqlite")
    ingest(load_fleet(small_fleet / "fleet.toml"), st2, workers=2)
    assert _values(st2) == _values(st)


def test_dask_local_cluster_identical_to_serial(small_fleet, serial_store, tmp_path, monkeypatch):
    """A real LocalCluster (2 worker processes): bit-identical results. Its workers run with
    the allocator settings of this process: Dask's default MALLOC_TRIM_THRESHOLD_ (which costs
    +60–75 % CPU per recording, docs/scaling.md) is not set in them, nor left in os.environ."""
    from drivelash.wear.ingest import DaskRunner

    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
    st, _ = serial_store
    st3 = Store(tmp_path / "d.sqlite")
    with DaskRunner("local", 2) as runner:
        env = runner.client.run(os.environ.get, "MALLOC_TRIM_THRESHOLD_")
        ingest(load_fleet(small_fleet / "fleet.toml"), st3, dask=runner)
    assert len(env) == 2 and set(env.values()) == {None}
    assert "MALLOC_TRIM_THRESHOLD_" not in os.environ
    assert _values(st3) == _values(st)


def test_unreachable_dask_scheduler_in_process_writes_nothing(small_fleet, tmp_path, monkeypatch):
    import importlib

    ing = importlib.import_module("drivelash.wear.ingest")

    real = ing.DaskRunner.__init__
    monkeypatch.setattr(ing.DaskRunner, "__init__", lambda self, a, w=2, timeout=10.0: real(self, a, w, 1.0))
    with pytest.raises(ing.SchedulerError, match=r"^--dask tcp://127.0.0.1:1: cannot reach the scheduler"):
        ingest(load_fleet(small_fleet / "fleet.toml"), Store(tmp_path / "w.sqlite"), dask="tcp://127.0.0.1:1")
    assert Store(tmp_path / "w.sqlite").counts()["axis"] == 0  # connected before anything was written


@pytest.mark.slow
def test_unreachable_dask_scheduler_writes_nothing(small_fleet, tmp_path):
    db = tmp_path / "w.sqlite"
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "drivelash.cli",
            "track",
            "ingest",
            str(small_fleet / "fleet.toml"),
            "--db",
            str(db),
            "--dask",
            "tcp://127.0.0.1:1",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 2, r.stderr
    assert (
        r.stderr.strip().count("\n") == 0
        and "--dask tcp://127.0.0.1:1: cannot reach the scheduler" in r.stderr
    )
    assert not db.exists()


def test_unreachable_database_exit_2(small_fleet, cli250):
    r = cli250(
        [
            "track",
            "ingest",
            str(small_fleet / "fleet.toml"),
            "--db",
            "postgresql+psycopg://u:pw@127.0.0.1:1/x",
        ]
    )
    assert r.returncode == 2 and r.stderr.strip().count("\n") == 0 and "cannot open the store" in r.stderr
    assert "pw@" not in r.stderr


_KILLABLE = textwrap.dedent(
    """
    import sys
    from drivelash.wear import Store, ingest, load_fleet
    ingest(load_fleet(sys.argv[1]), Store(sys.argv[2]), workers=1, batch_size=3, batch_seconds=1e9,
           update_alarms=False)
    """
)


def test_sigkill_mid_ingest_then_resume_stores_each_recording_once(small_fleet, tmp_path):
    fleet = copy_fleet(small_fleet, tmp_path / "fleet")
    db = tmp_path / "w.sqlite"
    n_files = len(list((fleet / "recordings").rglob("*.parquet")))
    proc = subprocess.Popen([sys.executable, "-c", _KILLABLE, str(fleet / "fleet.toml"), str(db)])
    t_end = time.monotonic() + 120
    seen = 0
    while time.monotonic() < t_end and proc.poll() is None:
        if db.exists():
            try:
                with sqlite3.connect(db, timeout=5) as c:
                    seen = c.execute("SELECT count(*) FROM estimate").fetchone()[0]
            except sqlite3.Error:  # schema not there yet
                seen = 0
            if seen >= 3:
                break
        time.sleep(0.05)
    assert proc.poll() is None, "ingest finished before it could be killed"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    st = Store(db)
    partial = st.counts()
    assert 3 <= partial["estimate"] < n_files and partial["estimate"] % 3 == 0  # whole batches only
    failed = sum(r["status"] == "failed" for r in st.estimates())  # retried by the resume
    rep = ingest(load_fleet(fleet / "fleet.toml"), st, workers=1)
    assert rep.skipped == partial["estimate"] - failed and rep.planned == n_files - rep.skipped
    assert rep.retried == failed
    c = st.counts()
    assert c["recording"] == c["estimate"] == n_files
    paths = [r["path"] for r in st.estimates()]
    assert len(set(paths)) == n_files


def test_postgresql_store_ingest_and_forecast(small_fleet, serial_store, pg_url):
    """The same ingest on a real PostgreSQL server gives the same values and forecasts."""
    st, _ = serial_store
    pg = Store(pg_url)
    assert pg.revision() == "0004"
    ingest(load_fleet(small_fleet / "fleet.toml"), pg, workers=1)
    assert _values(pg) == _values(st)
    rep = ingest(load_fleet(small_fleet / "fleet.toml"), pg, workers=1)
    failed = sum(r["status"] == "failed" for r in pg.estimates())
    assert failed > 0 and rep.planned == rep.retried == rep.still_failing == failed  # only those, again
    assert _values(pg) == _values(st)
    a = {s["axis"]: (s["model"], s["crossing"], s["days_to_threshold"]) for s in fleet_summary(pg)}
    b = {s["axis"]: (s["model"], s["crossing"], s["days_to_threshold"]) for s in fleet_summary(st)}
    assert a == b
    assert len(pg.alarms()) == len(st.alarms())
    pg.close()


def test_cli_status_forecast_report(small_fleet, serial_store, tmp_path, monkeypatch, capsys):
    st, _ = serial_store
    db = str(st.url.database)
    capsys.readouterr()  # only the commands' output
    with monkeypatch.context() as m:
        m.setenv("COLUMNS", "200")  # for status only, as before
        code, stdout, stderr = run_in_process(["track", "status", "--db", db], capsys)
    assert code == 0, stderr
    assert "M01/X" in stdout and "M02/Y" in stdout
    out = tmp_path / "f.json"
    code, stdout, stderr = run_in_process(
        ["track", "forecast", "M01/X", "--db", db, "--json", str(out)], capsys
    )
    assert code == 0, stderr
    doc = json.loads(out.read_text())
    assert doc["axis"] == "M01/X" and doc["generator"].startswith("drivelash ")
    assert len(doc["estimates"]) == len(st.estimates("M01/X"))
    ok = [e for e in doc["estimates"] if e["status"] == "ok"]
    assert ok and all(e["sample_rate_hz"] == pytest.approx(8000.0) for e in ok)
    assert all(e["estimate_rate_hz"] == pytest.approx(1000.0) for e in ok)  # the fleet's default
    code, stdout, stderr = run_in_process(["track", "forecast", "M01/Q", "--db", db], capsys)
    assert code == 2 and "no axis 'M01/Q'" in stderr and stderr.count("\n") == 1


class _Dying:
    """A worker function that kills its own worker process the first time it sees ``target``
    (a module-level class: picklable for the process pool and for Dask)."""

    def __init__(self, marker: str, target: str) -> None:
        self.marker, self.target = marker, target

    def __call__(self, task):
        from drivelash.wear.estimate import estimate_recording

        if task.path.endswith(self.target):
            try:
                os.close(os.open(self.marker, os.O_CREAT | os.O_EXCL))
            except FileExistsError:
                pass
            else:
                os._exit(1)  # the worker process dies mid-task, no exception, no result
        return estimate_recording(task)


@pytest.mark.slow
@pytest.mark.parametrize("how", ["processes", "dask"])
def test_a_dying_worker_loses_no_recording(small_fleet, serial_store, tmp_path, how):
    st, _ = serial_store
    target = sorted((small_fleet / "recordings" / "M02" / "Y").glob("*.parquet"))[3].name
    marker = tmp_path / "died"
    st2 = Store(tmp_path / "w.sqlite")
    kw = {"dask": "local"} if how == "dask" else {}
    rep = ingest(
        load_fleet(small_fleet / "fleet.toml"),
        st2,
        workers=2,
        compute=_Dying(str(marker), target),
        **kw,
    )
    assert marker.exists()  # a worker really died
    assert rep.planned == len(st.estimates())
    assert _values(st2) == _values(st)  # rerun, nothing lost, same numbers


def test_cli_ingest_with_unreadable_recordings_exit_2_after_storing(tmp_path, capsys):
    """Corrupt/unreadable recordings: one warning line each, stored as failed, the rest stored, exit 2."""
    from drivelash.sim.fleet import simulate_fleet

    from .conftest import _add_corrupt, ingest_here

    simulate_fleet(tmp_path / "f", machines=1, axes=1, recordings=3, seed=1)
    _add_corrupt(tmp_path / "f")
    db = tmp_path / "w.sqlite"
    r = ingest_here(tmp_path / "f" / "fleet.toml", db, capsys)
    assert r.returncode == 2, r.stderr
    err = r.stderr.strip().splitlines()
    warnings = [x for x in err if x.startswith("drivelash: warning: ")]
    assert len(warnings) >= 2 and all("M01-X_2026030" in w or "column" in w or "file" in w for w in warnings)
    assert err[-1].startswith("drivelash: error: ") and "recordings failed (stored as failed" in err[-1]
    out = " ".join(r.stdout.split())  # the summary says at which rate δ was estimated
    # (files that only failed are not counted as estimated: session 31, B-10)
    assert "estimated, 2 failed (at most 1000 Hz: every k-th sample of faster recordings;" in out, out
    rows = Store(db, create=False).estimates()
    assert len(rows) == 5 and sum(r["status"] == "failed" for r in rows) == len(warnings)


def test_a_second_configuration_does_not_count_a_recording_twice(small_fleet, serial_store, tmp_path):
    """The same recordings ingested again under another configuration (here every sample instead
    of 1 kHz; a new drive file, method or drivelash version does the same) are new estimates of
    the same recordings: the trend takes one per recording — the axis's current configuration's
    — not both (before session 8 it took both: every recording twice in the fit)."""
    from dataclasses import replace

    from drivelash.wear.alarms import axis_summary

    st = Store(tmp_path / "w.sqlite")
    fleet = load_fleet(small_fleet / "fleet.toml")
    name = "M01/Y"
    ax = next(a for a in fleet.axes if a.name == name)
    ingest(replace(fleet, axes=(ax,)), st, workers=1)
    axis_row = next(a for a in st.axes() if a["name"] == name)
    before = axis_summary(st, axis_row)
    n_rec = len({r["content_hash"] for r in st.estimates(name)})
    assert before["recordings"] == n_rec
    from drivelash.wear.fleet import config_hash

    full = ax.at_rate(None)
    assert full.drive_hash == config_hash(ax.drive, ax.method) != ax.drive_hash
    ingest(replace(fleet, axes=(full,)), st, workers=1)
    rows = st.estimates(name)
    assert len(rows) == 2 * n_rec  # both configurations are kept in the store
    axis_row = next(a for a in st.axes() if a["name"] == name)
    assert axis_row["drive_hash"] == full.drive_hash
    after = axis_summary(st, axis_row)
    assert after["recordings"] == n_rec and after["used"] == before["used"]
    assert {r["config_hash"] for r in after["used_rows"]} == {full.drive_hash}
    # and back: the 1 kHz configuration is current again, its estimates are used (nothing new)
    ingest(replace(fleet, axes=(ax,)), st, workers=1)
    axis_row = next(a for a in st.axes() if a["name"] == name)
    again = axis_summary(st, axis_row)
    assert {r["config_hash"] for r in again["used_rows"]} == {ax.drive_hash}
    assert [r["delta"] for r in again["used_rows"]] == [r["delta"] for r in before["used_rows"]]


def test_status_and_forecast_judge_with_the_fleet_current_threshold(small_fleet, serial_store, tmp_path):
    """Exploration: a threshold lowered in fleet.toml was ignored by `track status --fleet` until
    the next ingest (the store's copy of 167.30 mrad was used)."""
    from drivelash.commands.track import run_forecast, run_status

    st, _ = serial_store
    db = str(st.url.database)
    src = (small_fleet / "fleet.toml").read_text()
    fleet = load_fleet(small_fleet / "fleet.toml")
    a = fleet.axes[0]
    stored = next(x for x in st.axes() if x["name"] == a.name)["threshold_rad"]
    low = 0.001  # below every estimate: the axis has crossed it
    shutil.copytree(small_fleet, tmp_path / "f", ignore=shutil.ignore_patterns("recordings", "wear.sqlite*"))
    edited = tmp_path / "f" / "fleet.toml"
    edited.write_text(re.sub(r"(?m)^threshold = [0-9.eE+-]+$", f"threshold = {low!r}", src, count=1))
    new = load_fleet(edited)
    assert new.axes[0].threshold_rad == low and stored != low
    s = next(x for x in run_status(db, quiet=True, fleet=new) if x["axis"] == a.name)
    assert s["threshold_rad"] == low and s["crossed"] and any(x.kind == "threshold" for x in s["alarms"])
    doc = run_forecast(a.name, db, quiet=True, fleet=new)
    assert doc["threshold_rad"] == low and doc["crossed"]
    # negative control: without the fleet file the store's threshold judges, not crossed
    s = next(x for x in run_status(db, quiet=True) if x["axis"] == a.name)
    assert s["threshold_rad"] == stored and not s["crossed"]


def test_forecast_json_over_a_users_file_offers_a_force_that_exists(serial_store, tmp_path, capsys):
    """``track forecast --json mine.json`` said "use --force to replace it" but the command had
    no ``--force`` ("No such option: --force"); every other command writing files has one."""
    from tests.cli_runner import run_in_process

    st, _ = serial_store
    db = str(st.url.database)
    mine = tmp_path / "mine.json"
    mine.write_bytes(b'{"mine": 1}\n')
    code, _, err = run_in_process(["track", "forecast", "M01/X", "--db", db, "--json", str(mine)], capsys)
    assert code == 2 and err.strip().splitlines() == [
        f"drivelash: error: --json {mine}: an existing file that is not a drivelash output; "
        "use --force to replace it or choose another path"
    ]
    assert mine.read_bytes() == b'{"mine": 1}\n'
    code, _, err = run_in_process(
        ["track", "forecast", "M01/X", "--db", db, "--json", str(mine), "--force"], capsys
    )
    assert code == 0, err
    assert json.loads(mine.read_text())["axis"] == "M01/X"
