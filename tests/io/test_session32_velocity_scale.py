"""A sample rate stated 2× off (or a velocity scaled by a factor that is no unit) is refused
by the loader, naming the velocity column and the factor (session 30's tester A, M8: a 4 kHz
export read at 8 kHz made the velocity 0.5× the position's derivative; `estimate` then said
"not converged" with no reason and `identify` called the shaft rigid).

The rule (``load.check_velocity_scale``): the position against the integral of its velocity,
θ ≈ a + s·∫ω dt; refused when 1/s lies outside [1/1.5, 1.5] and the fit explains ≥ 90 % of
θ's variance. Negative controls: correct recordings, and a coarse encoder on a small motion
whose *derivative* ratio reads 0.47 (why the rule integrates rather than differentiates).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import cumulative_trapezoid

import drivelash as dl
from drivelash.io._unitcheck import unit_ratio_sums
from drivelash.io._velscale import VelocityScaleFit
from drivelash.io.load import VELOCITY_SCALE_FACTOR
from drivelash.io.stream import TraceStream
from drivelash.sim.scenarios import get_scenario

BENCH_TOML = str(__import__("pathlib").Path(__file__).resolve().parents[2] / "examples" / "drive_bench.toml")


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    """bench-0B, 3 s at 8 kHz, written without its time column (a drive export that relies on
    ``[sampling] sample_rate``)."""
    df = get_scenario("bench-0B").simulate(duration=3.0, seed=2).to_pandas()
    path = tmp_path_factory.mktemp("m8") / "notime.csv"
    df[["theta_m", "omega_m", "theta_l", "omega_l", "torque_m"]].to_csv(path, index=False)
    return path


def _config(tmp_path, rate: float):
    """The README's bench configuration with the stated sample rate."""
    from pathlib import Path

    cfg = tmp_path / f"rate{rate:g}.toml"
    cfg.write_text(
        Path(BENCH_TOML).read_text(encoding="utf-8") + f"\n[sampling]\nsample_rate = {rate!r}\n",
        encoding="utf-8",
    )
    return cfg


@pytest.mark.parametrize(("rate", "factor"), [(16000.0, "0.5×"), (4000.0, "2×")])
def test_a_sample_rate_stated_2x_off_is_refused_whole_and_streamed(bench, tmp_path, rate, factor):
    cfg = _config(tmp_path, rate)
    for load in (
        lambda: dl.load_trace(bench, str(cfg)),
        lambda: TraceStream(bench, dl.load_config(cfg), chunk_rows=997),
    ):
        with pytest.raises(dl.DataError) as exc:
            load()
        msg = str(exc.value)
        assert (
            "\n" not in msg and "column 'omega_m'" in msg and f"velocity is {factor} the derivative" in msg
        ), msg
        assert "sample_rate" in msg, msg


def test_the_command_exits_2_with_one_line(bench, tmp_path, capsys):
    from cli_runner import run_in_process

    code, out, err = run_in_process(
        ["estimate", str(bench), "--config", str(_config(tmp_path, 16000.0))], capsys
    )
    assert code == 2 and "Traceback" not in err
    line = [x for x in err.splitlines() if x.startswith("drivelash: error")]
    assert len(line) == 1 and "velocity is 0.5× the derivative of theta_m" in line[0], err


def test_negative_control_the_right_rate_loads(bench, tmp_path):
    tr = dl.load_trace(bench, str(_config(tmp_path, 8000.0)))
    assert len(tr) == 24000
    with TraceStream(bench, dl.load_config(_config(tmp_path, 8000.0)), chunk_rows=997) as st:
        assert st.n_samples == 24000


