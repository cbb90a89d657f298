"""The online estimator's Python boundary: wrong shapes, wrong states and non-finite samples are
refused with one line before the njit kernel runs (it would read/write out of bounds or keep NaN
in its state forever); valid input gives bit-identical results to the unchecked kernel."""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.control.references import position_sine
from drivelash.errors import DataError, ParameterError
from drivelash.estimation import deadzone as dz
from drivelash.estimation.estimator import DeadzoneEstimator, samples_of

from .conftest import RIG_ESTIMATOR, TS, rig_trace


@pytest.fixture(scope="module")
def samples():
    trace, _ = rig_trace(position_sine(1.0, TS, 1.0, 0.5))
    return samples_of(trace)  # (n, 5) with the motor torque


def _est(T_s=TS):
    return DeadzoneEstimator(RIG_ESTIMATOR, 0.093, T_s)


def _one_line(err) -> str:
    msg = str(err.value)
    assert "\n" not in msg
    return msg


def _bits(a):
    return np.ascontiguousarray(a).view(np.uint64)


@pytest.mark.parametrize("cols", [slice(0, 3), slice(0, 2)])
def test_run_samples_refuses_too_few_columns(samples, cols):
    e = _est()
    before = e.state.copy()
    bad = np.ascontiguousarray(samples[:, cols])
    with pytest.raises(DataError) as err:
        e.run_samples(bad)
    msg = _one_line(err)
    assert msg.startswith("samples: expected") and "(n, 4) or (n, 5)" in msg
    assert f"got float64 array of shape {bad.shape}" in msg
    assert np.array_equal(_bits(e.state), _bits(before))


def test_run_samples_refuses_extra_column_and_transposed(samples):
    e = _est()
    before = e.state.copy()
    wide = np.hstack([samples, np.ones((len(samples), 1))])
    with pytest.raises(DataError, match=r"got float64 array of shape \(\d+, 6\)$"):
        e.run_samples(wide)
    with pytest.raises(DataError, match=rf"got float64 array of shape \(5, {len(samples)}\)$"):
        e.run_samples(samples.T.copy())
    with pytest.raises(DataError, match=r"shape \(5,\)$"):
        e.run_samples(samples[0])
    assert np.array_equal(_bits(e.state), _bits(before))


def test_kernel_wrapper_refuses_wrong_shapes_dtype_layout(samples):
    e = _est()
    st, p = e.state, e.params
    with pytest.raises(DataError, match=r"shape \(\d+, 3\)$"):
        dz.deadzone_run(st, np.ascontiguousarray(samples[:, :3]), p)
    with pytest.raises(DataError, match=r"got non-contiguous float64 array"):
        dz.deadzone_run(st, samples[::2], p)
    with pytest.raises(DataError, match=r"got float32 array"):
        dz.deadzone_run(st, samples.astype(np.float32), p)
    with pytest.raises(ParameterError) as err:
        dz.deadzone_run(np.zeros(3), samples, p)
    expected = f"deadzone_run.state: expected a C-contiguous float64 array of shape ({st.size},)"
    assert _one_line(err).startswith(expected)
    assert _one_line(err).endswith("got float64 array of shape (3,)")
    with pytest.raises(ParameterError, match=r"^deadzone_run.params: .*got float64 array of shape \(3,\)$"):
        dz.deadzone_run(st, samples, np.zeros(3))


def test_state_assignment_checks_length_and_dtype(samples):
    e = _est()
    before = e.state.copy()
    with pytest.raises(ParameterError) as err:
        e.state = np.zeros(3)
    msg = _one_line(err)
    expected = f"DeadzoneEstimator.state: expected a C-contiguous float64 array of shape ({before.size},)"
    assert msg.startswith(expected)
    assert msg.endswith("got float64 array of shape (3,)")
    foreign = _est(T_s=1e-3).state  # another T_s: another σ window, another length
    assert foreign.size != before.size
    with pytest.raises(ParameterError, match=rf"got float64 array of shape \({foreign.size},\)$"):
        e.state = foreign.copy()
    with pytest.raises(ParameterError, match=r"got float32 array"):
        e.state = before.astype(np.float32)
    with pytest.raises(ParameterError, match=r"got list$"):
        e.state = list(before)
    assert np.array_equal(_bits(e.state), _bits(before))
    e.state = before.copy()  # a snapshot of the right shape is accepted


def test_step_refuses_wrong_length(samples):
    e = _est()
    before = e.state.copy()
    with pytest.raises(DataError, match=r"^sample: expected 4 or 5 values .* got shape \(3,\)$"):
        e.step(samples[0, :3])
    with pytest.raises(DataError, match=r"got shape \(1, 5\)$"):
        e.step(samples[:1])
    assert np.array_equal(_bits(e.state), _bits(before))


