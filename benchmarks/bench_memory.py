"""Memory of ``drivelash estimate`` on a long 8 kHz recording (issue 15, acceptance 2).

Writes a recording of ``--minutes`` at 8 kHz (default 60 min = 28.8 M samples) as Parquet
and as CSV in a temporary directory, runs ``drivelash estimate`` on each in a subprocess and
reports its peak RSS (``resource.getrusage(RUSAGE_CHILDREN).ru_maxrss`` of that child
alone: one child per measurement, each from a fresh helper process), wall time, bytes of
RAM per sample and per byte of file. It then checks that δ̂ of the streamed run equals the
in-memory run (:class:`drivelash.estimation.estimator.DeadzoneEstimator` on
:func:`drivelash.io.load_trace`) on a shorter prefix file (``--prefix-minutes``), bit for
bit.

Baseline (named, measured in the same run): the file size — a competent user's pandas
script ``pd.read_parquet`` / ``pd.read_csv`` holds at least the decoded columns
(8 bytes × columns × samples); we print RSS / decoded size.

The recording: 60 s of the simulated bench test ``bench-0A`` (0.5 Hz position sine, in
periodic steady state after 10 s), its last 50 s tiled with continued time — the numbers
are a drive's, the content repeats; δ̂ comparisons are between two readings of the same file, so the tiling
does not matter for them.

Run: ``make bench`` (a 10-minute recording, to keep ``make bench`` short) or
``.venv/bin/python benchmarks/bench_memory.py --minutes 60`` for the acceptance figure.
Goal: peak RSS < 1 GiB for 60 min (28.8 M samples), Parquet and CSV.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

RATE_HZ = 8000.0
COLUMNS = ("t", "theta_m", "omega_m", "theta_l", "omega_l", "torque_m")
CONFIG = Path(__file__).resolve().parents[1] / "examples" / "drive_bench.toml"
GOAL_BYTES = 1 << 30

#: Runs one command in a child and prints that child's peak RSS (this helper has no other child).
_MEASURE = """
import json, resource, subprocess, sys, time
t0 = time.perf_counter()
p = subprocess.run(sys.argv[1:], capture_output=True, text=True)
wall = time.perf_counter() - t0
rss = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024
print(json.dumps({"rc": p.returncode, "rss": rss, "wall": wall, "err": p.stderr[-2000:]}))
"""


def _tile(minutes: float) -> tuple[dict[str, np.ndarray], int]:
    """One steady-state 50 s segment of bench-0A and the number of samples to write."""
    from drivelash.sim.scenarios import get_scenario

    sc = get_scenario("bench-0A")
    tr = sc.simulate(duration=60.0)
    k0 = int(round(10.0 * RATE_HZ))
    seg = {c: tr[c][k0:] for c in COLUMNS if c != "t"}
    return seg, int(round(minutes * 60.0 * RATE_HZ))


def _chunks(seg: dict[str, np.ndarray], n: int, rows: int = 1 << 20):
    m = len(next(iter(seg.values())))
    for start in range(0, n, rows):
        stop = min(n, start + rows)
        idx = np.arange(start, stop)
        cols = {"t": idx / RATE_HZ}
        for c, v in seg.items():  # 50 s = 25 periods of the 0.5 Hz reference: tiles join smoothly
            cols[c] = v[idx % m]
        yield cols


def write_recording(dirpath: Path, minutes: float, seg: dict[str, np.ndarray]) -> tuple[Path, Path, int]:
    """Write the recording as Parquet (row groups of 1 M) and CSV; returns the paths and sample count."""
    import pyarrow as pa
    import pyarrow.csv as pcsv
    import pyarrow.parquet as pq

    n = int(round(minutes * 60.0 * RATE_HZ))
    pq_path, csv_path = dirpath / f"rec-{minutes:g}min.parquet", dirpath / f"rec-{minutes:g}min.csv"
    schema = pa.schema([(c, pa.float64()) for c in COLUMNS])
    with pq.ParquetWriter(pq_path, schema) as w, pa.OSFile(str(csv_path), "wb") as fcsv:
        cw = pcsv.CSVWriter(fcsv, schema)
        for cols in _chunks(seg, n):
            batch = pa.record_batch([pa.array(cols[c]) for c in COLUMNS], schema=schema)
            w.write_batch(batch)
            cw.write_batch(batch)
        cw.close()
    return pq_path, csv_path, n


def measure(args: list[str]) -> dict:
    """Peak RSS [bytes], wall time [s] and exit code of ``args`` run as a child."""
    out = subprocess.run([sys.executable, "-c", _MEASURE, *args], capture_output=True, text=True, check=True)
    return json.loads(out.stdout)


def estimate_cmd(path: Path, json_out: Path) -> list[str]:
    return [
        sys.executable,
        "-c",
        "from drivelash.cli import main; main()",
        "estimate",
        str(path),
        "--config",
        str(CONFIG),
        "--json",
        str(json_out),
        "--force",
    ]


#: The chunk reader alone (``drivelash.io.TraceStream``: validation pass, second pass, chunks).
_READ_STREAM = """
import sys
from drivelash.estimation.estimator import INPUT_COLUMNS
from drivelash.io import load_config
from drivelash.io.stream import TraceStream
with TraceStream(sys.argv[1], load_config(sys.argv[2]), required=INPUT_COLUMNS) as s:
    n = sum(len(c) for c in s.chunks())
