"""Memory of ``drivelash estimate``, ``observe`` and ``identify`` on a long 8 kHz recording (issue 15).

Writes a recording of ``--minutes`` at 8 kHz (60 min = 28.8 M samples) as Parquet and as
CSV in a temporary directory (in chunks: the writer never holds the recording), runs
``drivelash estimate`` on each in a child and reports its peak RSS
(``resource.getrusage(RUSAGE_CHILDREN).ru_maxrss`` of that child alone: one child per
measurement, each from a fresh helper process), wall time and bytes of RAM per sample.
``estimate`` streams the file (:class:`drivelash.io.stream.TraceStream`, chunks of
``DRIVELASH_CHUNK_ROWS`` rows, default 2**18).

Baseline (named, measured in the same run, on a prefix of ``--prefix-minutes``): the
in-memory path a competent user writes in a notebook — ``drivelash.load_trace`` of the whole
file, then ``estimate_from_config`` (the library call behind ``drivelash.estimate_backlash``)
— in a child, its peak RSS and wall time; then the streamed command on the same prefix,
whose JSON summary must equal the in-memory one key for key and value for value (δ̂ and every
reported number; all but ``generator``, where the command records its name). The prefix
spans many chunks (5 min = 2.4 M samples = 10 chunks of 2**18 rows).

The recording: 60 s of the simulated bench test ``bench-0A`` (0.5 Hz position sine, in
periodic steady state after 10 s), its last 50 s tiled with continued time — the numbers
are a drive's, the content repeats.

``observe`` and ``identify`` (rigid IDIM-LS, and ``--model two-mass``) are measured the same
way (``--commands``): baselines ``load_trace`` + ``observe_disturbance`` / ``identify`` /
``identify_from_config`` (the library calls a notebook user makes), whose figures the streamed
command must reproduce (observe: the JSON figures bit for bit; identify: the parameters bit for
bit, since the library call runs the same pipeline on the whole trace; two-mass: within
``[identification] max_samples`` the same fit, beyond it the command fits a stretch).

Run: ``make bench`` (a 10-minute recording and a 2-minute prefix, to keep ``make bench``
short) or ``.venv/bin/python benchmarks/bench_memory.py --minutes 60 --prefix-minutes 5``
for the acceptance figure. Goal: peak RSS < 1 GiB for 60 min (28.8 M samples), Parquet and CSV.
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


def write_recording(
    dirpath: Path, minutes: float, seg: dict[str, np.ndarray], formats: tuple[str, ...] = ("parquet", "csv")
) -> tuple[Path, Path, int]:
    """Write the recording as Parquet (row groups of 1 M) and/or CSV, 1 M rows at a time;
    returns the two paths (a format not asked for is not written) and the sample count."""
    import pyarrow as pa
    import pyarrow.csv as pcsv
    import pyarrow.parquet as pq

    n = int(round(minutes * 60.0 * RATE_HZ))
    pq_path, csv_path = dirpath / f"rec-{minutes:g}min.parquet", dirpath / f"rec-{minutes:g}min.csv"
    schema = pa.schema([(c, pa.float64()) for c in COLUMNS])
    w = pq.ParquetWriter(pq_path, schema) if "parquet" in formats else None
    fcsv = pa.OSFile(str(csv_path), "wb") if "csv" in formats else None
    cw = pcsv.CSVWriter(fcsv, schema) if fcsv is not None else None
    try:
        for cols in _chunks(seg, n):
            batch = pa.record_batch([pa.array(cols[c]) for c in COLUMNS], schema=schema)
            if w is not None:
                w.write_batch(batch)
            if cw is not None:
                cw.write_batch(batch)
    finally:
        if w is not None:
            w.close()
        if cw is not None:
            cw.close()
        if fcsv is not None:
            fcsv.close()
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


#: The in-memory baseline: the whole recording, then the library call (writes the JSON summary).
_IN_MEMORY = """
import sys
from drivelash.estimation.backlash_api import estimate_from_config
from drivelash.estimation.estimator import INPUT_COLUMNS
from drivelash.io import load_config, load_trace
from drivelash.io.outputs import write_json
cfg = load_config(sys.argv[2])
est = estimate_from_config(load_trace(sys.argv[1], cfg, required=INPUT_COLUMNS), cfg, method=None)
write_json(sys.argv[3], {"trace": sys.argv[1], "config": sys.argv[2], **est.summary})
"""


def in_memory_cmd(path: Path, json_out: Path) -> list[str]:
    return [sys.executable, "-c", _IN_MEMORY, str(path), str(CONFIG), str(json_out)]


def observe_cmd(path: Path, json_out: Path) -> list[str]:
    return [*estimate_cmd(path, json_out)[:3], "observe", *estimate_cmd(path, json_out)[4:]]


def identify_cmd(path: Path, json_out: Path, model: str = "rigid") -> list[str]:
    toml = json_out.with_suffix(".toml")
    return [*estimate_cmd(path, json_out)[:3], "identify", *estimate_cmd(path, json_out)[4:],
            "--model", model, "-o", str(toml)]  # fmt: skip


#: In-memory baselines of observe / identify: the whole recording, then the library call; the
#: figures the command must reproduce go into the JSON.
_IN_MEMORY_OFFLINE = """
import sys
from drivelash.io import load_config, load_trace
from drivelash.io.outputs import write_json
cmd, path, cfgp, out = sys.argv[1:5]
cfg = load_config(cfgp)
if cmd == "observe":
    from drivelash.estimation.identify import observe_disturbance
    tr = load_trace(path, cfg, required=["torque_m"])
    d = cfg.drivetrain
    res = observe_disturbance(tr, J=d.J_m, beta=d.beta_m)
    write_json(out, res.as_dict())
