"""Section monitor (spec 02 §6) on a synthetic pass with a known local rack defect."""

from __future__ import annotations

import numpy as np
import pytest

import control as ct
from drivelash.errors import DataError, ParameterError
from drivelash.te.protocol.monitoring import (
    MonitorParams,
    defect_covered,
    false_sections_per_metre,
    monitor_sections,
    section_edges,
    section_mae,
    section_peak,
)

K_V, K_P, T_N, J_S = 231.0, 12.4, 3.05e-3, 3.5e-3
G3 = -ct.tf([J_S * T_N / K_P, T_N, 1, 0], [J_S * T_N / K_P, T_N, 1 + K_V * T_N, K_V])


def path_error(t, te):
    """Eq (3) applied to a TE series (python-control, zero initial state)."""
    return ct.forced_response(G3, t, te).outputs


def _pass(defect_center=0.6, width=0.03, amp=6e-6, v=0.1, seed=0):
    rng = np.random.default_rng(seed)
    T_s = 1e-3
    t = np.arange(0, 1.6 / v, T_s)
    x = 0.05 + v * t
    te_model = 5e-6 * np.sin(2 * np.pi * x / 0.013333) + 20e-6 * np.sin(2 * np.pi * x / 0.2667)
    bump = amp * np.exp(-0.5 * ((x - defect_center) / (width / 4)) ** 2) * np.sin(2 * np.pi * x / 0.006)
    te_true = te_model + bump + 0.05e-6 * rng.standard_normal(t.size)
    e_meas = path_error(t, te_true - te_model)  # an ideal compensation of the modelled part
    return t, x, te_true, te_model, e_meas


def test_section_peak_against_loop_reference():
    rng = np.random.default_rng(4)
    x = rng.uniform(0, 1, 1000)
    v = rng.standard_normal(1000)
    edges = section_edges(0.0, 1.0, 0.1)
    ref = [np.max(np.abs(v[(x >= a) & (x < b)])) for a, b in zip(edges[:-1], edges[1:], strict=True)]
    np.testing.assert_allclose(section_peak(x, v, edges), ref, rtol=0)


def test_mae_statistic_also_flags_a_large_defect():
    t, x, te_true, te_model, e_meas = _pass(amp=12e-6)
    rep = monitor_sections(t, x, te_true, te_model, e_meas, path_error, MonitorParams(statistic="mae"))
    assert rep.statistic == "mae"
    assert defect_covered(rep, (0.585, 0.615))
    assert np.count_nonzero(rep.flagged) == 1


def test_section_mae_against_loop_reference():
    rng = np.random.default_rng(2)
    x = rng.uniform(0, 1, 1000)
    v = rng.standard_normal(1000)
    edges = section_edges(0.0, 1.0, 0.1)
    got = section_mae(x, v, edges)
    ref = [np.mean(np.abs(v[(x >= a) & (x < b)])) for a, b in zip(edges[:-1], edges[1:], strict=True)]
    np.testing.assert_allclose(got, ref, rtol=1e-12)
    assert section_edges(0.0, 0.95, 0.1).size == 11  # last section partial


def test_a_partial_last_section_ends_where_the_data_end():
    # te validate --quick: passes over the model's valid range [0.0500107, 0.44998935] m; the
    # last section was reported as ending at 0.4500107 m, beyond the range the passes cover
    lo, hi = 0.0500107, 0.44998935
    e = section_edges(lo, hi, 0.1)
    assert e.size == 5 and e[-1] == np.nextafter(hi, np.inf)
    np.testing.assert_allclose(e[:-1], lo + 0.1 * np.arange(4), rtol=0, atol=1e-15)
    # a sample at x_max still counts in the last section (right-open bins)
    x = np.array([lo, 0.2, hi])
    assert np.all(np.isfinite(section_mae(x[[0]], [1.0], e)[:1]))
    assert section_mae(x, np.array([1.0, 2.0, 3.0]), e)[-1] == 3.0
    # full sections keep their length
    assert np.allclose(np.diff(section_edges(0.0, 1.0, 0.1)), 0.1, rtol=0, atol=1e-12)


def test_flags_exactly_the_defective_section():
    t, x, te_true, te_model, e_meas = _pass()
    rep = monitor_sections(t, x, te_true, te_model, e_meas, path_error)
    defect = (0.6 - 0.015, 0.6 + 0.015)
    assert defect_covered(rep, defect)
    assert false_sections_per_metre(rep, defect) == 0.0
    (a, b), *rest = rep.flagged_intervals()
    assert not rest and a == pytest.approx(0.55) and b == pytest.approx(0.65)
    # the uncompensated estimate is (3) applied to the measured TE, section by section
    ref = section_mae(x, path_error(t, te_true), rep.edges)
    np.testing.assert_allclose(rep.mae_uncompensated, ref, rtol=1e-12)
    # away from the defect the compensation is estimated to remove almost everything
    assert np.nanmedian(rep.improvement) > 0.9


def test_no_defect_no_flags():
    t, x, te_true, te_model, e_meas = _pass(amp=0.0)
    rep = monitor_sections(t, x, te_true, te_model, e_meas, path_error)
    assert not np.any(rep.flagged)
    assert rep.threshold == pytest.approx(3.0 * np.median(rep.peak_model))  # noise level × factor


def test_defect_straddling_a_section_boundary_is_covered():
    t, x, te_true, te_model, e_meas = _pass(defect_center=0.55, amp=12e-6)
    rep = monitor_sections(t, x, te_true, te_model, e_meas, path_error)
    defect = (0.55 - 0.015, 0.55 + 0.015)
    assert defect_covered(rep, defect)
    assert false_sections_per_metre(rep, defect) == 0.0
    assert np.count_nonzero(rep.flagged) == 2


def test_monitor_rejects_bad_input():
    with pytest.raises(DataError):
        monitor_sections(np.zeros(10), np.zeros(9), np.zeros(10), np.zeros(10), np.zeros(10), path_error)
    with pytest.raises(ParameterError):
        MonitorParams(section_length=0.0)
    with pytest.raises(ParameterError):
        MonitorParams(statistic="rms")
