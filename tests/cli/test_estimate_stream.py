"""``drivelash estimate`` streams the recording (issue 15, item 5): same JSON, bounded memory.

The command reads the file in chunks (:class:`drivelash.io.stream.TraceStream`) and runs the
estimator over them; the reference is the in-memory path a notebook user takes,
:func:`drivelash.estimation.backlash_api.estimate_from_config` on :func:`drivelash.load_trace`
(whole trace, the estimator's own 65 536-row blocks). The chunk size is made small
(``DRIVELASH_CHUNK_ROWS``) so that the recording spans many chunks and the chunk borders
fall elsewhere than the in-memory blocks'.
"""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest
from tests.cli_runner import run_in_process

from drivelash.errors import ResourceError
from drivelash.estimation.backlash_api import estimate_from_config
from drivelash.estimation.estimator import INPUT_COLUMNS
from drivelash.io import load_config, load_trace
from drivelash.io.formats import write_trace
from drivelash.io.outputs import Outputs, write_json
from drivelash.io.trace import Trace

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "examples" / "drive_bench.toml"
CHUNK = 4999  # rows: 96 000 samples → 20 chunks, borders off the in-memory 65 536-row blocks
GIB = 1 << 30


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> dict[str, Path]:
    """12 s of bench-0B at 8 kHz with the true δ (96 000 samples), as Parquet, CSV and HDF5."""
    from drivelash.sim.scenarios import get_scenario

    tr = get_scenario("bench-0B").simulate(duration=12.0, seed=1)
    d = tmp_path_factory.mktemp("stream")
    return {ext: write_trace(tr, d / f"b0b.{ext}") for ext in ("parquet", "csv", "h5")}


def _in_memory_json(path: Path, out: Path) -> str:
    cfg = load_config(CONFIG)
    est = estimate_from_config(load_trace(path, cfg, required=INPUT_COLUMNS), cfg, method=None)
    with Outputs("estimate", force=True) as o:  # the command's signature, as the CLI writes it
        write_json(
            o.staging(o.file(out, option="--json")),
            {"trace": str(path), "config": str(CONFIG), **est.summary},
        )
    return out.read_text()


def _streamed_json(path: Path, out: Path, capsys) -> str:
    code, _, err = run_in_process(
        ["estimate", str(path), "--config", str(CONFIG), "--json", str(out), "--force"], capsys
    )
    assert code == 0, err
    return out.read_text()


@pytest.mark.parametrize("ext", ["parquet", "csv", "h5"])
def test_streamed_json_equals_in_memory_bit_for_bit(recording, ext, tmp_path, monkeypatch, capsys):
    """Every number of the JSON (δ̂, verdict, δ1 check, Δθ range, traversals, gains, MAEE, …)."""
    monkeypatch.setenv("DRIVELASH_CHUNK_ROWS", str(CHUNK))
    path = recording[ext]
    got = _streamed_json(path, tmp_path / "s.json", capsys)
    ref = _in_memory_json(path, tmp_path / "m.json")
    assert got == ref
    s = json.loads(got)
    assert s["samples"] == 96000 and s["samples"] > 10 * CHUNK
    # the summary carries the figures computed while streaming, not placeholders
    assert s["maee_rad"] is not None and 0 < s["maee_rad"] < 1e-3
    assert s["converged"] and abs(s["delta"] - s["delta_true"]) < 1e-3
    assert s["traversals"] >= 2 and s["dtheta_range"] > s["delta"]


def test_negative_control_one_sample_changes_the_json(recording, tmp_path, monkeypatch, capsys):
    """The comparison above is sensitive: one sample of θ_l moved by 1 nrad (a thousandth of
    an encoder count) changes the JSON."""
    monkeypatch.setenv("DRIVELASH_CHUNK_ROWS", str(CHUNK))
    tr = load_trace(recording["parquet"])
    cols = dict(tr.columns)
    th = cols["theta_l"].copy()
    k = 90000  # in the last third, where the verdict's statistics are accumulated
    th[k] += 1e-9
    cols["theta_l"] = th
    p = write_trace(Trace(cols, meta=tr.meta), tmp_path / "ulp.parquet")
    got = json.loads(_streamed_json(p, tmp_path / "s.json", capsys))
    ref = json.loads(_in_memory_json(recording["parquet"], tmp_path / "m.json"))
    del got["trace"], ref["trace"]
    assert got != ref
    assert got["samples"] == ref["samples"]


def test_decimated_plot_and_report_are_written(recording, tmp_path, monkeypatch, capsys):
    """--plot and --report from the streamed run's decimated series (and the decimated recording)."""
    monkeypatch.setenv("DRIVELASH_CHUNK_ROWS", str(CHUNK))
    png, html = tmp_path / "e.png", tmp_path / "e.html"
    code, _, err = run_in_process(
        ["estimate", str(recording["parquet"]), "-c", str(CONFIG), "--plot", str(png), "--report", str(html)],
        capsys,
    )
    assert code == 0, err
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000
    text = html.read_text()
    assert "data:image/png;base64," in text
    # the report states δ̂ with its 95 % interval, the one the JSON gives (δ̂ ± 1.96 delta_std) ...
    js = json.loads(_streamed_json(recording["parquet"], tmp_path / "e.json", capsys))
    lo, hi = 1e3 * (js["delta"] - 1.96 * js["delta_std"]), 1e3 * (js["delta"] + 1.96 * js["delta_std"])
    assert f"[{lo:.3f}, {hi:.3f}]" in text
    assert f"<td>{1e3 * js['delta']:.6g}</td>" in text  # the JSON's δ̂
    # ... and keeps the estimator's raw statistics apart, with their units named
    assert "Estimator diagnostics (the JSON&#x27;s extra), SI units" in text  # HTML-escaped quote


