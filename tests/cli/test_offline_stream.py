"""``drivelash observe`` and ``drivelash identify`` stream the recording (issue 15, item 5).

The references are computed independently of the streamed code: ``scipy.signal.filtfilt``
and ``np.gradient`` over the whole signal, the STSMO over the whole signal, numpy means —
what ``observe_disturbance`` computed before it streamed. The chunk size is made small
(``DRIVELASH_CHUNK_ROWS``) so that the recording spans many chunks.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy import signal
from tests.cli_runner import run_in_process

from drivelash.estimation.identify import DEFAULT_RHO, observe_disturbance
from drivelash.estimation.stsmo import STSMOParams, SuperTwistingObserver
from drivelash.io import load_config, load_trace
from drivelash.io.formats import write_trace
from drivelash.io.trace import Trace

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "examples" / "drive_bench.toml"
CHUNK = 4999  # rows: 40 000 samples → 9 chunks
EXTS = ("parquet", "csv", "h5")


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> dict[str, Path]:
    """5 s of bench-0B at 8 kHz (40 000 samples), without the velocity columns (so the
    observer differentiates the position through the zero-phase filter), in three formats."""
    from drivelash.sim.scenarios import get_scenario

    tr = get_scenario("bench-0B").simulate(duration=5.0, seed=2)
    tr = tr.select(["t", "theta_m", "theta_l", "torque_m"])
    d = tmp_path_factory.mktemp("offline")
    return {ext: write_trace(tr, d / f"b0b.{ext}") for ext in EXTS}


def _reference_observer(trace: Trace, J: float, beta: float) -> tuple[np.ndarray, np.ndarray, float, float]:
    """The whole-array observer (the pre-streaming code): filtfilt, np.gradient, STSMO."""
    T_s = trace.T_s
    b, a = signal.butter(4, 100.0 / (0.5 / T_s))
    v = np.gradient(signal.filtfilt(b, a, trace["theta_m"]), T_s, edge_order=1)
    p = STSMOParams.from_rho(DEFAULT_RHO, T_s)
    obs = SuperTwistingObserver(STSMOParams(k1=p.k1, k2=p.k2, T_s=T_s), omega0=float(v[0]))
    _, phi = obs.run(v, (trace["torque_m"] - beta * v) / J)
    d = -J * phi
    acc = np.gradient(v, T_s, edge_order=1)
    cv = (np.abs(acc) < 0.05 * np.abs(acc).max()) & (np.abs(v) > 0.2 * np.abs(v).max())
    cv[: min(len(trace) // 10, int(round(0.5 / T_s)))] = False
    return v, d, float(d[cv & (v > 0)].mean()), float(d[cv & (v < 0)].mean())


def _observe(path: Path, tmp: Path, capsys, out_ext: str = "parquet") -> tuple[str, Trace]:
    out, js = tmp / f"obs.{out_ext}", tmp / "obs.json"
    code, _, err = run_in_process(
        ["observe", str(path), "--config", str(CONFIG), "--json", str(js), "-o", str(out), "--force"], capsys
    )
    assert code == 0, err
    return js.read_text(), load_trace(out)


@pytest.mark.parametrize("ext", EXTS)
def test_observe_streamed_equals_whole_signal(recording, ext, tmp_path, monkeypatch, capsys):
    """Velocity and d̂ bit for bit against filtfilt/np.gradient/STSMO over the whole signal;
    the means to 1e-15 (the streamed sum is blockwise; here it is equal)."""
    monkeypatch.setenv("DRIVELASH_CHUNK_ROWS", str(CHUNK))
    cfg = load_config(CONFIG)
    J, beta = cfg.drivetrain.J_m, cfg.drivetrain.beta_m
    text, out = _observe(recording[ext], tmp_path, capsys)
    whole = load_trace(recording[ext], cfg)
    v, d, m_pos, m_neg = _reference_observer(whole, J, beta)
    assert len(out) == len(whole) > 8 * CHUNK
    assert np.array_equal(out["velocity"], v)
    assert np.array_equal(out["disturbance"], d)
    assert np.array_equal(out["t"], whole["t"])
    s = json.loads(text)
    assert s["mean_disturbance_forward"] == pytest.approx(m_pos, rel=1e-15, abs=0)
    assert s["mean_disturbance_backward"] == pytest.approx(m_neg, rel=1e-15, abs=0)
    assert s["constant_velocity_samples"] > 1000
    # the notebook API (whole trace in memory) gives the same JSON figures
    api = observe_disturbance(whole, J=J, beta=beta).as_dict()
    assert {k: s[k] for k in api} == api
    # one chunk (the default size) and many chunks: the same JSON, byte for byte
    monkeypatch.delenv("DRIVELASH_CHUNK_ROWS")
    (tmp_path / "one").mkdir()
    text1, out1 = _observe(recording[ext], tmp_path / "one", capsys)
    assert text1 == text
    assert np.array_equal(out1["disturbance"], out["disturbance"])


def test_observe_negative_control_one_sample(recording, tmp_path, monkeypatch, capsys):
    """The comparison is sensitive: one torque sample moved by 1e-9 N·m changes d̂ and the JSON."""
    monkeypatch.setenv("DRIVELASH_CHUNK_ROWS", str(CHUNK))
    tr = load_trace(recording["parquet"])
    u = tr["torque_m"].copy()
    u[20000] += 1e-9
    bad = write_trace(tr.with_columns({"torque_m": u}), tmp_path / "bad.parquet")
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    text_a, out_a = _observe(recording["parquet"], tmp_path / "a", capsys)
    text_b, out_b = _observe(bad, tmp_path / "b", capsys)
    assert not np.array_equal(out_a["disturbance"], out_b["disturbance"])
    ja, jb = json.loads(text_a), json.loads(text_b)
    assert ja["mean_disturbance_forward"] != jb["mean_disturbance_forward"] or (
        ja["mean_disturbance_backward"] != jb["mean_disturbance_backward"]
    )


def test_observe_spill_removed_and_output_untouched_on_error(recording, tmp_path, monkeypatch, capsys):
    """SIGTERM while the output is written (after the spill files are made) leaves no spill
    file and no output."""
    import drivelash.io.formats as formats
    from drivelash.cli import Terminated

    monkeypatch.setenv("DRIVELASH_CHUNK_ROWS", str(CHUNK))
    monkeypatch.setenv("DRIVELASH_SPILL_DIR", str(tmp_path))

    def boom(*a, **k):
        raise Terminated

    monkeypatch.setattr(formats.TraceWriter, "write", boom)
    out = tmp_path / "obs.parquet"
    code, _, err = run_in_process(
        ["observe", str(recording["parquet"]), "--config", str(CONFIG), "-o", str(out)], capsys
    )
    assert code == 143, err
    assert not out.exists()
    assert [p.name for p in tmp_path.iterdir()] == []


@pytest.mark.parametrize("ext", ["csv", "parquet", "h5", "mat"])
def test_trace_writer_in_chunks_equals_write_trace(ext, tmp_path):
    """The chunked writer of `observe -o` writes what write_trace writes (CSV byte for byte)."""
    from drivelash.io.formats import TraceWriter

    n = 10007
    rng = np.random.default_rng(3)
    tr = Trace(
        {"t": np.arange(n) / 8000.0, "velocity": rng.normal(size=n), "d": rng.normal(size=n)}, {"a": 1}
    )
    a, b = write_trace(tr, tmp_path / f"a.{ext}"), tmp_path / f"b.{ext}"
    with TraceWriter(b, tr.names, n, tr.meta) as w:
        for s in range(0, n, 999):
            w.write({c: tr[c][s : s + 999] for c in tr.names})
    ta, tb = load_trace(a), load_trace(b)
    assert ta.names == tb.names and all(np.array_equal(ta[c], tb[c]) for c in ta.names)
    assert {k: v for k, v in ta.meta.items() if k != "source"} == {
        k: v for k, v in tb.meta.items() if k != "source"
    }
    if ext == "csv":
        assert a.read_bytes() == b.read_bytes()
