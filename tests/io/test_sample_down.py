"""``load_trace(..., max_rate_hz=)``: a recording sampled faster keeps every k-th sample.

What the wear tracker's ``estimate_rate_hz`` relies on (docs/scaling.md): k is the largest integer
with rate / k >= max_rate_hz; the kept samples are exactly rows 0, k, 2k, … of the full load (unit
conversion and encoder unwrapping at the full rate); a non-finite value anywhere is still refused.
"""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.errors import DataError
from drivelash.io import Trace, load_trace, write_trace

RATE = 8000.0


def _recording(tmp_path, n=4001, *, nan_row=None, wrap=False):
    t = np.arange(n) / RATE
    rng = np.random.default_rng(3)
    th = 0.3 * np.sin(2 * np.pi * 0.5 * t)
    cols = {
        "t": t,
        "pos_deg": np.degrees(th),
        "vel": np.gradient(th, t),
        "load": th + 1e-3 * rng.standard_normal(n),
        "load_vel": np.gradient(th, t) + 1e-3 * rng.standard_normal(n),
        "iq": np.cos(2 * np.pi * 3 * t),
    }
    if wrap:  # a 12-bit single-turn encoder over 3 revolutions, its velocity with it
        revs = 1.5 * (1 - np.cos(np.pi * t / t[-1]))
        cols["pos_deg"] = np.mod(np.round(revs * 4096), 4096)
        cols["vel"] = np.gradient(2 * np.pi * revs, t)
    if nan_row is not None:
        cols["load_vel"][nan_row] = np.nan
    path = write_trace(Trace(cols), tmp_path / "r.parquet")
    mapping = {
        "pos_deg": {"column": "theta_m", "unit": "counts", "counts_per_rev": 4096}
        if wrap
        else {"column": "theta_m", "unit": "deg"},
        "vel": {"column": "omega_m", "unit": "rad/s"},
        "load": {"column": "theta_l", "unit": "rad"},
        "load_vel": {"column": "omega_l", "unit": "rad/s"},
        "iq": {"column": "torque_m", "unit": "A", "torque_constant": 0.8},
    }
    return path, mapping


@pytest.mark.parametrize(("max_rate", "k"), [(1000.0, 8), (3000.0, 2), (2000.0, 4), (1100.0, 7)])
def test_every_kth_sample_of_the_full_load(tmp_path, max_rate, k):
    path, mapping = _recording(tmp_path)
    full = load_trace(path, mapping)
    down = load_trace(path, mapping, max_rate_hz=max_rate)
    assert RATE / k >= max_rate > RATE / (k + 1)  # the largest k that keeps the rate
    assert down.meta["sampled_down"] == {"k": k, "T_s": pytest.approx(1 / RATE, rel=1e-12), "samples": 4001}
    assert len(down) == len(range(0, 4001, k))
    assert down.T_s == pytest.approx(k / RATE, rel=1e-9)
    for c in full.names:  # the very values of the full load (units converted at the full rate)
        np.testing.assert_array_equal(down[c], full[c][::k], err_msg=c)


@pytest.mark.parametrize("max_rate", [None, 8000.0, 9000.0, 20000.0])
def test_no_sampling_down_at_or_below_the_limit(tmp_path, max_rate):
    """Negative control: a recording no faster than the limit is loaded whole, unmarked."""
    path, mapping = _recording(tmp_path)
    full = load_trace(path, mapping)
    same = load_trace(path, mapping, max_rate_hz=max_rate)
    assert "sampled_down" not in same.meta and len(same) == len(full)
    for c in full.names:
        np.testing.assert_array_equal(same[c], full[c])


def test_a_nan_in_a_skipped_row_is_still_refused(tmp_path):
    """Row 1001 is not kept at k = 8, yet the file is refused with its one-line error."""
    path, mapping = _recording(tmp_path, nan_row=1001)
    with pytest.raises(DataError) as exc:
        load_trace(path, mapping, max_rate_hz=1000.0)
    msg = str(exc.value)
    assert "\n" not in msg and "load_vel" in msg and "data row 1002 (1-based)" in msg, msg


def test_encoder_unwrapped_at_the_full_rate(tmp_path):
    """Wrap-arounds are undone before the samples are dropped: the kept positions are the
    full load's, not an unwrap of the sparser samples."""
    path, mapping = _recording(tmp_path, wrap=True)
    full = load_trace(path, mapping)
    down = load_trace(path, mapping, max_rate_hz=1000.0)
    assert full["theta_m"].max() > 2 * np.pi * 2.9  # three revolutions, unwrapped
    np.testing.assert_array_equal(down["theta_m"], full["theta_m"][::8])