def test_streamed_series_keep_the_recorded_torque(recording):
    """The decimated series behind --plot/--report carry the motor torque when the recording has
    it (the report's overview drew positions and velocities only, though the law used the torque)."""
    from drivelash.estimation.pipeline import estimate_stream
    from drivelash.io.stream import TraceStream

    cfg = load_config(CONFIG)
    with TraceStream(recording["parquet"], cfg, required=INPUT_COLUMNS, chunk_rows=CHUNK) as stream:
        core, res, series = estimate_stream(cfg, stream, None, series=True)
    assert "torque_m" in series and series["torque_m"].size == series["t"].size > 100
    full = load_trace(recording["parquet"], cfg, required=INPUT_COLUMNS)
    idx = np.searchsorted(full["t"], series["t"])
    assert np.array_equal(series["torque_m"], full["torque_m"][idx])  # decimated, not altered


def test_long_file_streams_within_a_budget_that_refuses_whole_reads(recording, tmp_path, monkeypatch, capsys):
    """The memory guard budgets the streamed path: a recording whose whole read is refused
    (negative control: ``load_trace`` raises) is estimated in chunks under the same budget."""
    tr = load_trace(recording["parquet"])
    n, reps = len(tr), 4
    # the recording forward, backward (time-reversed: positions continuous, velocities negated),
    # forward, backward: tiled copies would be joined recordings, which the loader refuses (B5)
    back = {c: (-v[::-1] if c.startswith("omega") else v[::-1]) for c, v in tr.columns.items()}
    cols = {c: np.concatenate([v, back[c]] * (reps // 2)) for c, v in tr.columns.items() if c != "t"}
    cols["t"] = np.arange(n * reps) * 125e-6
    p = write_trace(Trace(cols), tmp_path / "long.parquet")  # 384 000 samples × 10 columns
    monkeypatch.setenv("DRIVELASH_MEMORY_BUDGET", "150M")  # whole read: ≈ 245 MB planned
    monkeypatch.setenv("DRIVELASH_CHUNK_ROWS", "20000")
    with pytest.raises(ResourceError, match="would need about"):
        load_trace(p)
    code, _, err = run_in_process(
        ["estimate", str(p), "--config", str(CONFIG), "--json", str(tmp_path / "l.json")], capsys
    )
    assert code == 0, err
    assert json.loads((tmp_path / "l.json").read_text())["samples"] == n * reps
    monkeypatch.setenv("DRIVELASH_MEMORY_BUDGET", "20M")  # below the chunk buffers: refused, one line
    code, _, err = run_in_process(["estimate", str(p), "--config", str(CONFIG)], capsys)
    assert code == 2 and "DRIVELASH_CHUNK_ROWS" in err and len(err.strip().splitlines()) == 1


def test_bad_chunk_rows_is_one_line(recording, monkeypatch, capsys):
    monkeypatch.setenv("DRIVELASH_CHUNK_ROWS", "many")
    code, _, err = run_in_process(["estimate", str(recording["parquet"]), "--config", str(CONFIG)], capsys)
    assert code == 2 and "DRIVELASH_CHUNK_ROWS='many'" in err and len(err.strip().splitlines()) == 1


# --------------------------------------------------------------------------- peak RSS (slow)
def _bench_memory():
    spec = importlib.util.spec_from_file_location("bench_memory", ROOT / "benchmarks" / "bench_memory.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["parquet", "csv"])
def test_one_hour_8khz_estimate_peak_rss_below_1_gib(fmt, tmp_path):
    """Acceptance (issue 15): a 1-hour 8 kHz recording (28.8 M samples), peak RSS < 1 GiB.

    The recording is written in chunks (benchmarks/bench_memory.py); ``drivelash estimate``
    runs in a child whose peak RSS is ``getrusage(RUSAGE_CHILDREN).ru_maxrss`` of a helper
    with no other child.
    """
    bm = _bench_memory()
    seg, _ = bm._tile(60.0)
    pq_path, csv_path, n = bm.write_recording(tmp_path, 60.0, seg, formats=(fmt,))
    path = pq_path if fmt == "parquet" else csv_path
    try:
        m = bm.measure(bm.estimate_cmd(path, tmp_path / "e.json"))
    finally:
        path.unlink()  # 0.8 GB (Parquet) / 3 GB (CSV): pytest keeps its last three temp dirs
    assert m["rc"] == 0, m["err"]
    assert n == 28_800_000
    assert json.loads((tmp_path / "e.json").read_text())["samples"] == n
    assert m["rss"] < GIB, f"peak RSS {m['rss'] / 2**20:.0f} MiB"


def test_rss_helper_measures_the_child(tmp_path):
    """The RSS measurement used above sees a child that allocates 300 MiB (negative control: 0)."""
    bm = _bench_memory()
    big = bm.measure([sys.executable, "-c", "import numpy as np; a = np.ones(300 * 2**17); print(a.sum())"])
    small = bm.measure([sys.executable, "-c", "pass"])
    assert big["rc"] == 0 and small["rc"] == 0
    assert big["rss"] > 300 * 2**20 > small["rss"]
