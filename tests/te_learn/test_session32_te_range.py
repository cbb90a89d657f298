"""One per-flank torque range for ``TEModel.predict(strict=True)``, the table and the compensator.

Session 32 tester E, E6: the runtime table (``build_table``, read by the compensator and written
by ``te export``) spans flank +1 over [0, torque_max] and flank −1 over [−torque_max, 0] (the
load acts against the motion: the motor torque has the sign of the flank), but
``predict(strict=True)`` checked only |torque| ≤ torque_max and stated the range as
"±torque_max". On the demo's model (torque_max 9.554 N·m) flank +1 at −9 N·m was answered with
−24.614 µm, extrapolated, where the table holds its 0 N·m edge (−38.427 µm): 14 µm apart for the
same input. The conftest's model (torque_max 9 N·m) is used here.
"""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.errors import ParameterError
from drivelash.te.runtime.compensator import Compensator, CompensatorParams
from drivelash.te.runtime.persist import load_model, save_model
from drivelash.te.runtime.table import (
    build_table,
    flank_torque_range,
    flank_torques,
    valid_torque_range,
)

T_MAX = 9.0  # the conftest model's context.valid_range.torque_max [N·m]


@pytest.fixture(scope="module")
def model(small_trained, tmp_path_factory):
    return load_model(save_model(small_trained, tmp_path_factory.mktemp("range32") / "m"))


@pytest.fixture(scope="module")
def table(model):
    return build_table(model, 0.0, 0.3, 1e-3, T_MAX, 10)


def test_the_valid_range_is_per_flank():
    assert valid_torque_range(None, 1) is None  # nothing known: nothing checked
    assert flank_torque_range(0.0, T_MAX, 1) == (0.0, T_MAX)
    lo, hi = flank_torque_range(0.0, T_MAX, -1)
    assert (lo, hi) == (-T_MAX, 0.0) and str(hi) == "0.0"  # no "-0" in a message
    assert flank_torque_range(1.0, T_MAX, -1) == (-T_MAX, -1.0)
    with pytest.raises(ParameterError, match="must be \\+1 or -1"):
        flank_torques(np.array([0.0, 1.0]), 0)


@pytest.mark.parametrize(
    ("direction", "torque"), [(1, -4.0), (1, -9.0), (-1, 4.0), (-1, 9.0), (1, 9.5), (-1, -9.5)]
)
def test_strict_refuses_a_torque_outside_the_flank_range(model, direction, torque):
    """A torque of the wrong sign for the flank was taken before (only |torque| was checked)."""
    with pytest.raises(ParameterError) as err:
        model.predict(np.array([0.1, 0.2]), torque, direction, strict=True)
    msg = str(err.value)
    own, other = ("[0, 9]", "[-9, 0]") if direction == 1 else ("[-9, 0]", "[0, 9]")
    assert "\n" not in msg and "±" not in msg, msg
    assert msg.startswith(f"TEModel.predict.torque: {torque:g} N·m is outside"), msg
    assert (
        f"valid torque range of flank {direction:+d}, {own} N·m (flank {-direction:+d}: {other} N·m" in msg
    ), msg
    assert model.predict(np.array([0.2]), torque, direction).size == 1  # not strict: answered (evaluation)


def test_strict_in_range_is_bit_identical(model):
    """Negative control: every torque of the flank's range (its ends, −0.0/+0.0 and the 1e-9
    slack included) is answered with the very numbers of the non-strict call."""
    x = np.linspace(0.01, 0.29, 301)
    for d in (1, -1):
        lo, hi = valid_torque_range(model, d)
        grid = np.linspace(lo, hi, 301)
        assert np.array_equal(model.predict(x, grid, d, strict=True), model.predict(x, grid, d))
        for tq in (lo, hi, 0.0, -0.0, d * T_MAX * (1 + 5e-10), -d * 1e-12):
            assert np.array_equal(model.predict(x, tq, d, strict=True), model.predict(x, tq, d)), (d, tq)


def test_table_compensator_and_strict_use_one_range(model, table):
    """The table's torque grid per flank is valid_torque_range; strict predict accepts each node
    and equals the table there; beyond it the table — and so the compensator — holds the edge."""
    xs = table.x_grid[::25]
    for d in (1, -1):
        grid = table.torque_grid(d)
        assert (grid[0], grid[-1]) == valid_torque_range(model, d)
        X, T = np.meshgrid(xs, grid, indexing="ij")
        assert np.array_equal(
            table.predict(X, T, d), model.predict(X.ravel(), T.ravel(), d, strict=True).reshape(X.shape)
        )
        # the wrong sign is held at 0 N·m, above the range at ±torque_max (never extrapolated)
        assert np.array_equal(table.predict(xs, -d * 4.0, d), table.predict(xs, 0.0, d))
        assert np.array_equal(table.predict(xs, d * 20.0, d), table.predict(xs, d * T_MAX, d))
    # the compensator reads the same table: its model torque is clamped to the flank's range
    n = 40
    x_d = np.linspace(0.10, 0.14, n + 1)
    zero = np.zeros(n)
    p = CompensatorParams(v_max=1.0, hysteresis=100.0, release=0.0)  # the flank stays +1

    def v_te(torque: float) -> np.ndarray:
        comp = Compensator(table, p, flank=1)
        out = comp.run(x_d, np.full(n, torque), zero, zero)[1]
        assert comp.flank == 1 and comp.cycles_outside == 0
        return out

    assert np.array_equal(v_te(-4.0), v_te(0.0))
    assert np.array_equal(v_te(20.0), v_te(T_MAX))
    assert not np.array_equal(v_te(4.0), v_te(0.0))  # in range the torque matters