def test_valid_input_bit_identical_to_the_kernel(samples):
    """Negative control: the checks change nothing for valid input (run_samples, chunked, step)."""
    e = _est()
    h = len(samples) // 2
    o1 = e.run_samples(samples[:h])
    o2 = e.run_samples(samples[h:])
    ref = np.empty((len(samples), dz.N_OUT))
    st = dz.deadzone_run_into(_est().state, samples, _est().params, ref)
    assert np.array_equal(_bits(np.vstack([o1, o2])), _bits(ref))
    assert np.array_equal(_bits(e.state), _bits(st))
    s = _est()
    rows = np.array([s.step(samples[i]) for i in range(200)])
    assert np.array_equal(_bits(rows), _bits(ref[:200]))
    four = _est().run_samples(samples[:, :4])  # (n, 4) without the torque: accepted
    assert four.shape == (len(samples), dz.N_OUT)


@pytest.mark.parametrize(("col", "name"), list(enumerate(["theta_m", "omega_m", "theta_l", "omega_l"])))
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_run_samples_refuses_nonfinite_position_velocity(samples, col, name, bad):
    e = _est()
    e.run_samples(samples[:1000])
    before = e.state.copy()
    block = samples[1000:].copy()
    block[700, col] = bad
    block[900, (col + 1) % 4] = np.nan  # a later one: the first is named
    with pytest.raises(DataError) as err:
        e.run_samples(block)
    msg = _one_line(err)
    assert msg.startswith(f"column '{name}': sample 700 (0-based in this call) is {bad}: ")
    assert np.array_equal(_bits(e.state), _bits(before))
    # the state is usable: the clean block continues exactly as without the refused call
    clean = _est()
    clean.run_samples(samples[:1000])
    assert np.array_equal(_bits(e.run_samples(samples[1000:])), _bits(clean.run_samples(samples[1000:])))


@pytest.mark.parametrize(("col", "name"), list(enumerate(["theta_m", "omega_m", "theta_l", "omega_l"])))
def test_step_refuses_nonfinite_position_velocity(samples, col, name):
    e = _est()
    e.run_samples(samples[:100])
    before = e.state.copy()
    x = samples[100].copy()
    x[col] = np.nan
    with pytest.raises(DataError) as err:
        e.step(x)
    assert _one_line(err).startswith(f"column '{name}': sample 0 (0-based in this call) is nan: ")
    assert np.array_equal(_bits(e.state), _bits(before))


def test_nan_torque_still_accepted(samples):
    """Kept behaviour: a NaN torque means "no torque for this sample" (load observer)."""
    x = samples[:2000].copy()
    x[500, 4] = np.nan
    e = _est()
    out = e.run_samples(x)
    assert np.isfinite(out[:, dz.O_DELTA]).all() and np.isfinite(e.state).all()
    ref = np.empty((len(x), dz.N_OUT))
    dz.deadzone_run_into(_est().state, x, _est().params, ref)
    assert np.array_equal(_bits(out), _bits(ref))
    s = _est()
    rows = np.array([s.step(x[i]) for i in range(600)])
    assert np.array_equal(_bits(rows), _bits(ref[:600]))


# -- run(): the estimator's T_s against the recording's sample period -------------------------
@pytest.fixture(scope="module")
def short_trace():
    trace, _ = rig_trace(position_sine(1.0, TS, 1.0, 0.5))
    return trace


@pytest.mark.parametrize("T_s", [1e-3, 62.5e-6, TS * (1 + 2e-3)])
def test_run_refuses_another_sample_time(short_trace, T_s):
    """run() used the trace's period while step/run_samples use T_s: one object, two estimators."""
    with pytest.raises(ParameterError, match=r"^DeadzoneEstimator\.T_s: ") as err:
        _est(T_s).run(short_trace)
    msg = _one_line(err)
    assert f"{T_s:.6g} s differs from the trace's sample period 0.000125 s" in msg
    assert "T_s=trace.T_s" in msg


def test_run_accepts_the_recordings_rate_within_tolerance(short_trace):
    """The nominal rate of a logger whose stamps drift (EMPS: 1.6e-5) is the same rate; the
    result is the one of an estimator built with the trace's own period, bit for bit."""
    ref = _est(short_trace.T_s).run(short_trace)
    for T_s in (TS, TS * (1 + 1.6e-5), TS * (1 - 9e-4)):
        r = _est(T_s).run(short_trace)
        assert np.array_equal(_bits(r.delta_hat), _bits(ref.delta_hat))
        assert (r.delta, r.delta_std) == (ref.delta, ref.delta_std)


