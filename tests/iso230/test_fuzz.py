"""Property tests: any table or recording gives a result or a one-line DataError — nothing else."""

from __future__ import annotations

import math
import warnings

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drivelash.errors import DataError
from drivelash.iso230 import approaches_from_rows, detect_dwells, evaluate

finite = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
anyfloat = st.floats(allow_nan=True, allow_infinity=True, width=64)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.lists(
        st.tuples(
            st.sampled_from([0.0, 0.1, 0.2, 0.3]) | anyfloat,
            st.integers(0, 4) | anyfloat,
            st.sampled_from([-1.0, 1.0]) | anyfloat,
            finite | anyfloat,
        ),
        min_size=0,
        max_size=40,
    )
)
def test_tables_give_a_result_or_a_data_error(rows):
    a = np.array(rows, dtype=np.float64).reshape(-1, 4)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no silent numerical warning either
        try:
            res = evaluate(approaches_from_rows(a[:, 0], a[:, 1], a[:, 2], a[:, 3]))
        except DataError as exc:
            assert "\n" not in str(exc)
            return
    for k in res.AXIS_KEYS:
        assert math.isfinite(getattr(res, k)) and getattr(res, k) >= 0 or k == "B_mean"


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.lists(st.sampled_from([0.0, 0.05, 0.1, 0.15]), min_size=1, max_size=12),
    st.integers(5, 400),
    st.floats(0.0, 1e-5),
    st.integers(0, 2**16),
)
def test_recordings_give_a_result_or_a_data_error(levels, hold, noise, seed):
    """Staircase commands of random targets and dwell lengths, with noise on the measurement."""
    rng = np.random.default_rng(seed)
    P = np.repeat(np.asarray(levels), hold)
    P = np.convolve(
        np.concatenate([np.full(50, P[0]), P, np.full(50, P[-1])]), np.ones(25) / 25, mode="valid"
    )
    t = np.arange(P.size) * 2e-3
    ref = P + rng.normal(0, noise, P.size)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            d = detect_dwells(t, P, ref)
            evaluate(d.approaches)
        except DataError as exc:
            assert "\n" not in str(exc)


def test_huge_values_are_refused_not_overflowed():
    rows = np.array([(P, j, d, 1e300) for P in (0.0, 0.1) for j in (1, 2) for d in (1, -1)])
    try:
        approaches_from_rows(rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3])
    except DataError as exc:
        assert "implausible value 1e+300" in str(exc)
    else:
        raise AssertionError("1e300 m deviations were accepted")
