"""Figures of merit (spec 01 §3) on hand-computed signals."""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.metrics import convergence_time, maee, steady_state_peak


def test_maee_and_ss_peak_by_hand():
    t = np.arange(11.0)  # 0 … 10 s
    est = np.array([0, 5, 8, 9, 9.5, 10.2, 9.9, 10.05, 10, 10, 10.01])
    assert maee(t, est, 10.0, 5.0) == pytest.approx(0.2)  # |10 − 10.2| at t = 5
    assert maee(t, est, 10.0, 0.0, T=2.0) == pytest.approx(10.0)
    assert steady_state_peak(t, est, 10.0, 3.0) == pytest.approx(0.05)  # t ∈ [7, 10]


def test_convergence_time_by_hand():
    t = np.arange(11.0)
    est = np.array([0, 5, 8, 9, 9.5, 10.2, 9.9, 10.05, 10, 10, 10.01])
    assert convergence_time(t, est, 10.0, 0.6) == 4.0  # last excursion > 0.6 at t = 3
    assert convergence_time(t, est, 10.0, 0.1) == 6.0  # 0.2 at t = 5
    assert convergence_time(t, est, 10.0, 0.001) is None  # error at the end 0.01 > band
    assert convergence_time(t, est, 10.0, 0.6, t_start=2.0) == 2.0  # relative to t_start