def _jittered(trace):
    """Every 4th interval 1 % long (within the loader's default jitter tolerance, 1 %): the
    mean interval is 0.25 % above the median one (``Trace.T_s``)."""
    from drivelash.io.trace import Trace

    dt = np.full(len(trace) - 1, TS)
    dt[::4] *= 1.01
    cols = {k: np.asarray(trace[k]) for k in trace.names}
    cols["t"] = np.concatenate([[0.0], np.cumsum(dt)])
    return Trace(cols, dict(trace.meta))


def test_run_accepts_a_jittered_recording_built_with_its_own_T_s(short_trace):
    """Built with T_s=trace.T_s, as the refusal tells, a jittered recording was refused (its
    mean interval, which run() compared with, is 0.25 % off the median)."""
    jt = _jittered(short_trace)
    mean = float(np.diff(jt["t"]).mean())
    assert abs(mean / jt.T_s - 1) > 2e-3
    r = _est(jt.T_s).run(jt)
    ref = _est(mean).run(jt)  # the same run: run() integrates with the mean period either way
    assert np.array_equal(_bits(r.delta_hat), _bits(ref.delta_hat))
    with pytest.raises(ParameterError, match=r"median interval 0\.000125 s"):  # another rate still refused
        _est(1e-4).run(jt)


@pytest.mark.parametrize("T_s", [0.0, -125e-6, float("nan"), float("inf")])
@pytest.mark.parametrize("given", [False, True])
def test_constructor_refuses_a_sample_time_that_is_not_positive(T_s, given):
    """With a given config the tuning rule's check was skipped: 0 raised ZeroDivisionError, NaN a
    bare ValueError, and a negative or infinite T_s was taken."""
    from drivelash.params import EstimatorConfig

    cfg = EstimatorConfig.tuned(RIG_ESTIMATOR, TS, 0.5) if given else None
    with pytest.raises(ParameterError) as err:
        DeadzoneEstimator(RIG_ESTIMATOR, 0.093, T_s, cfg)
    assert _one_line(err) == f"DeadzoneEstimator.T_s: sample time must be finite and > 0 s, got {T_s!r}"


@pytest.mark.parametrize(
    ("args", "key", "text"),
    [
        ((None, 0.093, TS), "drivetrain", "expected a DrivetrainParams, got NoneType"),
        (({"J_m": 1.0}, 0.093, TS), "drivetrain", "expected a DrivetrainParams, got dict"),
        ((RIG_ESTIMATOR, None, TS), "backlash", "got None"),
        ((RIG_ESTIMATOR, "0.093", TS), "backlash", "got '0.093'"),
        ((RIG_ESTIMATOR, True, TS), "backlash", "got True"),
        ((RIG_ESTIMATOR, 0.093, None), "T_s", "sample time must be a number [s], got None"),
    ],
)
def test_constructor_names_the_argument_of_the_wrong_type(args, key, text):
    """A missing or wrongly typed argument was an AttributeError ("'NoneType' object has no attribute
    'J_l'") or a bare TypeError from float(); now one line naming the argument."""
    with pytest.raises(ParameterError) as err:
        DeadzoneEstimator(*args)
    msg = _one_line(err)
    assert msg.startswith(f"DeadzoneEstimator.{key}: ") and msg.endswith(text)


def test_constructor_takes_numpy_scalars():
    """Negative control: numpy scalars (a δ1 or T_s computed from arrays) are numbers."""
    ref = DeadzoneEstimator(RIG_ESTIMATOR, 0.093, TS)
    e = DeadzoneEstimator(RIG_ESTIMATOR, np.float32(0.093), np.float64(TS))
    assert e.T_s == ref.T_s and e.delta1 == float(np.float32(0.093))


def test_a_configuration_table_is_refused_with_the_conversion_named():
    """README's low-level path with a loaded configuration's tables (the s19 tester's F20): the
    message names the conversion; the conversion works (negative control: a plain wrong type
    gets no such hint, above)."""
    from pathlib import Path

    from drivelash.io.config import load_config

    cfg = load_config(Path(__file__).resolve().parents[2] / "examples" / "drive_bench.toml")
    with pytest.raises(ParameterError) as err:
        DeadzoneEstimator(cfg.drivetrain, 0.0525, TS)
    assert _one_line(err).endswith(
        "got DrivetrainParamsSection (a configuration file's [drivetrain] table: pass "
        "load_config(path).to_drivetrain_params())"
    )
    with pytest.raises(ParameterError) as err:
        DeadzoneEstimator(cfg.to_drivetrain_params(), cfg.backlash, TS)
    assert _one_line(err).endswith(
        "(a configuration file's [backlash] table: pass its offset, load_config(path).backlash.delta1)"
    )
    est = DeadzoneEstimator(cfg.to_drivetrain_params(), cfg.backlash.delta1, TS)
    assert est.delta1 == 0.093