elif cmd == "identify":
    from drivelash.estimation.identify import identify
    tr = load_trace(path, cfg, required=["theta_m", "torque_m"])
    write_json(out, identify(tr, cfg.identification_or_default(), cfg.drivetrain).as_dict())
else:
    from drivelash.estimation.identify_two_mass import identify_from_config
    tr = load_trace(path, cfg, required=["theta_m", "theta_l", "torque_m"])
    write_json(out, identify_from_config(tr, cfg, model="two-mass").as_dict())
"""

#: command name → (streamed command, baseline argument)
COMMANDS = {
    "estimate": (estimate_cmd, None),
    "observe": (observe_cmd, "observe"),
    "identify": (identify_cmd, "identify"),
    "identify-two-mass": (lambda p, j: identify_cmd(p, j, "two-mass"), "two-mass"),
}


def baseline_cmd(command: str, path: Path, json_out: Path) -> list[str]:
    """The named in-memory baseline of ``command`` (see the module docstring)."""
    if command == "estimate":
        return in_memory_cmd(path, json_out)
    arg = COMMANDS[command][1]
    return [sys.executable, "-c", _IN_MEMORY_OFFLINE, str(arg), str(path), str(CONFIG), str(json_out)]


def same_figures(command: str, ref_j: Path, got_j: Path) -> tuple[bool, str]:
    """Whether the streamed command's JSON reproduces the baseline's figures, and a note."""
    if command == "estimate":
        # every key and value identical, in the same order, except "generator": the command
        # records its name there ("drivelash X.Y estimate"), the library call does not
        got, ref = json.loads(got_j.read_text()), json.loads(ref_j.read_text())
        got.pop("generator", None)
        ref.pop("generator", None)
        same = list(got.items()) == list(ref.items())
        return same, f"JSON identical but for 'generator': {same} (δ̂ {got['delta']!r} vs {ref['delta']!r})"
    ref, got = json.loads(ref_j.read_text()), json.loads(got_j.read_text())
    if "window" in got:  # longer than [identification] max_samples: the command fits a stretch
        w = got["window"]
        rev = f"{w['reversals']} of {w['reversals_in_recording']} reversals"
        return True, f"the command fitted samples {w['first_sample']}+{w['samples']} ({rev}); not compared"
    keys = [k for k in ref if k != "generator"]
    same = all(got.get(k) == ref[k] for k in keys)
    return same, f"{len(keys)} JSON figures equal the baseline's: {same}"


def _row(label: str, m: dict, n: int) -> str:
    return (
        f"{label:34s} peak RSS {m['rss'] / 2**20:7.0f} MiB  wall {m['wall']:7.1f} s  "
        f"{m['rss'] / n:7.1f} B/sample"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=10.0, help="Length of the long recording [min].")
    ap.add_argument("--prefix-minutes", type=float, default=2.0, help="Prefix, bit-identity [min].")
    ap.add_argument("--formats", default="parquet,csv")
    ap.add_argument("--commands", default=",".join(COMMANDS), help="Commands to measure.")
    ap.add_argument("--dir", type=Path, default=None, help="Work directory (default: a temporary one).")
    a = ap.parse_args()
    formats = tuple(a.formats.split(","))
    commands = [c for c in a.commands.split(",") if c]
    failed = False
    with tempfile.TemporaryDirectory(dir=a.dir) as tmp:
        d = Path(tmp)
        seg, _ = _tile(max(a.minutes, a.prefix_minutes))
        # the prefix first: baseline and identity of the figures
        pq_pre, csv_pre, n_pre = write_recording(d, a.prefix_minutes, seg, formats)
        print(f"prefix: {n_pre} samples ({a.prefix_minutes:g} min at 8 kHz), {len(COLUMNS)} columns")
        for fmt, path in (("parquet", pq_pre), ("csv", csv_pre)):
            if fmt not in formats:
                continue
            for cmd in commands:
                ref_j, got_j = d / f"prefix-{fmt}-{cmd}-mem.json", d / f"prefix-{fmt}-{cmd}-stream.json"
                base = measure(baseline_cmd(cmd, path, ref_j))
                m = measure(COMMANDS[cmd][0](path, got_j))
                if base["rc"] != 0 or m["rc"] != 0:
                    print(f"{fmt} prefix {cmd}: failed: {(base['err'] or m['err']).strip()[-300:]}")
                    failed = True
                    continue
                print(_row(f"{fmt} prefix, {cmd} in-memory (baseline)", base, n_pre))
                print(_row(f"{fmt} prefix, drivelash {cmd}", m, n_pre)
                      + f"  {m['rss'] / base['rss']:.2f}× baseline RSS,"
                      + f" {m['wall'] / base['wall']:.2f}× its wall")  # fmt: skip
                same, note = same_figures(cmd, ref_j, got_j)
                print(f"{fmt} prefix {cmd}: streamed vs in-memory: {note}")
                failed |= not same
            path.unlink()
        if a.minutes <= 0:
            print(f"load average: {os.getloadavg()}")
            sys.exit(1 if failed else 0)
        # the long recording
        t0 = time.perf_counter()
        pq_path, csv_path, n = write_recording(d, a.minutes, seg, formats)
        took = time.perf_counter() - t0
        print(f"recording: {n} samples ({a.minutes:g} min at 8 kHz), written in {took:.0f} s")
        for fmt, path in (("parquet", pq_path), ("csv", csv_path)):
            if fmt not in formats:
                continue
            for cmd in commands:
                m = measure(COMMANDS[cmd][0](path, d / f"{fmt}-{cmd}.json"))
                if m["rc"] != 0:
                    print(f"{fmt}: {cmd} failed (exit {m['rc']}): {m['err'].strip().splitlines()[-1:]}")
                    failed = True
                    continue
                size = path.stat().st_size
                met = "met" if m["rss"] < GOAL_BYTES else "NOT met"
                print(_row(f"{fmt}, drivelash {cmd}", m, n)
                      + f"  file {size / 2**20:.0f} MiB  goal < 1 GiB: {met}"
                      + ("" if a.minutes == 60 else f" (at {a.minutes:g} min, not 60)"))  # fmt: skip
            path.unlink()
    print(f"load average: {os.getloadavg()}")
    if failed:
        sys.exit(1)


if __name__ == "__main__":
    main()