def test_negative_control_coarse_encoder_on_a_small_motion(tmp_path):
    """2048 counts/rev, ±20 mrad at 0.5 Hz, 1 kHz: one count per ≈ 50 samples. The derivative
    ratio the unit check uses reads ≈ 0.5 (the samples it selects are those next to a count
    step); the integral reads 1 and the file loads."""
    t = np.arange(6000) * 1e-3
    th = 0.02 * np.sin(np.pi * t)
    q = 2 * np.pi / 2048
    th_q = np.floor(th / q) * q
    om = np.gradient(th, t) + 0.0316 * np.random.default_rng(0).standard_normal(t.size)
    s_od, s_dd, count, _ = unit_ratio_sums(t, th_q, om, max(1, min(25, t.size // 50)))
    assert count >= 10 and s_od / s_dd < 1 / VELOCITY_SCALE_FACTOR  # the derivative would refuse it
    fit = VelocityScaleFit()
    fit.feed(t, th_q, om)
    s, r2 = fit.result()
    assert s == pytest.approx(1.0, abs=0.02) and r2 > 0.98
    pq = tmp_path / "coarse.parquet"
    pd.DataFrame({"t": t, "theta_m": th_q, "omega_m": om, "torque_m": np.cos(t)}).to_parquet(pq)
    assert len(dl.load_trace(pq)) == t.size


def test_fit_over_chunks_equals_the_whole_and_scipy():
    rng = np.random.default_rng(5)
    t = np.cumsum(rng.uniform(0.5, 1.5, 5000)) * 1e-3
    om = np.sin(3 * t) + 0.1 * rng.standard_normal(t.size)
    th = 0.7 * cumulative_trapezoid(om, t, initial=0.0) + 3.0 + 1e-3 * rng.standard_normal(t.size)
    whole = VelocityScaleFit()
    whole.feed(t, th, om)
    chunked = VelocityScaleFit()
    cuts = np.sort(rng.choice(np.arange(1, t.size), 40, replace=False))
    for a, b in zip(np.r_[0, cuts], np.r_[cuts, t.size], strict=True):
        chunked.feed(t[a:b], th[a:b], om[a:b])
    ref = np.polyfit(cumulative_trapezoid(om, t, initial=0.0), th, 1)[0]
    assert whole.result()[0] == pytest.approx(ref, rel=1e-9)
    assert chunked.result()[0] == pytest.approx(ref, rel=1e-9)
    assert chunked.result()[1] == pytest.approx(whole.result()[1], rel=1e-9)
    assert whole.result()[0] == pytest.approx(0.7, rel=1e-3)


@pytest.fixture(scope="module")
def bench_0c():
    return get_scenario("bench-0C").simulate(duration=8.0, seed=1)


@pytest.mark.parametrize(
    ("factor", "match"), [(-1.0, "counts against the derivative"), (0.5, "0.5× the derivative")]
)
def test_api_trace_gets_the_loaders_velocity_checks(bench_0c, factor, match):
    """A Trace built in Python skipped the loader's checks: bench-0C with ω_m counting against
    θ_m gave δ̂ = 197.924 mrad "converged" for the true 105 (session 31 left-over, measured on
    1338a88); now refused like the file, naming the API call and the column."""
    from drivelash.io.trace import Trace

    cols = {n: np.array(bench_0c[n]) for n in bench_0c.names}
    cols["omega_m"] = factor * cols["omega_m"]
    with pytest.raises(dl.DataError, match=match) as exc:
        dl.estimate_backlash(Trace(cols, meta=dict(bench_0c.meta)), BENCH_TOML, delta1=0.0525)
    assert str(exc.value).startswith("estimate_backlash(data=Trace), column 'omega_m'")


def test_api_trace_negative_control_unchanged(bench_0c):
    est = dl.estimate_backlash(bench_0c, BENCH_TOML, delta1=0.0525)
    assert round(1e3 * est.delta) == 105 and est.converged


def test_a_loaded_trace_is_not_checked_twice(bench, tmp_path, monkeypatch):
    """`identify` hands the trace the loader checked to the fit: the velocity checks (0.14 s on a
    60 s recording at 8 kHz) run once, in the loader."""
    import drivelash.io.load as load
    from drivelash.estimation.identify_two_mass import as_trace

    tr = dl.load_trace(bench, str(_config(tmp_path, 8000.0)))
    calls = []
    monkeypatch.setattr(load, "check_trace_velocities", lambda *a: calls.append(a))
    assert as_trace(tr, None, [], "identify_drive") is tr and calls == []
    built = dl.Trace({n: tr[n] for n in tr.names}, {})  # negative control: built in Python
    as_trace(built, None, [], "identify_drive")
    assert len(calls) == 1


def test_a_loaded_trace_changed_in_python_is_checked_again(bench_0c, tmp_path):
    """The last read of session 33: the loader's own trace was recognised by ``meta["format"]``,
    which ``with_columns`` copies — a loaded bench-0C with ω_m flipped in Python then reached the
    estimator unchecked (the session-32 finding: δ̂ 197.9 mrad "converged" for 105). The check is
    skipped only for the very object the loader returned. Negative control: that object itself
    estimates without a second check's refusal."""
    pq = tmp_path / "0c.parquet"
    bench_0c.to_parquet(pq)
    loaded = dl.load_trace(pq)
    assert "format" in loaded.meta
    flipped = loaded.with_columns({"omega_m": -np.asarray(loaded["omega_m"])})
    assert flipped.meta.get("format") == loaded.meta["format"]  # what fooled the old rule
    with pytest.raises(dl.DataError, match="counts against the derivative") as exc:
        dl.estimate_backlash(flipped, BENCH_TOML, delta1=0.0525)
    assert str(exc.value).startswith("estimate_backlash(data=Trace), column 'omega_m'")
    est = dl.estimate_backlash(loaded, BENCH_TOML, delta1=0.0525)
    assert round(1e3 * est.delta) == 105 and est.converged
