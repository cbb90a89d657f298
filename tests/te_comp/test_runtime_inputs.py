"""Compensator.step/run refuse non-finite inputs with one line before the kernel runs (a NaN
was returned as the velocity command and stayed in the state); valid input is unchanged."""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.errors import DataError
from drivelash.te.runtime.compensator import Compensator, CompensatorParams
from drivelash.te.runtime.table import build_table

from .analytic import BilinearTE

T_SC = 5e-3
PARAMS = CompensatorParams(v_max=1.0, hysteresis=0.5, t_ss_sign=35e-3, release=0.0, bl_gain=1.0)


def _inputs(n=120, k_flip=40):
    k = np.arange(n + 1)
    x_d = 0.4 - 0.02 * T_SC * np.abs(k - k_flip)
    tq = np.where(k[:-1] < k_flip, 3.0, -3.0)
    omega = np.where(k[:-1] < k_flip, 30.0, -30.0)
    return x_d, tq, omega, np.zeros(n)


@pytest.fixture(scope="module")
def table():
    return build_table(BilinearTE(), 0.0, 1.0, 0.05e-3, 10.0, 11)


def _bits(a):
    return np.ascontiguousarray(a, dtype=np.float64).view(np.uint64)


def _one_line(err) -> str:
    msg = str(err.value)
    assert "\n" not in msg
    return msg


NAMES = ["x_d_n", "x_d_next", "torque_m", "omega_m", "alpha_m"]


@pytest.mark.parametrize("which", range(5))
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_step_refuses_nonfinite_input(table, which, bad):
    x_d, tq, om, al = _inputs()
    comp = Compensator(table, PARAMS, flank=1)
    for k in range(50):
        comp.step(x_d[k], x_d[k + 1], tq[k], om[k], al[k])
    before = comp.state.copy()
    args = [x_d[50], x_d[51], tq[50], om[50], al[50]]
    args[which] = bad
    with pytest.raises(DataError) as err:
        comp.step(*args)
    assert _one_line(err).startswith(f"Compensator.step: {NAMES[which]} is {bad}; ")
    assert np.array_equal(_bits(comp.state), _bits(before))
    # and the next cycles continue exactly as without the refused call
    ref = Compensator(table, PARAMS, flank=1)
    for k in range(50):
        ref.step(x_d[k], x_d[k + 1], tq[k], om[k], al[k])
    for k in range(50, 120):
        assert comp.step(x_d[k], x_d[k + 1], tq[k], om[k], al[k]) == ref.step(
            x_d[k], x_d[k + 1], tq[k], om[k], al[k]
        )


@pytest.mark.parametrize("which", range(4))
def test_run_refuses_nonfinite_input(table, which):
    arrays = list(_inputs())
    comp = Compensator(table, PARAMS, flank=1)
    comp.run(arrays[0][:21], arrays[1][:20], arrays[2][:20], arrays[3][:20])
    before = comp.state.copy()
    arrays[which] = arrays[which].copy()
    arrays[which][37] = np.nan
    with pytest.raises(DataError) as err:
        comp.run(*arrays)
    name = ["x_d", "torque_m", "omega_m", "alpha_m"][which]
    assert _one_line(err).startswith(f"Compensator.run: {name}[37] (0-based) is nan; ")
    assert np.array_equal(_bits(comp.state), _bits(before))


def test_run_refuses_2d_arrays(table):
    x_d, tq, om, al = _inputs()
    comp = Compensator(table, PARAMS, flank=1)
    before = comp.state.copy()
    with pytest.raises(
        DataError, match=r"^Compensator.run: expected 1-D arrays, got x_d \(121,\), torque_m \(120, 1\)"
    ):
        comp.run(x_d, tq[:, None], om, al)
    assert np.array_equal(_bits(comp.state), _bits(before))


def test_valid_input_unchanged_and_step_equals_run(table):
    """Negative control: finite inputs run as before (step == run, bit for bit, state too)."""
    x_d, tq, om, al = _inputs()
    a = Compensator(table, PARAMS, flank=1)
    v, vte, vbl = a.run(x_d, tq, om, al)
    b = Compensator(table, PARAMS, flank=1)
    rows = np.array([b.step(x_d[k], x_d[k + 1], tq[k], om[k], al[k]) for k in range(tq.size)])
    assert np.array_equal(_bits(np.column_stack([v, vte, vbl])), _bits(rows))
    assert np.array_equal(_bits(a.state), _bits(b.state))
    assert np.isfinite(v).all() and np.abs(vbl).max() > 0  # the flank change ran
