"""End-to-end ingest throughput of the wear tracker (read + validate + estimate + store).

Measured in one run on a simulated fleet of 60 s recordings at 8 kHz (the rig's rate; the
scale-out case of docs/scaling.md is one 60 s recording per axis and day):

* **serial ingest** (one process: hash, read, validate, estimate, commit to SQLite) — CPU time
  of the process, as a multiple of real time per core — at the fleet's default
  ``estimate_rate_hz`` (1 kHz: every 8th sample is estimated; the file is still hashed, decoded
  and checked for non-finite values whole) and, on the same files, at every sample (``"full"``);
* **named baselines**: what a competent user would write without the tracker — a loop calling
  :func:`drivelash.io.load_trace` (``max_rate_hz`` the fleet's rate) and
  :func:`drivelash.estimation.pipeline.estimate_trace` on each file, and, for the full rate, a
  loop calling the body of ``drivelash estimate``
  (:func:`drivelash.commands.estimate.run_estimate`); results kept in memory; the ratios show
  what the store and bookkeeping cost;
* **Dask** ``LocalCluster`` with 2 worker processes on the same recordings (a fresh store):
  speed-up over the serial wall time (goal ≥ 1.7×; on a 2-core machine shared with other jobs
  this is bounded by what the other jobs leave), with the CPU time each worker and the writer
  used and the share of a core each worker got (CPU / wall) — the figures that tell a slow
  worker from a starved one;
* **peak memory** of the writer process (``ru_maxrss`` of a child process ingesting N
  recordings serially) for N = 8 and N = 32 short recordings: flat means the ratio ≈ 1.

Goals (issue 10): ≥ 1000× real time per core; Dask 2 workers ≥ 1.7× serial; memory flat.
The load average is printed: figures taken on a shared machine are lower bounds.

``--stages`` also measures what each stage of the ingest costs per sample in isolation
(:func:`stage_costs`, best of ``--repeats``, CPU time) and the ceiling that the work which must
be done puts on the throughput: hashing the file, decoding the Parquet columns, the motion pass
and the estimator kernel, once for the chosen law and once for the δ1 check (both laws run
over every sample and both change stored figures) — and the two laws as the estimator runs them,
each sample observed once for both (``deadzone_run2_into``), which is what the ceiling counts.
Everything else (mapping, validation, the kernel's input block, the verdict, the store) is
overhead on top of that ceiling.

Run: ``make bench`` or ``.venv/bin/python benchmarks/bench_wear.py [--recordings N] [--stages]``.
"""

from __future__ import annotations

import argparse
import hashlib
import math
import os
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

RECORDING_S = 60.0


