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
from tests.cli.test_estimate_stream import GIB, _bench_memory
from tests.cli_runner import run_in_process

from drivelash.estimation.identify import default_rho, observe_disturbance
from drivelash.estimation.stsmo import STSMOParams, SuperTwistingObserver
from drivelash.io import load_config, load_trace
from drivelash.io.formats import write_trace
from drivelash.io.outputs import jsonable
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
    p = STSMOParams.from_rho(default_rho(float(np.abs(v).max())), T_s)
    obs = SuperTwistingObserver(STSMOParams(k1=p.k1, k2=p.k2, T_s=T_s), omega0=float(v[0]))
    _, phi = obs.run(v, (trace["torque_m"] - beta * v) / J)
    d = -J * phi
    acc = np.gradient(v, T_s, edge_order=1)
    cv = (np.abs(acc) < 0.05 * np.abs(acc).max()) & (np.abs(v) > 0.2 * np.abs(v).max())
    cv[: min(len(trace) // 10, int(round(0.5 / T_s)))] = False
    return v, d, float(d[cv & (v > 0)].mean()), float(d[cv & (v < 0)].mean())


def _perturbed(path: Path, tmp: Path, du: float) -> Path:
    """The recording with torque sample 20 000 moved by ``du`` [N·m] (and run dirs a/, b/)."""
    tr = load_trace(path)
    u = tr["torque_m"].copy()
    u[20000] += du
    (tmp / "a").mkdir()
    (tmp / "b").mkdir()
    return write_trace(tr.with_columns({"torque_m": u}), tmp / "bad.parquet")


def _observe(path: Path, tmp: Path, capsys, out_ext: str = "parquet") -> tuple[str, Trace]:
    out, js = tmp / f"obs.{out_ext}", tmp / "obs.json"
    code, _, err = run_in_process(
        ["observe", str(path), "--config", str(CONFIG), "--json", str(js), "-o", str(out), "--force"], capsys
    )
    assert code == 0, err
    return js.read_text(), load_trace(out)


@pytest.mark.parametrize("ext", EXTS)
def test_observe_streamed_equals_whole_signal(recording, ext, tmp_path, monkeypatch, capsys):
    """Velocity, d̂ and the means bit for bit against filtfilt/np.gradient/STSMO/np.mean over
    the whole signal."""
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
    assert s["mean_disturbance_forward"] == m_pos
    assert s["mean_disturbance_backward"] == m_neg
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


def test_observe_report_same_from_many_chunks(recording, tmp_path, monkeypatch, capsys):
    """--report from a run over many chunks is the report of one chunk, byte for byte (the
    thinned series are taken at the same sample indices)."""
    html = []
    for rows in (str(CHUNK), None):
        if rows is None:
            monkeypatch.delenv("DRIVELASH_CHUNK_ROWS")
        else:
            monkeypatch.setenv("DRIVELASH_CHUNK_ROWS", rows)
        out = tmp_path / f"o{len(html)}.html"
        code, _, err = run_in_process(
            ["observe", str(recording["parquet"]), "-c", str(CONFIG), "--report", str(out)], capsys
        )
        assert code == 0, err
        html.append(out.read_bytes())
    assert html[0] == html[1] and b"data:image/png;base64," in html[0]
    # the summary names what each figure is and its unit (rotary axis: kg·m², N·m·s/rad, N·m)
    text = html[0].decode()
    for label in (
        "J, inertia assumed [kg·m²]",
        "β, viscous friction assumed [N·m·s/rad]",
        "mean d̂, forward constant-velocity stretches [N·m]",
    ):
        assert label in text, label


def test_observe_negative_control_one_sample(recording, tmp_path, monkeypatch, capsys):
    """The comparison is sensitive: one torque sample moved by 1e-9 N·m changes d̂ and the JSON."""
    monkeypatch.setenv("DRIVELASH_CHUNK_ROWS", str(CHUNK))
    bad = _perturbed(recording["parquet"], tmp_path, 1e-9)
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


def _reference_rigid(trace: Trace) -> tuple[np.ndarray, int]:
    """IDIM-LS as written before streaming: filtfilt, np.gradient twice, border cut,
    scipy.signal.decimate of every column, numpy lstsq (SVD)."""
    T_s = trace.T_s
    b, a = signal.butter(4, 100.0 / (0.5 / T_s))
    dq = np.gradient(signal.filtfilt(b, a, trace["theta_m"]), T_s, edge_order=1)
    ddq = np.gradient(dq, T_s, edge_order=1)
    sl = slice(50, len(trace) - 50)
    W = np.column_stack([ddq[sl], dq[sl], np.sign(dq[sl]), np.ones(len(trace))[sl]])
    Wd = np.column_stack([signal.decimate(W[:, j], 10, ftype="iir", zero_phase=True) for j in range(4)])
    yd = signal.decimate(trace["torque_m"][sl], 10, ftype="iir", zero_phase=True)
    theta, *_ = np.linalg.lstsq(Wd, yd, rcond=None)
    return theta, yd.size


def _identify(path: Path, tmp: Path, capsys) -> dict:
    js = tmp / "id.json"
    code, _, err = run_in_process(
        [
            "identify",
            str(path),
            "--config",
            str(CONFIG),
            "--model",  # the recording maps theta_l and the config gives N: the default is two-mass
            "rigid",
            "--json",
            str(js),
            "-o",
            str(tmp / "d.toml"),
            "--force",
        ],
        capsys,
    )
    assert code == 0, err
    return json.loads(js.read_text())


@pytest.mark.parametrize("ext", EXTS)
def test_identify_rigid_streamed_equals_whole_signal(recording, ext, tmp_path, monkeypatch, capsys):
    """The streamed command equals the in-memory API bit for bit (one pipeline, fixed QR
    blocks), and the pre-streaming least squares (SVD) to 1e-10 relative."""
    from drivelash.estimation.identify import identify

    monkeypatch.setenv("DRIVELASH_CHUNK_ROWS", str(CHUNK))
    s = _identify(recording[ext], tmp_path, capsys)
    cfg = load_config(CONFIG)
    whole = load_trace(recording[ext], cfg)
    api = identify(whole, cfg.identification_or_default(), cfg.drivetrain)
    for k, v in api.as_dict().items():
        assert s[k] == v, k
    theta_ref, rows = _reference_rigid(whole)
    assert s["n_rows"] == rows > 3000
    got = np.array([s["parameters"][n]["value"] for n in ("M", "F_v", "F_c", "offset")])
    np.testing.assert_allclose(got, theta_ref, rtol=1e-10, atol=0)
    # the observer that follows the identification streams too (same figures as the API)
    obs = observe_disturbance(whole, J=api["M"], beta=api["F_v"]).as_dict()
    assert {k: s["observer"][k] for k in obs} == obs


def test_identify_negative_control_one_sample(recording, tmp_path, monkeypatch, capsys):
    """One torque sample moved by 1e-6 N·m changes the identified values."""
    monkeypatch.setenv("DRIVELASH_CHUNK_ROWS", str(CHUNK))
    bad = _perturbed(recording["parquet"], tmp_path, 1e-6)
    a = _identify(recording["parquet"], tmp_path / "a", capsys)
    b = _identify(bad, tmp_path / "b", capsys)
    assert a["parameters"]["F_c"]["value"] != b["parameters"]["F_c"]["value"]


# ------------------------------------------------------------------ two-mass: the fitted stretch
STILL = 16000  # samples of standstill before the motion (2 s at 8 kHz)


@pytest.fixture(scope="module")
def two_mass_recording(tmp_path_factory) -> dict[str, Path]:
    """6 s of bench-0B (48 000 samples, with velocities), and the same after 2 s of standstill."""
    from drivelash.sim.scenarios import get_scenario

    tr = get_scenario("bench-0B").simulate(duration=6.0, seed=2)
    tr = tr.select(["t", "theta_m", "omega_m", "theta_l", "omega_l", "torque_m"])
    still = {c: np.full(STILL, tr[c][0]) for c in tr.names}
    still["omega_m"][:] = still["omega_l"][:] = still["torque_m"][:] = 0.0
    cols = {c: np.concatenate([still[c], tr[c]]) for c in tr.names}
    cols["t"] = np.arange(STILL + len(tr)) * tr.T_s
    d = tmp_path_factory.mktemp("two_mass")
    out = {ext: write_trace(tr, d / f"move.{ext}") for ext in EXTS}
    out.update({f"still.{ext}": write_trace(Trace(cols, tr.meta), d / f"still.{ext}") for ext in EXTS})
    return out


def _two_mass_config(tmp: Path, max_samples: int) -> Path:
    p = tmp / "tm.toml"
    p.write_text(
        CONFIG.read_text() + f'\n[identification]\nmodel = "two-mass"\nmax_samples = {max_samples}\n',
        encoding="utf-8",
    )
    return p


def _identify_two_mass(path: Path, cfg: Path, tmp: Path, capsys) -> dict:
    js = tmp / "tm.json"
    code, _, err = run_in_process(["identify", str(path), "--config", str(cfg), "--json", str(js)], capsys)
    assert code == 0, err
    return json.loads(js.read_text())


def _values(d: dict) -> dict:
    return {k: (p["value"], p["ci95"]) for k, p in d["parameters"].items()}


@pytest.mark.parametrize("ext", EXTS)
def test_two_mass_within_budget_unchanged(two_mass_recording, ext, tmp_path, monkeypatch, capsys):
    """A recording within [identification] max_samples is fitted whole: the streamed read
    gives the numbers of the whole-file path (load_trace + identify_from_config) exactly."""
    from drivelash.estimation.identify_two_mass import identify_from_config

    monkeypatch.setenv("DRIVELASH_CHUNK_ROWS", str(CHUNK))
    cfg = _two_mass_config(tmp_path, 480_000)
    s = _identify_two_mass(two_mass_recording[ext], cfg, tmp_path, capsys)
    conf = load_config(cfg)
    ref = identify_from_config(load_trace(two_mass_recording[ext], conf), conf, model="two-mass").as_dict()
    assert "window" not in s
    for k, v in ref.items():
        assert s[k] == v, k


@pytest.mark.parametrize("ext", EXTS)
def test_two_mass_longer_than_budget_fits_the_moving_stretch(
    two_mass_recording, ext, tmp_path, monkeypatch, capsys
):
    """Over the budget, the stretch with the most reversals is fitted (not the standstill at
    the start, where the fit has nothing to fit: the negative control), the JSON says which,
    and the numbers equal a whole-trace fit of exactly that stretch."""
    from drivelash.estimation.identify_two_mass import identify_from_config, reversal_blocks

    monkeypatch.setenv("DRIVELASH_CHUNK_ROWS", str(CHUNK))
    L = 24000
    cfg = _two_mass_config(tmp_path, L)
    path = two_mass_recording[f"still.{ext}"]
    s = _identify_two_mass(path, cfg, tmp_path, capsys)
    w = s["window"]
    whole = load_trace(path, load_config(cfg))
    first = w["first_sample"]
    assert w["samples"] == L and w["recording_samples"] == len(whole) == STILL + 48000
    assert first >= STILL - 80  # the window lies in the motion
    # independent count: reversals of the 10 ms block velocity in every candidate stretch
    B = 80
    rev, moving = reversal_blocks(whole["theta_m"][::B], B, whole.T_s)
    ks = range(0, (len(whole) - L) // B + 1)
    counts = [int(((rev >= k) & (rev < k + L // B)).sum()) for k in ks]
    moved = [int(moving[k : k + L // B].sum()) for k in ks]
    assert w["reversals"] == max(counts) == counts[first // B] >= 2
    best = [k for k in ks if counts[k] == max(counts)]
    assert first // B == max(best, key=lambda k: (moved[k], -k))
    conf = load_config(cfg)
    ref = identify_from_config(whole.slice(first, first + L), conf, model="two-mass").as_dict()
    assert _values(s) == _values(jsonable(ref))  # as the JSON writes it (NaN, ±inf → null)
    # negative control: the first samples (what a naive cut would fit) stand still
    with pytest.raises(Exception, match="moving windows"):
        identify_from_config(whole.slice(0, STILL), conf, model="two-mass")


# --------------------------------------------------------------------------- peak RSS (slow)
@pytest.fixture(scope="module", params=["parquet", "csv"])
def one_hour(request, tmp_path_factory):
    """A 1-hour 8 kHz recording (28.8 M samples) written in chunks (benchmarks/bench_memory.py)."""
    bm = _bench_memory()
    seg, _ = bm._tile(60.0)
    d = tmp_path_factory.mktemp(f"hour-{request.param}")
    pq_path, csv_path, n = bm.write_recording(d, 60.0, seg, formats=(request.param,))
    path = pq_path if request.param == "parquet" else csv_path
    yield path, n
    path.unlink()


@pytest.mark.slow
@pytest.mark.parametrize("command", ["observe", "identify", "identify-two-mass"])
def test_one_hour_8khz_offline_peak_rss_below_1_gib(one_hour, command, tmp_path):
    """Acceptance (issue 15 item 5): ``observe`` and ``identify`` (rigid, two-mass) on a 1-hour
    8 kHz recording, peak RSS < 1 GiB (the child's ``ru_maxrss``, as for ``estimate``)."""
    bm = _bench_memory()
    path, n = one_hour
    js = tmp_path / "o.json"
    m = bm.measure(bm.COMMANDS[command][0](path, js))
    assert m["rc"] == 0, m["err"]
    assert n == 28_800_000
    s = json.loads(js.read_text())
    if command == "observe":
        assert s["constant_velocity_samples"] > 1_000_000
    elif command == "identify":
        assert s["n_rows"] == -(-(n - 100) // 10)
    else:
        assert s["window"]["samples"] == 480_000 and s["window"]["recording_samples"] == n
    print(f"\n{path.suffix} {command}: peak RSS {m['rss'] / 2**20:.0f} MiB, {m['rss'] / n:.1f} B/sample, "
          f"wall {m['wall']:.1f} s")  # fmt: skip
    assert m["rss"] < GIB, f"peak RSS {m['rss'] / 2**20:.0f} MiB"