assert n == s.n_samples, (n, s.n_samples)
"""


def stream_cmd(path: Path) -> list[str]:
    return [sys.executable, "-c", _READ_STREAM, str(path), str(CONFIG)]


def in_memory_delta_hat(path: Path) -> np.ndarray:
    """δ̂(t) of the in-memory run (the reference for bit-identity)."""
    from drivelash.commands.estimate import estimate_trace
    from drivelash.estimation.estimator import INPUT_COLUMNS
    from drivelash.io import load_config, load_trace

    cfg = load_config(CONFIG)
    res, _ = estimate_trace(cfg, load_trace(path, cfg, required=INPUT_COLUMNS), "default")
    return res.delta_hat


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=10.0, help="Length of the long recording [min].")
    ap.add_argument("--prefix-minutes", type=float, default=1.0, help="Prefix for the δ̂ comparison [min].")
    ap.add_argument("--formats", default="parquet,csv")
    ap.add_argument("--dir", type=Path, default=None, help="Work directory (default: a temporary one).")
    a = ap.parse_args()
    formats = a.formats.split(",")
    with tempfile.TemporaryDirectory(dir=a.dir) as tmp:
        d = Path(tmp)
        t0 = time.perf_counter()
        seg, _ = _tile(a.minutes)
        pq_path, csv_path, n = write_recording(d, a.minutes, seg)
        print(f"recording: {n} samples ({a.minutes:g} min at 8 kHz), {len(COLUMNS)} columns, "
              f"written in {time.perf_counter() - t0:.0f} s")  # fmt: skip
        decoded = n * len(COLUMNS) * 8
        rows = []
        for fmt, path in (("parquet", pq_path), ("csv", csv_path)):
            if fmt not in formats:
                continue
            m = measure(estimate_cmd(path, d / f"{fmt}.json"))
            if m["rc"] != 0:
                print(f"{fmt}: estimate failed (exit {m['rc']}): {m['err'].strip().splitlines()[-1:]}")
                rows.append((fmt, path, None))
                continue
            size = path.stat().st_size
            per = m["rss"] / n
            print(f"{fmt:8s}: peak RSS {m['rss'] / 2**20:8.0f} MiB  wall {m['wall']:7.1f} s  "
                  f"{per:6.1f} B/sample  {m['rss'] / size:5.2f}× file ({size / 2**20:.0f} MiB)  "
                  f"{m['rss'] / decoded:5.2f}× decoded columns (pandas baseline ≥ 1.00×)  "
                  f"goal < 1 GiB at 60 min: {'met' if m['rss'] < GOAL_BYTES else 'NOT met'}"
                  f"{' (extrapolated)' if a.minutes != 60 else ''}")  # fmt: skip
            rows.append((fmt, path, m))
            r = measure(stream_cmd(path))
            if r["rc"] != 0:
                print(f"{fmt}: chunk reader failed: {r['err'].strip().splitlines()[-1:]}")
                continue
            mib, per_r = r["rss"] / 2**20, r["rss"] / n
            print(f"{fmt:8s}  chunk reader alone (TraceStream, validation + chunks): peak RSS "
                  f"{mib:8.0f} MiB  wall {r['wall']:7.1f} s  {per_r:6.1f} B/sample")  # fmt: skip
        # bit-identity on a prefix: streamed CLI run (JSON δ) vs in-memory δ̂ on the same file
        pq_pre, csv_pre, n_pre = write_recording(d, a.prefix_minutes, seg)
        for fmt, path in (("parquet", pq_pre), ("csv", csv_pre)):
            if fmt not in formats:
                continue
            ref = in_memory_delta_hat(path)
            out = d / f"prefix-{fmt}.json"
            p = subprocess.run(estimate_cmd(path, out), capture_output=True, text=True)
            if p.returncode != 0:
                print(f"{fmt} prefix: estimate failed: {p.stderr.strip()[-300:]}")
                continue
            got = json.loads(out.read_text())["delta"]
            same = got == float(ref[-1])
            print(f"{fmt} prefix ({n_pre} samples): final δ̂ CLI {got!r} vs in-memory {float(ref[-1])!r}: "
                  f"{'bit-identical' if same else 'DIFFERENT'}")  # fmt: skip
    print(f"load average: {os.getloadavg()}")


if __name__ == "__main__":
    main()