def _fleet(root: Path, recordings: int, duration: float, seed: int) -> Path:
    from drivelash.sim.fleet import simulate_fleet

    out = root / f"fleet-{recordings}-{duration:g}"
    simulate_fleet(
        out, machines=1, axes=2, recordings=max(2, recordings // 2), seed=seed, duration=duration, workers=2
    )
    # the simulator makes a few recordings corrupt (the ingest tests want them); a rate counts
    # only recordings that are estimated, so they are removed here
    import json

    truth = json.loads((out / "truth.json").read_text())
    for a in truth["axes"].values():
        for r in a["recordings"]:
            if r["corrupt"]:
                (out / r["file"]).unlink()
    return out


def _peak_rss_mb(fleet: Path, db: Path) -> float:
    code = textwrap.dedent(
        """
        import resource, sys
        from drivelash.wear import Store, ingest, load_fleet
        ingest(load_fleet(sys.argv[1]), Store(sys.argv[2]), workers=1)
        print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)
        """
    )
    r = subprocess.run(
        [sys.executable, "-c", code, str(fleet / "fleet.toml"), str(db)],
        capture_output=True,
        text=True,
        check=True,
    )
    return float(r.stdout.strip().splitlines()[-1])


def _stages_of(axis, path: Path) -> tuple[int, dict[str, object], set[str]]:
    """(samples, stage label → zero-argument callable, labels of the work that must be done)."""
    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq

    import drivelash.estimation.estimator as est
    from drivelash.estimation import deadzone as dz
    from drivelash.estimation.pipeline import estimate_trace
    from drivelash.io.formats import read_raw
    from drivelash.io.load import _mapping_from, trace_from_table
    from drivelash.wear.estimate import content_hash

    cmap, sampling = _mapping_from(axis.drive)
    table = read_raw(path)
    trace = trace_from_table(table, cmap, sampling, required=est.INPUT_COLUMNS)
    n = len(trace)
    data = Path(path).read_bytes()
    names = list(table.columns)
    seen: dict = {}
    run_session = est._run_session

    def spy(setup, blocks, keep, error_since=()):
        seen["setup"] = setup
        return run_session(setup, blocks, keep, error_since)

    est._run_session = spy
    try:
        estimate_trace(axis.drive, trace, axis.method, keep="decimated")
    finally:
        est._run_session = run_session
    setup = seen["setup"]
    x = est.samples_of(trace)
    out = np.empty((n, dz.N_OUT))
    N = axis.drive.to_drivetrain_params().N

    def decode() -> list:
        tab = pq.read_table(pa.BufferReader(data), columns=names, use_threads=False)
        return [c.to_numpy() for c in tab.columns]

    stages: dict[str, object] = {
        "hash: SHA-256 of the file (in memory)": lambda: hashlib.sha256(data).digest(),
        "read: Parquet decode of the columns (pyarrow, in memory, one thread)": decode,
        "motion pass (scan_blocks)": lambda: est.scan_blocks(est.trace_blocks(trace), N),
    }
    laws = []
    for label, cfg in (("chosen law", setup.config), ("delta1 check law", setup.check_config)):
        if cfg is None:
            continue
        prm = est.build_params(setup.drivetrain, setup.delta1, cfg, setup.T_s, (2 * n) // 3)
        s0 = dz.initial_state(prm, cfg.delta0)
        laws.append((s0, prm))
        stages[f"estimator kernel, {label}"] = lambda s0=s0, prm=prm: dz.deadzone_run_into(s0, x, prm, out)
    required = set(stages)
    if len(laws) == 2 and dz.observe_shared(laws[0][0], laws[1][0], laws[0][1], laws[1][1]):
        # what the estimator runs: both laws over one observation of each sample (the two
        # single-law stages above are shown for comparison, not counted)
        (s_a, p_a), (s_b, p_b) = laws  # (not `pa`: that is pyarrow here)
        out_b = np.empty_like(out)
        label = "estimator kernel, both laws observed once (as run)"
        stages[label] = lambda: dz.deadzone_run2_into(s_a, s_b, x, p_a, p_b, out, out_b)
        required = (required - {k for k in stages if k.startswith("estimator kernel, ")}) | {label}
    stages.update(
        {
            "drivelash: hash the file (content_hash)": lambda: content_hash(path),
            "drivelash: read the file (read_raw)": lambda: read_raw(path),
            "drivelash: map + validate (trace_from_table)": lambda: trace_from_table(
                table, cmap, sampling, required=est.INPUT_COLUMNS
            ),
            "drivelash: estimate_trace (both laws, verdict)": lambda: estimate_trace(
                axis.drive, trace, axis.method, keep="decimated"
            ),
        }
    )
    return n, stages, required


def stage_costs(files: list, repeats: int = 3) -> dict[str, float]:
    """CPU time per sample [s] of each ingest stage, measured in isolation (best of ``repeats``).

    ``files``: (axis, path) pairs. The estimator's two laws are run with the parameters the
    ingest gives them (captured from one ``estimate_trace`` call per recording). The key
    ``"__required__"`` holds the sum over the work that must be done.
    """
    tot: dict[str, float] = {}
    n_tot = 0
    required: set[str] = set()
    for a, p in files:
        n, stages, required = _stages_of(a, p)
        n_tot += n
        for k, f in stages.items():
            b = math.inf
            for _ in range(repeats):
                c0 = time.process_time()
                f()  # type: ignore[operator]
                b = min(b, time.process_time() - c0)
            tot[k] = tot.get(k, 0.0) + b
    out = {k: v / n_tot for k, v in tot.items()}
    out["__required__"] = sum(v for k, v in out.items() if k in required)
    return out


def store_rate(url: str, n: int) -> tuple[float, float | None]:
    """Writer rate [rows/s] of ``n`` synthetic results in batches of 64, and bytes per recording
    (table + indexes; PostgreSQL: ``pg_total_relation_size``, SQLite: file size) or None."""
    import dataclasses
    from datetime import datetime, timedelta

    import sqlalchemy as sa

    from drivelash.wear.store import EstimateRow, Store

    @dataclasses.dataclass(frozen=True)
    class _Axis:
        name: str
        drive_path: str = "/fleet/drives/M00001-X.toml"
        drive_hash: str = "c" * 64
        threshold_rad: float = 0.2
        transmission: float | None = None
        horizon_days: float = 30.0
        not_excited_alarm: int = 5

    st = Store(url)
    axes = [_Axis(f"M{i:05d}/{a}") for i in range(max(1, n // 100)) for a in "XYZ"]
    ids = st.upsert_axes(axes)
    t0 = datetime(2026, 1, 1)
    rows = [
        EstimateRow(
            axis=axes[i % len(axes)].name,
            path=f"/fleet/recordings/M{i:05d}/X/M{i:05d}-X_20260101T060000.parquet",
            size_bytes=14_000_000,
            mtime_ns=1_767_000_000_000_000_000 + i,
            content_hash=f"{i:064x}",
            start_time=t0 + timedelta(minutes=i),
            duration_s=60.0,
            sample_rate_hz=8000.0,
            samples=480000,
            method="default",
            code_version="drivelash 0.1.0",
            config_hash="c" * 64,
            status="ok",
            reason="120 traversals of the deadzone; information during 35 % of the last window",
            delta=0.1 + 1e-9 * i,
            delta1_estimate=0.05,
            delta_std=1e-4,
            excitation_ok=True,
            converged=True,
            runtime_s=0.05,
        )
        for i in range(n)
    ]
    w0 = time.perf_counter()
    for k in range(0, n, 64):
        st.commit_batch(rows[k : k + 64], ids)
    rate = n / (time.perf_counter() - w0)
    size = None
    if st.url.get_backend_name() == "postgresql":
        with st.engine.connect() as c:
            size = (
                sum(
                    c.execute(sa.text(f"SELECT pg_total_relation_size('{t}')")).scalar_one()
                    for t in ("recording", "estimate")
                )
                / n
            )
    elif st.url.database:
        with st.engine.connect() as c:
            c.exec_driver_sql("PRAGMA wal_checkpoint(TRUNCATE)")
        size = Path(st.url.database).stat().st_size / n
    st.close()
    return rate, size


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--recordings", type=int, default=32, help="60 s recordings to ingest")
    ap.add_argument("--store-rows", type=int, default=20000, help="synthetic results for the writer rate")
    ap.add_argument(
        "--pg", default=None, help="also measure the writer on this PostgreSQL URL (empty database)"
    )
    ap.add_argument(
        "--fleet", type=Path, default=None, help="an existing simulated fleet (A/B on the same files)"
    )
    ap.add_argument(
        "--rate",
        default=None,
        help="estimate_rate_hz of the default-rate runs (Hz or 'full'; default: the fleet's, 1000)",
    )
    ap.add_argument("--stages", action="store_true", help="also measure each stage's cost per sample")
    ap.add_argument("--repeats", type=int, default=3, help="best of this many runs per stage (--stages)")
    args = ap.parse_args()

    from dataclasses import replace

    from drivelash.commands.estimate import run_estimate
    from drivelash.estimation.estimator import INPUT_COLUMNS
    from drivelash.estimation.pipeline import estimate_trace
    from drivelash.io import load_trace
    from drivelash.wear import Store, ingest, load_fleet
    from drivelash.wear.estimate import estimate_recording
    from drivelash.wear.ingest import plan

    print(
        f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores "
        "(figures are lower bounds when loaded)"
    )
    with tempfile.TemporaryDirectory(prefix="bench-wear-") as tmp:
        root = Path(tmp)
        t0 = time.perf_counter()
        fl = args.fleet or _fleet(root, args.recordings, RECORDING_S, seed=1)
        fleet = load_fleet(fl / "fleet.toml")
        if args.rate is not None:  # another estimation rate for the default-rate runs
            r = None if args.rate == "full" else float(args.rate)
            fleet = replace(fleet, axes=tuple(a.at_rate(r) for a in fleet.axes))
        files = [(a, p) for a in fleet.axes for p in a.files()]
        data_s = len(files) * RECORDING_S
        print(
            f"fleet: {len(files)} recordings × {RECORDING_S:g} s at 8 kHz, "
            f"simulated in {time.perf_counter() - t0:.0f} s"
        )

        # warm-up: numba caches loaded in this process
        run_estimate(files[0][1], files[0][0].drive_path, quiet=True)

        c0 = time.process_time()
        for a, p in files:
            run_estimate(p, a.drive_path, quiet=True)
        base_cpu = time.process_time() - c0

        # warm-up of the ingest path (the trend libraries the alarm refresh imports: scipy.stats,
        # scikit-learn, statsmodels, ruptures — a one-time cost per process, not a rate): the
        # first axis's recordings into a throwaway store, timed and printed separately. (Until
        # session 8 this was one recording, too few for a trend, so the imports — 0.65 s CPU —
        # fell into the measured serial ingest and lowered its rate.)
        one = replace(fleet, axes=(replace(fleet.axes[0], recordings=str(files[0][1])),))
        c0 = time.process_time()
        ingest(replace(fleet, axes=fleet.axes[:1]), Store(root / "warm.sqlite"), workers=1)
        warm_cpu = time.process_time() - c0
        # an axis with too few recordings fits no trend: import what the trend imports lazily
        import ruptures  # noqa: F401
        import scipy.optimize  # noqa: F401
        import scipy.stats  # noqa: F401
        import sklearn.isotonic  # noqa: F401
        import statsmodels.api  # noqa: F401

        if args.stages:
            T_s = 1.0 / 8000.0
            cost = stage_costs(files, args.repeats)
            req = cost.pop("__required__")
            print(
                f"per-sample CPU cost of each stage in isolation (best of {args.repeats}), load "
                f"{os.getloadavg()[0]:.1f}:"
            )
            for k, v in cost.items():
                print(f"  {k:70s} {1e9 * v:7.1f} ns/sample")
            print(
                f"ceiling from the work that must be done (hash + decode + motion pass + both laws): "
                f"{1e9 * req:.1f} ns/sample -> {T_s / req:.0f}x real time per core at 8 kHz "
                f"(goal 1000x needs <= {1e9 * T_s / 1000:.0f} ns/sample)"
            )

        st = Store(root / "serial.sqlite")
        c0, w0 = time.process_time(), time.perf_counter()
        rep = ingest(fleet, st, workers=1)
        ser_cpu, ser_wall = time.process_time() - c0, time.perf_counter() - w0
        assert rep.planned == len(files)

        # the same recordings at their full rate (estimate_rate_hz = "full"), and the named
        # baseline at the fleet's rate: the library calls a user would loop over
        full_fleet = replace(fleet, axes=tuple(a.at_rate(None) for a in fleet.axes))
        c0 = time.process_time()
        ingest(full_fleet, Store(root / "serial-full.sqlite"), workers=1)
        full_cpu = time.process_time() - c0
        rate = fleet.axes[0].estimate_rate_hz
        c0 = time.process_time()
        for a, p in files:
            estimate_trace(a.drive, load_trace(p, a.drive, required=INPUT_COLUMNS, max_rate_hz=rate))
        base_rate_cpu = time.process_time() - c0

        st2 = Store(root / "dask.sqlite")
        from drivelash.wear.ingest import DaskRunner

        with DaskRunner("local", 2) as runner:
            # workers up, imported and their numba kernels loaded (as the serial process is)
            task0 = plan(one, Store(root / "warm-dask.sqlite"))[1][0]
            runner.client.run(estimate_recording, task0)
            wk0 = runner.client.run(time.process_time)
            w0, c0 = time.perf_counter(), time.process_time()
            ingest(fleet, st2, dask=runner)
            dask_wall, writer_cpu = time.perf_counter() - w0, time.process_time() - c0
            wk1 = runner.client.run(time.process_time)
            worker_cpu = [wk1[k] - wk0[k] for k in wk1]
        same = sorted((r["content_hash"], r["delta"], r["status"]) for r in st.estimates()) == sorted(
            (r["content_hash"], r["delta"], r["status"]) for r in st2.estimates()
        )

        small = _fleet(root, 8, 8.0, seed=2)
        big = _fleet(root, 32, 8.0, seed=3)
        m_small = _peak_rss_mb(small, root / "m8.sqlite")
        m_big = _peak_rss_mb(big, root / "m32.sqlite")

    rt_core = data_s / ser_cpu
    rate_txt = f"estimate_rate_hz = {rate:g}" if rate else "every sample"
    print(
        f"warm-up: first ingest of one axis in this process (with the imports of the trend "
        f"libraries): {warm_cpu:6.2f} s CPU, once per process (not in the rates below)"
    )
    print(
        f"serial ingest, the fleet's default ({rate_txt}): {ser_wall:6.2f} s wall, {ser_cpu:6.2f} s CPU "
        f"-> {rt_core:7.0f}x real time per core (goal >= 1000x) {'OK' if rt_core >= 1000 else 'NOT met'}"
    )
    print(
        f"  baseline (loop over load_trace(max_rate_hz={rate}) + estimate_trace, no store): "
        f"{base_rate_cpu:6.2f} s CPU -> {data_s / base_rate_cpu:7.0f}x; ingest/baseline throughput "
        f"{base_rate_cpu / ser_cpu:.2f}"
    )
    print(
        f'serial ingest, every sample (estimate_rate_hz = "full"): {full_cpu:6.2f} s CPU -> '
        f"{data_s / full_cpu:7.0f}x real time per core"
    )
    print(
        f"  baseline (loop over `drivelash estimate` bodies, every sample, no store): {base_cpu:6.2f} s "
        f"CPU -> {data_s / base_cpu:7.0f}x real time; ingest/baseline throughput {base_cpu / full_cpu:.2f}"
    )
    sp = ser_wall / dask_wall
    print(
        f"Dask LocalCluster, 2 workers: {dask_wall:6.2f} s wall -> {sp:.2f}x the serial wall time "
        f"(goal >= 1.7x) {'OK' if sp >= 1.7 else 'NOT met'}; results identical to serial: {same}"
    )
    print(
        f"  Dask CPU: workers {' + '.join(f'{c:.2f}' for c in worker_cpu)} s, writer and scheduler "
        f"{writer_cpu:.2f} s (serial run: {ser_cpu:.2f} s); share of a core each worker got: "
        f"{', '.join(f'{c / dask_wall:.2f}' for c in worker_cpu)} (1.00 = a free core)"
    )
    print(
        f"peak writer memory: {m_small:.0f} MB for 8 recordings, {m_big:.0f} MB for 32 "
        f"(ratio {m_big / m_small:.2f}; flat: {'OK' if m_big / m_small < 1.2 else 'NOT met'})"
    )
    with tempfile.TemporaryDirectory(prefix="bench-store-") as tmp:
        rate, size = store_rate(str(Path(tmp) / "w.sqlite"), args.store_rows)
        print(f"writer, SQLite: {rate:.0f} results/s (batches of 64), {size:.0f} bytes per recording")
    if args.pg:
        rate, size = store_rate(args.pg, args.store_rows)
        print(f"writer, PostgreSQL: {rate:.0f} results/s, {size:.0f} bytes per recording (tables + indexes)")
    print(f"load average at the end {os.getloadavg()[0]:.1f}")
    if not same:
        raise SystemExit("Dask results differ from the serial run")


if __name__ == "__main__":
    main()
