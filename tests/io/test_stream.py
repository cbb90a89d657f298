"""The chunked reader: chunks equal ``load_trace`` bit for bit; the same refusals, one line each."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_io_validation import CASE_NAMES, _bad_cases, _good

from drivelash.errors import DataError, ResourceError
from drivelash.io import Trace, load_trace, write_trace
from drivelash.io.stream import TraceStream, iter_trace_chunks

N = 5000


def _signals(n: int = N, T_s: float = 1e-3) -> dict[str, np.ndarray]:
    t = np.arange(n) * T_s
    th = 0.3 * np.sin(2 * np.pi * 2 * t) + 0.2 * t
    return {
        "t": t,
        "theta_m": th,
        "omega_m": 0.3 * 2 * np.pi * 2 * np.cos(2 * np.pi * 2 * t) + 0.2,
        "theta_l": th - 0.01,
        "torque_m": 1.5 * np.sin(2 * np.pi * 2 * t + 0.3) + 0.1 * np.cos(2 * np.pi * 7 * t),
    }


def _concat(chunks) -> dict[str, np.ndarray]:
    chunks = list(chunks)
    return {k: np.concatenate([c[k] for c in chunks]) for k in chunks[0].names}


def _same(a: dict[str, np.ndarray], b: Trace) -> None:
    assert list(a) == b.names
    for k in a:
        assert a[k].view(np.int64).tolist() == b[k].view(np.int64).tolist(), k  # bit for bit


@pytest.mark.parametrize("ext", [".csv", ".parquet", ".h5", ".mat", ".mat73"])
@pytest.mark.parametrize("chunk_rows", [13, 1 << 18])
def test_chunks_equal_load_trace_bit_for_bit(tmp_path, ext, chunk_rows):
    rng = np.random.default_rng(1)
    cols = _signals()
    cols["torque_m"] = cols["torque_m"] + 1e-3 * rng.standard_normal(N)
    p = tmp_path / f"x{'.mat' if ext == '.mat73' else ext}"
    write_trace(Trace(cols), p, fmt="mat73" if ext == ".mat73" else None)
    ref = load_trace(p, required=["theta_m", "torque_m"])
    with TraceStream(p, required=["theta_m", "torque_m"], chunk_rows=chunk_rows) as s:
        assert s.n_samples == N and s.T_s == ref.T_s  # the exact median, as Trace.T_s
        assert s.meta == ref.meta
        got = _concat(s.chunks())
    _same(got, ref)


def test_mapping_units_wraparound_and_sample_rate(tmp_path):
    n = 6000
    k = np.arange(n)
    counts = (np.floor(5000 + 3000 * np.sin(2 * np.pi * k / 1500.0)) % 4096).astype(float)  # wraps
    cols = {
        "enc": counts,
        "speed_rpm": 60.0 * np.gradient(np.unwrap(counts, period=4096) / 4096, 1e-3),
        "cur": np.cos(k / 50.0) + 0.01 * np.sin(k / 3.0),
    }
    p = tmp_path / "raw.csv"
    import pandas as pd

    pd.DataFrame(cols).to_csv(p, index=False)
    mapping = {
        "enc": {"column": "theta_m", "unit": "counts", "counts_per_rev": 4096},
        "speed_rpm": {"column": "omega_m", "unit": "rpm"},
        "cur": {"column": "torque_m", "unit": "A", "torque_constant": 0.8},
    }
    from drivelash.io.config import DriveConfig

    cfg = DriveConfig.model_validate({"columns": mapping, "sampling": {"sample_rate": 1000.0}})
    ref = load_trace(p, cfg)
    assert any("wrap-around" in w for w in ref.meta["warnings"])
    for rows in (1, 97, 4096):
        with TraceStream(p, cfg, chunk_rows=rows) as s:
            assert s.meta["warnings"] == ref.meta["warnings"]
            _same(_concat(s.chunks()), ref)


def test_still_load_is_read_like_load_trace(tmp_path):
    """A load that never moves (θ_l, ω_l constant) is a recording, not an error, for both
    readers (``load.MAY_STAND_STILL``); a constant motor position is refused by both."""
    c = _signals()
    c["theta_l"] = np.full(N, 0.25)
    c["omega_l"] = np.zeros(N)
    p = write_trace(Trace(c), tmp_path / "still.parquet")
    with TraceStream(p, required=["theta_l", "omega_l"], chunk_rows=700) as s:
        _same(_concat(s.chunks()), load_trace(p, required=["theta_l", "omega_l"]))
    c["theta_m"] = np.full(N, 0.25)
    q = write_trace(Trace(c), tmp_path / "still_motor.parquet")
    for read in (load_trace, TraceStream):
        with pytest.raises(DataError, match="constant signal"):
            read(q)


def test_columns_selects_what_is_read(tmp_path):
    p = write_trace(Trace(_signals()), tmp_path / "x.parquet")
    chunks = list(iter_trace_chunks(p, columns=["torque_m"], chunk_rows=1024))
    assert chunks[0].names == ["t", "torque_m"] and sum(len(c) for c in chunks) == N
    assert [c.row0 for c in chunks[:3]] == [0, 1024, 2048]
    with pytest.raises(DataError, match="no such column"):
        TraceStream(p, columns=["omega_l"])


@pytest.mark.parametrize("name", [c for c in CASE_NAMES if c not in ("missing_column",)])
def test_same_refusals_as_load_trace(tmp_path_factory, name):
    cases = _cases(tmp_path_factory)
    path, fragment, column, row = cases[name]
    with pytest.raises(DataError) as ref:
        load_trace(path, required=["theta_m", "torque_m"])
    for rows in (3, 64, 1 << 18):
        with pytest.raises(DataError) as got:
            TraceStream(path, required=["theta_m", "torque_m"], chunk_rows=rows)
        assert str(got.value) == str(ref.value), (rows, str(got.value), str(ref.value))


_CASES: dict = {}


def _cases(factory):
    if not _CASES:
        _CASES.update(_bad_cases(factory.mktemp("bad-stream")))
    return _CASES


def test_missing_required_column(tmp_path):
    c = _good()
    del c["torque_m"]
    p = write_trace(Trace(c), tmp_path / "m.parquet")
    with pytest.raises(DataError, match="missing required column") as ei:
        TraceStream(p, required=["torque_m"])
    assert "column 'torque_m'" in str(ei.value)


@pytest.mark.parametrize(("scale", "unit"), [(1e9, "ns"), (1e6, "us"), (1e3, "ms")], ids=["ns", "us", "ms"])
def test_integer_time_stamps_taken_as_seconds_are_refused_with_the_fix(tmp_path, scale, unit):
    c = _signals(2000, 1e-3 if unit == "ms" else 125e-6)
    c["t"] = np.round(c["t"] * scale)
    p = write_trace(Trace(c), tmp_path / "ns.csv")
    for read in (lambda: load_trace(p), lambda: TraceStream(p)):
        with pytest.raises(DataError, match="implausible sample period") as ei:
            read()
        assert f'time_unit = "{unit}"' in str(ei.value) and "\n" not in str(ei.value)
    # the fix the message names works, and gives the true period
    from drivelash.io.config import DriveConfig

    cfg = DriveConfig.model_validate({"sampling": {"time_unit": unit}})
    assert load_trace(p, cfg).T_s == pytest.approx(1e-3 if unit == "ms" else 125e-6, rel=1e-9)
    assert TraceStream(p, cfg).T_s == load_trace(p, cfg).T_s


def test_declared_time_unit_is_checked_against_the_period(tmp_path):
    """Finding: KUKA rec_B with its time ×1000 and [columns] unit = "s" gave J_m = 20161 kg·m²
    (truth ≈ 0.02) without a word: a declared unit was trusted. No velocity is mapped (as in
    examples/kuka), so the period is the only evidence."""
    from drivelash.io.config import DriveConfig

    c = _signals(2000, 4e-3)  # 250 Hz
    p = tmp_path / "kuka.csv"
    rows = np.column_stack([np.round(c["t"] * 1e3), c["theta_m"], c["torque_m"]])
    np.savetxt(p, rows, delimiter=",", header="time_ms,pos,tq", comments="", fmt="%.10g")

    def cfg(unit: str) -> DriveConfig:
        cols = {"time_ms": {"column": "t", "unit": unit}, "pos": {"column": "theta_m", "unit": "rad"}}
        return DriveConfig.model_validate({"columns": {**cols, "tq": {"column": "torque_m", "unit": "N·m"}}})

    for read in (lambda u: load_trace(p, cfg(u)), lambda u: TraceStream(p, cfg(u))):
        with pytest.raises(DataError, match="implausible sample period 4 s") as ei:
            read("s")
        msg = str(ei.value)
        assert "\n" not in msg and "column 'time_ms'" in msg and 'set unit = "ms" there' in msg, msg
        assert read("ms").T_s == pytest.approx(4e-3, rel=1e-9)  # negative control: the right unit


def test_plausible_slow_recordings_pass(tmp_path):
    c = _signals(500, 0.37)  # 2.7 Hz logging, non-integer seconds: plausible
    p = write_trace(Trace(c), tmp_path / "slow.parquet")
    assert load_trace(p).T_s == pytest.approx(0.37)


def test_resampling_reads_whole_and_matches(tmp_path):
    c = _signals(3000)
    c["t"][1500:] += 0.4e-3
    p = write_trace(Trace(c), tmp_path / "j.parquet")
    ref = load_trace(p, resample=True)
    with TraceStream(p, resample=True, chunk_rows=500) as s:
        _same(_concat(s.chunks()), ref)


def test_memory_budget_guards_whole_reads(tmp_path, monkeypatch):
    p = write_trace(Trace(_signals()), tmp_path / "x.parquet")
    monkeypatch.setenv("DRIVELASH_MEMORY_BUDGET", "100K")
    with pytest.raises(ResourceError, match=r"would need about .* budget of 100 KiB") as ei:
        load_trace(p)
    assert "\n" not in str(ei.value)
    with TraceStream(p, chunk_rows=256) as s:  # streaming stays within it
        assert sum(len(c) for c in s.chunks()) == N


@pytest.mark.slow
def test_hdf5_and_mat73_of_any_length_are_read(tmp_path):
    """More than the old 10 M-element cut-off: no column is skipped for its size."""
    import h5py

    n = 10_000_001
    p = tmp_path / "long.h5"
    with h5py.File(p, "w") as f:
        f.create_dataset("t", data=np.arange(n, dtype=np.float64) * 1e-4, chunks=True)
        f.create_dataset("torque_m", data=np.sin(np.arange(n) * 1e-3), chunks=True)
    with TraceStream(p, chunk_rows=1 << 20) as s:
        assert s.n_samples == n and s.names == ["t", "torque_m"]
        assert math.isclose(s.T_s, 1e-4, rel_tol=1e-9)


def test_trace_from_frame_makes_every_check_the_loader_makes(tmp_path):
    import pandas as pd

    c = _signals(3000)
    p = write_trace(Trace(c), tmp_path / "x.parquet")
    ref = load_trace(p)
    got = Trace.from_frame(pd.DataFrame(c))
    for k in ref.names:
        assert np.array_equal(got[k], ref[k])
    assert got.meta["source"] == "<DataFrame>"
    bad = dict(c)
    bad["torque_m"] = c["torque_m"].copy()
    bad["torque_m"][42] = np.nan
    with pytest.raises(DataError, match=r"<DataFrame>, column 'torque_m', data row 43 \(1-based\): NaN"):
        Trace.from_frame(pd.DataFrame(bad))
    ns = dict(c)
    ns["t"] = np.round(c["t"] * 1e9)
    with pytest.raises(DataError, match="implausible sample period"):
        Trace.from_frame(pd.DataFrame(ns))
    with pytest.raises(DataError, match="missing required column"):
        Trace.from_frame(pd.DataFrame(c), required=["omega_l"])


def test_linear_position_and_reference_1000x_apart_are_refused(tmp_path):
    """Finding: EMPS qm declared in mm while in m gave M = 95 113 kg silently; the reference qg,
    mapped in m, follows the same motion, so a factor 1000 between their spans is a unit slip."""
    from drivelash.io.config import DriveConfig

    c = _signals(3000)
    x = 0.1 * np.sin(2 * np.pi * 0.5 * c["t"])  # carriage position [m]
    p = tmp_path / "emps.csv"
    rows = np.column_stack([c["t"], x + 1e-5 * np.cos(c["t"]), x, c["torque_m"]])
    np.savetxt(p, rows, delimiter=",", header="t,qm,qg,f", comments="", fmt="%.12g")

    def cfg(unit_qm: str, ref: str = "x_ref", unit_qg: str = "m") -> DriveConfig:
        cols = {
            "t": {"column": "t", "unit": "s"},
            "qm": {"column": "theta_m", "unit": unit_qm},
            "qg": {"column": ref, "unit": unit_qg},
            "f": {"column": "torque_m", "unit": "N"},
        }
        return DriveConfig.model_validate({"columns": cols})

    for read in (lambda k: load_trace(p, cfg(*k)), lambda k: TraceStream(p, cfg(*k))):
        with pytest.raises(DataError, match=r"theta_m spans 0\.001× x_ref \(column 'qg'\)") as ei:
            read(("mm",))
        assert "\n" not in str(ei.value) and "column 'qm'" in str(ei.value)
        assert read(("m",)).T_s == pytest.approx(1e-3)  # negative control: consistent units
        # negative control: a second column in an angle unit is not compared (gear ratios)
        assert read(("m", "theta_l", "deg")).T_s == pytest.approx(1e-3)
