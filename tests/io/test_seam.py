"""Two recordings joined end to end: the loader names the seam (B5).

Reference figures: the simulator's recording (bench-0A, 11-bit encoders, 8 kHz) and numpy by
hand (the size of the jump at the seam, the velocity's allowance h·max|ω|).
"""

from __future__ import annotations

import numpy as np
import pytest
import tomli_w

from cli_runner import run_in_process
from drivelash.errors import DataError
from drivelash.io import Trace, load_trace, write_trace

COLS = ["t", "theta_m", "omega_m", "theta_l", "omega_l", "torque_m"]


@pytest.fixture(scope="module")
def rec():
    from identify.helpers import simulated_trace

    tr = simulated_trace(2.0)
    return {c: np.asarray(tr[c]) for c in COLS}, tr


def _joined(cols: dict) -> dict:
    """The recording twice, the time running on (the tester's concat_cont)."""
    t = cols["t"]
    T = t[-1] + (t[1] - t[0])
    return {c: np.concatenate((v, v + T if c == "t" else v)) for c, v in cols.items()}


def test_joined_recordings_are_refused_naming_file_column_row(tmp_path, rec):
    cols, _ = rec
    j = _joined(cols)
    n = cols["t"].size
    write_trace(Trace(j), tmp_path / "joined.parquet")
    with pytest.raises(DataError) as ei:
        load_trace(tmp_path / "joined.parquet")
    msg = str(ei.value)
    # the column whose step is larger relative to its velocity comes first: θ_m is checked first
    side = "m" if abs(j["theta_m"][n] - j["theta_m"][n - 1]) > 4 * 2 * np.pi / 2048 else "l"
    jump = abs(j[f"theta_{side}"][n] - j[f"theta_{side}"][n - 1])
    assert jump > 10 * (2 * np.pi / 2048)  # the seam is ≥ 10 counts (numpy by hand)
    assert f"column 'theta_{side}'" in msg
    assert f"data row {n + 1} (1-based)" in msg
    assert f"{jump * 1e3:.4g} mrad" in msg
    assert "concatenated recordings" in msg
    assert "\n" not in msg


@pytest.mark.parametrize("command", ["estimate", "identify"])
def test_cli_exit_2_one_line_nothing_written(tmp_path, rec, capsys, command, monkeypatch):
    cols, tr = rec
    write_trace(Trace(_joined(cols)), tmp_path / "joined.parquet")
    cfg = {
        "drivetrain": dict(tr.meta["estimator_drivetrain"]),
        "backlash": {"delta1": tr.meta["estimator_backlash"]["delta1"]},
    }
    (tmp_path / "d.toml").write_text(tomli_w.dumps(cfg))
    monkeypatch.setenv("DRIVELASH_CHUNK_ROWS", "5000")  # the streamed estimate: the seam inside a chunk run
    code, out, err = run_in_process(
        [
            command,
            str(tmp_path / "joined.parquet"),
            "-c",
            str(tmp_path / "d.toml"),
            "--json",
            str(tmp_path / "o.json"),
        ],
        capsys,
    )
    assert code == 2
    assert "Traceback" not in err
    assert "concatenated recordings" in err and "joined.parquet" in err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o.json").exists()


@pytest.mark.parametrize("chunk", [3, 7, 1000, 4001, 10**6])
def test_chunked_scan_equals_whole(rec, chunk):
    """The stream's scan (any chunking) finds the same seam as the loader's."""
    from drivelash.io._seam import SeamScan

    cols, _ = rec
    j = _joined(cols)
    whole = SeamScan("x")
    whole.feed(j["t"], j["theta_l"], j["omega_l"], 0, final=True)
    part = SeamScan("x")
    n = j["t"].size
    for a in range(0, n, chunk):
        part.feed(j["t"][a : a + chunk], j["theta_l"][a : a + chunk], j["omega_l"][a : a + chunk], a)
    part.finish()
    assert whole.first_seam() is not None
    assert part.first_seam() == whole.first_seam()
    assert part.q == whole.q


def test_legitimate_recordings_still_load(tmp_path, rec):
    """Negative controls: the recording itself, exported rounded to 1°, sampled at 1 kHz and
    125 Hz, with a velocity that lags by 80 samples (10 ms filter), and with one sample moved
    by one ulp (the position's resolution is a quantile, not the smallest step) — none is refused."""
    cols, _ = rec
    variants = {"as recorded": cols}
    q = np.radians(1.0)
    variants["1 deg"] = {
        **cols,
        "theta_m": np.round(cols["theta_m"] / q) * q,
        "theta_l": np.round(cols["theta_l"] / q) * q,
    }
    for k in (8, 64):
        variants[f"every {k}th"] = {c: v[::k] for c, v in cols.items()}
    lag = {c: v.copy() for c, v in cols.items()}
    for s in "ml":
        lag[f"omega_{s}"] = np.convolve(cols[f"omega_{s}"], np.ones(80) / 80)[: cols["t"].size]
    variants["lagging velocity"] = lag
    ulp = {c: v.copy() for c, v in cols.items()}
    ulp["theta_l"][277] = np.nextafter(ulp["theta_l"][277], np.inf)  # one step of one ulp
    variants["one ulp"] = ulp
    for name, v in variants.items():
        path = tmp_path / f"{name.replace(' ', '_')}.parquet"
        write_trace(Trace(v), path)
        tr = load_trace(path)
        assert len(tr) == v["t"].size, name


def test_int16_counter_of_a_finer_encoder_is_named(tmp_path, rec):
    """B10: a 19-bit encoder logged into int16 wraps every 1/8 revolution; without ``wrap`` the
    jumps were read silently (estimate blamed gravity). The seam message names ``wrap``; with
    ``wrap = 65536`` the same file loads (negative control)."""
    cols, _ = rec
    x = dict(cols)
    for c in ("theta_m", "theta_l"):
        n = np.round(cols[c] / (2 * np.pi) * 2**19).astype(np.int64)
        x[c] = ((n + 2**15) % 2**16 - 2**15).astype(np.int16)
    import pandas as pd

    pd.DataFrame(x).to_parquet(tmp_path / "wrap16.parquet")
    m = {c: {"column": c, "unit": "counts", "counts_per_rev": 2**19} for c in ("theta_m", "theta_l")}
    if np.ptp(cols["theta_m"]) * 2**19 / (2 * np.pi) > 2**16:  # the recording does wrap
        with pytest.raises(DataError, match="set wrap"):
            load_trace(tmp_path / "wrap16.parquet", m)
    for c in m:
        m[c]["wrap"] = 65536
    tr = load_trace(tmp_path / "wrap16.parquet", m)
    assert np.max(np.abs(tr["theta_m"] - cols["theta_m"])) < 2 * np.pi / 2**19
