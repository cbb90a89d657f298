"""Adaptive deadzone law: exactness (chunks, step, py_func), bounds, excitation verdict."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from drivelash.estimation import deadzone as dz
from drivelash.estimation.estimator import (
    INPUT_COLUMNS,
    DeadzoneEstimator,
    EstimatorConfig,
    build_params,
    excitation_frequency,
)
from drivelash.physics import backlash as bk  # independent reference of (12), (50)

from .conftest import RIG_ESTIMATOR, TS


def _samples(trace, n=None):
    return np.column_stack([trace[c][:n] for c in INPUT_COLUMNS])


@pytest.mark.parametrize("method", ["paper", "default"])
def test_chunked_equals_single_and_step_equals_run(short_bench_trace, method):
    trace, bl = short_bench_trace
    cfg = EstimatorConfig.tuned(RIG_ESTIMATOR, TS, 0.5, method=method)
    x = _samples(trace, 20000)
    one = DeadzoneEstimator(RIG_ESTIMATOR, bl, TS, cfg)
    out1 = one.run_samples(x)
    chunked = DeadzoneEstimator(RIG_ESTIMATOR, bl, TS, cfg)
    parts = [chunked.run_samples(x[a : a + 3001]) for a in range(0, len(x), 3001)]
    np.testing.assert_array_equal(np.concatenate(parts), out1)
    np.testing.assert_array_equal(chunked.state, one.state)
    stepper = DeadzoneEstimator(RIG_ESTIMATOR, bl, TS, cfg)
    rows = np.array([stepper.step(x[i]) for i in range(3000)])
    np.testing.assert_array_equal(rows, out1[:3000])
    # Trace-level run with internal chunking equals the unchunked one
    r1 = DeadzoneEstimator(RIG_ESTIMATOR, bl, TS, cfg).run(trace.slice(0, 20000))
    r2 = DeadzoneEstimator(RIG_ESTIMATOR, bl, TS, cfg).run(trace.slice(0, 20000), chunk=777)
    np.testing.assert_array_equal(r1.delta_hat, r2.delta_hat)
    np.testing.assert_array_equal(r1.delta_hat, out1[:, dz.O_DELTA])


@pytest.mark.parametrize("method", ["paper", "default"])
def test_jitted_equals_pure_python(short_bench_trace, method, monkeypatch):
    trace, bl = short_bench_trace
    cfg = EstimatorConfig.tuned(RIG_ESTIMATOR, TS, 0.5, method=method)
    p = build_params(RIG_ESTIMATOR, bl, cfg, TS)
    x = np.ascontiguousarray(_samples(trace, 4000))
    s0 = dz.initial_state(p)
    s_jit, out_jit = dz.deadzone_run(s0, x, p)
    # replace every jitted callee by its Python function, so nothing below runs compiled
    jitted = ("deadzone_run_into", "deadzone_step", "_observe", "_law", "_projection_fast", "_atan_diff")
    jitted += ("sgn",)
    for n in jitted:
        monkeypatch.setattr(dz, n, getattr(dz, n).py_func)
    s_py, out_py = dz.deadzone_run_kernel.py_func(s0, x, p)  # the kernel below the argument checks
    # same operations in the same order; 1e-12 allows for libm vs numba intrinsics (atan, exp)
    np.testing.assert_allclose(out_py, out_jit, rtol=0, atol=1e-12)
    np.testing.assert_allclose(s_py, s_jit, rtol=0, atol=1e-12)


@pytest.mark.parametrize("torque", [False, True])
def test_two_laws_observed_once_equal_two_runs(short_bench_trace, torque):
    """The chosen law and the δ1 check observed once (``deadzone_run2_into``, what the
    estimator runs) give bit for bit the states and outputs of two separate runs, in chunks,
    with the load observer and with the motor-side torque; laws that observe the recording
    differently (paper vs default) are refused by ``observe_shared``."""
    trace, bl = short_bench_trace
    cols = list(INPUT_COLUMNS) + (["torque_m"] if torque else [])
    x = np.ascontiguousarray(np.column_stack([trace[c][:20000] for c in cols]))
    cfg = EstimatorConfig.tuned(RIG_ESTIMATOR, TS, 0.5, torque_source="motor" if torque else "load")
    chk = EstimatorConfig.tuned(
        RIG_ESTIMATOR,
        TS,
        0.5,
        torque_source=cfg.torque_source,
        estimate_offset=True,
        estimate_stiffness=False,
    )
    pa, pb = build_params(RIG_ESTIMATOR, bl, cfg, TS, 12000), build_params(RIG_ESTIMATOR, bl, chk, TS, 12000)
    assert not np.array_equal(pa, pb)  # two different laws
    sa, sb = dz.initial_state(pa), dz.initial_state(pb)
    assert dz.observe_shared(sa, sb, pa, pb)
    ra, oa = dz.deadzone_run(sa, x, pa)
    rb, ob = dz.deadzone_run(sb, x, pb)
    fa, fb = np.empty_like(oa), np.empty_like(ob)
    for a in range(0, len(x), 7001):
        blk = slice(a, a + 7001)
        sa, sb = dz.deadzone_run2_into(sa, sb, x[blk], pa, pb, fa[blk], fb[blk])
    for got, want in ((fa, oa), (fb, ob), (sa, ra), (sb, rb)):
        np.testing.assert_array_equal(got.view(np.int64), want.view(np.int64))
    assert oa[-1, dz.O_DELTA] != ob[-1, dz.O_DELTA]  # control: the laws do differ
    paper = build_params(RIG_ESTIMATOR, bl, EstimatorConfig.tuned(RIG_ESTIMATOR, TS, 0.5, method="paper"), TS)
    assert not dz.observe_shared(dz.initial_state(paper), dz.initial_state(pa), paper, pa)


def test_projection_keeps_inside_and_stops_outside():
    dmax, eps = 0.5, 0.1
    assert dz.projection(0.1, 3.0, dmax, eps) == 3.0
    # on the outer edge (h = 1) an outward update is cancelled, an inward one kept
    assert dz.projection(dmax, 3.0, dmax, eps) == pytest.approx(0.0, abs=1e-12)
    assert dz.projection(dmax, -3.0, dmax, eps) == -3.0
    # in the boundary layer the outward update is scaled by 1 − h ∈ (0, 1)
    d = 0.49
    h = ((eps + 1) * d * d - dmax * dmax) / (eps * dmax * dmax)
    assert 0 < h < 1
    assert dz.projection(d, 2.0, dmax, eps) == pytest.approx(2.0 * (1 - h))


finite = st.floats(-50.0, 50.0, allow_nan=False, allow_infinity=False)


@settings(max_examples=60, deadline=None)
@given(
    x=arrays(np.float64, (300, 4), elements=finite),
    method=st.sampled_from(["paper", "default"]),
    offset=st.booleans(),
    delta_max=st.floats(0.01, 3.0),
    eps_delta=st.floats(0.01, 1.0),
    gamma=st.floats(0.1, 1e4),
)
def test_estimate_bounded_and_finite(x, method, offset, delta_max, eps_delta, gamma):
    cfg = EstimatorConfig.tuned(
        RIG_ESTIMATOR,
        TS,
        0.5,
        method=method,
        delta_max=delta_max,
        eps_delta=eps_delta,
        gamma=gamma,
        estimate_offset=offset,
    )
    # δ1 ≤ δ_max: a larger δ1 contradicts the bound and is refused (test_cli_estimate.py)
    est = DeadzoneEstimator(RIG_ESTIMATOR, min(0.05, delta_max), TS, cfg)
    out = est.run_samples(x)
    d = out[:, dz.O_DELTA]
    assert np.all(np.isfinite(d))
    assert d.min() >= 0.0
    assert d.max() <= delta_max * np.sqrt(1 + eps_delta)


def test_no_engagement_is_not_excitation(inside_trace):
    trace, bl = inside_trace
    for method in ("paper", "default"):
        cfg = EstimatorConfig.tuned(RIG_ESTIMATOR, TS, excitation_frequency(trace), method=method)
        r = DeadzoneEstimator(RIG_ESTIMATOR, bl, TS, cfg).run(trace)
        assert not r.excitation_ok
        assert not r.converged
        assert r.convergence_time_s is None
        assert "deadzone" in r.reason


def test_unidirectional_is_not_excitation(unidirectional_trace):
    trace, bl = unidirectional_trace
    for method in ("paper", "default"):
        cfg = EstimatorConfig.tuned(RIG_ESTIMATOR, TS, excitation_frequency(trace), method=method)
        r = DeadzoneEstimator(RIG_ESTIMATOR, bl, TS, cfg).run(trace)
        assert not r.excitation_ok
        assert not r.converged
        assert "reverse" in r.reason


def test_one_reversal_is_named_and_the_fallback_frequency_is_marked(tmp_path):
    """Exactly one reversal (1 rad position sine at 0.05 Hz over 10 s): before, the reason said
    "the motion never reverses (unidirectional)" and the JSON gave the 0.5 Hz fallback as the
    excitation frequency as if measured (true 0.05 Hz). Negative control: bench-0C at 0.5 Hz
    says "measured" (tested with the CLI's JSON, the summary both paths share)."""
    import drivelash as dl
    from drivelash.control.references import position_sine
    from drivelash.sim.engine import simulate
    from drivelash.sim.scenarios import RIG_DRIVETRAIN, get_scenario

    sc = get_scenario("bench-0C")
    ref = position_sine(10.0, sc.T_s, 1.0, 0.05)
    tr = simulate(RIG_DRIVETRAIN, sc.plant_backlash, sc.gains, ref, sensors=sc.sensors, seed=3).to_trace()
    from pathlib import Path

    cfg = Path(__file__).resolve().parents[2] / "examples" / "drive_bench.toml"
    est = dl.estimate_backlash(tr, cfg, delta1=0.0525)
    assert not est.excitation_ok and est["reason"].startswith("the motion reverses only once")
    assert est["excitation_frequency_hz"] == 0.5
    assert est["excitation_frequency_source"] == "default (fewer than 3 motion reversals)"
    ok = dl.estimate_backlash(sc.simulate(duration=6.0, seed=1), cfg, delta1=0.0525)
    assert ok["excitation_frequency_source"] == "measured"
    assert ok["excitation_frequency_hz"] == pytest.approx(0.5, rel=0.05)


def test_reversing_motion_is_excitation(short_bench_trace):
    trace, bl = short_bench_trace
    r = DeadzoneEstimator(RIG_ESTIMATOR, bl, TS).run(trace)
    assert r.excitation_ok, r.reason
    assert abs(r.delta - bl.delta) < 2e-3


def test_excitation_frequency_of_sine(short_bench_trace):
    trace, _ = short_bench_trace
    assert excitation_frequency(trace) == pytest.approx(0.5, rel=0.05)


def test_bad_config_field():
    from drivelash.errors import ParameterError

    with pytest.raises(ParameterError, match="gamma"):
        EstimatorConfig.tuned(RIG_ESTIMATOR, TS, 0.5, gamma=-1.0)


def test_model_torque_and_gradient_match_physics_module(short_bench_trace):
    """The kernel's fused (one-atan) T_l and ∂T_l/∂δ equal physics.backlash's (12), (50)."""
    trace, bl = short_bench_trace
    # a 0.5 s window (4000 samples) so that the σ ring buffer wraps within the 20000 samples
    cfg = EstimatorConfig.tuned(RIG_ESTIMATOR, TS, 0.5, method="paper", window=0.5)
    est = DeadzoneEstimator(RIG_ESTIMATOR, bl, TS, cfg)
    x = _samples(trace, 20000)
    out = est.run_samples(x)
    d_before = np.concatenate([[0.0], out[:-1, dz.O_DELTA]])  # δ̂ used at each sample
    dth = out[:, dz.O_DTHETA]
    dom = x[:, 1] / RIG_ESTIMATOR.N - x[:, 3]
    K, D = RIG_ESTIMATOR.K_S, RIG_ESTIMATOR.D_S
    ref = bk.smooth_torque(dth, dom, K, D, d_before, bl.delta1, cfg.alpha)
    # one atan instead of two: rounding differs at the 1e-15 relative level; 1e-12 N·m at ≤ 0.3 N·m
    np.testing.assert_allclose(out[:, dz.O_TORQUE_HAT], ref, rtol=0, atol=1e-12)
    # σ-window: sum of g² = (∂T_l/∂δ / K_S)² over the window, g from the reference (50)
    g = bk.dtorque_ddelta(dth, dom, K, D, d_before, bl.delta1, cfg.alpha) / K
    W = int(round(cfg.window / TS))
    c = np.concatenate([[0.0], np.cumsum(g * g)])
    k = np.arange(1, len(g) + 1)
    expect = (c[k] - c[np.maximum(k - W, 0)]) * TS  # sum of the last W samples
    np.testing.assert_allclose(out[:, dz.O_SIGMA_WIN], expect, rtol=1e-9, atol=1e-9)


def test_subcount_reconstruction_removes_quantisation():
    """Complementary filter: 11-bit quantised positions + exact velocities → sub-count Δθ."""
    q = 2 * np.pi / 2048
    t = np.arange(80000) * TS
    th_m = np.sin(np.pi * t) + 0.05 * np.sin(2 * np.pi * 7 * t)
    th_l = np.sin(np.pi * t - 0.01)
    w_m = np.pi * np.cos(np.pi * t) + 0.05 * 2 * np.pi * 7 * np.cos(2 * np.pi * 7 * t)
    w_l = np.pi * np.cos(np.pi * t - 0.01)
    x = np.column_stack([np.round(th_m / q) * q, w_m, np.round(th_l / q) * q, w_l])
    cfg = EstimatorConfig.tuned(RIG_ESTIMATOR, TS, 0.5)
    out = DeadzoneEstimator(RIG_ESTIMATOR, 0.05, TS, cfg).run_samples(x)
    true = th_m - th_l
    late = t > 1.0  # after the filter's start-up (ω_c = 31 rad/s)
    raw = np.abs(x[late, 0] - x[late, 2] - true[late])
    rec = np.abs(out[late, dz.O_DTHETA] - true[late])
    assert raw.max() > 0.5 * q  # the quantised difference is off by up to a count
    # while the encoders move, the count errors average out below ω_c (RMS ≤ q/20 = 0.15 mrad);
    # at the reversals both encoders dwell on one count for a while and that count's error
    # passes the low-pass, so the worst case is only a fraction of a count
    assert np.sqrt(np.mean(rec**2)) < q / 20
    assert rec.max() < q / 4


# --- helpers of the streaming session: equal to the numpy they replace -----------------------
def test_block_minmax_equals_reduceat():
    """Per-history-block min/max of δ̂ folded in block by block = np.minimum/maximum.reduceat
    over the block starts (what ``_Track.add`` computed before), NaN propagating as in numpy."""
    from drivelash.estimation import deadzone as dz

    rng = np.random.default_rng(3)
    n, Bh = 10_007, 97
    d = rng.normal(size=n)
    d[[5, 4000]] = np.nan
    out = np.zeros((n, dz.N_OUT))
    out[:, dz.O_DELTA] = d
    nb = -(-n // Bh)
    dmin, dmax = np.full(nb, np.inf), np.full(nb, -np.inf)
    rmin, rmax = dmin.copy(), dmax.copy()
    for row0 in range(0, n, 1234):  # blocks that straddle history blocks
        blk = out[row0 : row0 + 1234]
        dz.block_minmax(blk, row0, Bh, dmin, dmax)
        b0, b1 = row0 // Bh, (row0 + blk.shape[0] - 1) // Bh + 1
        starts = np.arange(b0, b1) * Bh - row0
        starts[0] = 0
        np.minimum(rmin[b0:b1], np.minimum.reduceat(blk[:, 0], starts), out=rmin[b0:b1])
        np.maximum(rmax[b0:b1], np.maximum.reduceat(blk[:, 0], starts), out=rmax[b0:b1])
    np.testing.assert_array_equal(dmin, rmin)
    np.testing.assert_array_equal(dmax, rmax)
    assert np.isnan(dmin[0]) and np.isnan(dmax[4000 // Bh])


def test_block_samples_copies_and_names_the_first_bad_value():
    """The kernel's input block equals np.column_stack of the columns; the first non-finite
    value in row-major order is named (row, then leftmost column), as np.argwhere gave it."""
    from drivelash.errors import DataError
    from drivelash.estimation.estimator import INPUT_COLUMNS, _block_samples

    rng = np.random.default_rng(1)
    blk = {c: rng.normal(size=50) for c in (*INPUT_COLUMNS, "torque_m")}
    np.testing.assert_array_equal(
        _block_samples(blk, 0, True), np.column_stack([blk[c] for c in (*INPUT_COLUMNS, "torque_m")])
    )
    blk["omega_l"][30] = np.inf
    blk["theta_l"][30] = np.nan
    blk["torque_m"][12] = np.nan
    with pytest.raises(
        DataError, match=r"torque_m.*data row 113 \(1-based\)|data row 113 \(1-based\).*torque_m"
    ):
        _block_samples(blk, 100, True)
    with pytest.raises(
        DataError, match=r"theta_l.*data row 131 \(1-based\)|data row 131 \(1-based\).*theta_l"
    ):
        _block_samples(blk, 100, False)


def test_motion_block_stats_equal_numpy():
    """Pass 1's per-block min, max and smallest step above the floor in one compiled pass =
    np.min, np.max and the masked np.diff it replaced (with and without the previous sample,
    a quantised signal, a NaN)."""
    from drivelash.estimation.motion import STEP_FLOOR, _block_stats

    rng = np.random.default_rng(2)
    for x, prev in (
        (np.round(rng.normal(size=1000) * 512) / 512, np.nan),
        (np.round(rng.normal(size=1000) * 512) / 512, 0.25),
        (np.full(10, 3.0), 3.0),
        (np.array([1.0, np.nan, 2.0, 2.5]), np.nan),
    ):
        d = np.abs(np.diff(x, prepend=prev)) if np.isfinite(prev) else np.abs(np.diff(x))
        d = d[d > STEP_FLOOR]
        ref = (np.min(x), np.max(x), np.min(d) if d.size else np.inf)
        np.testing.assert_array_equal(np.array(_block_stats(x, prev, STEP_FLOOR)), np.array(ref))
