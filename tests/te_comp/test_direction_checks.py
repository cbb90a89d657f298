"""TETable and Compensator take a flank as exactly +1 or −1 (one shared check,
``table.check_direction``): anything else is refused with one line; ±1 as a Python int, a NumPy
integer or a float equal to ±1 gives the same numbers, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.errors import ParameterError
from drivelash.te.runtime import table as te_table
from drivelash.te.runtime.compensator import Compensator, CompensatorParams
from drivelash.te.runtime.table import build_table

from .analytic import BilinearTE

BAD = [0, 2, -2, 0.5, -0.5, float("nan"), "pos", True, np.array([1]), np.array(0.5), np.array(True)]
GOOD = [
    (1, 1),
    (-1, -1),
    (np.int64(1), 1),
    (np.int32(-1), -1),
    (np.int8(1), 1),
    (1.0, 1),
    (np.float64(-1.0), -1),
    # NumPy 0-d arrays are scalars (np.sign(v[-1:]).squeeze()); taken before the exact check,
    # refused by it ("got array(1.)")
    (np.array(1.0), 1),
    (np.sign(np.array([-0.3])).squeeze(), -1),
]


@pytest.fixture(scope="module")
def table():
    return build_table(BilinearTE(), 0.0, 1.0, 0.05e-3, 10.0, 11)


def _one_line(err) -> str:
    msg = str(err.value)
    assert "\n" not in msg
    return msg


@pytest.mark.parametrize("bad", BAD, ids=repr)
def test_check_direction_refuses(bad):
    with pytest.raises(ParameterError) as err:
        te_table.check_direction(bad, "Owner")
    assert _one_line(err) == f"Owner.direction: must be +1 or -1, got {bad!r}"


@pytest.mark.parametrize(("good", "code"), GOOD, ids=repr)
def test_check_direction_accepts_plus_minus_one(good, code):
    d = te_table.check_direction(good, "Owner")
    assert d == code and type(d) is int


@pytest.mark.parametrize("bad", BAD, ids=repr)
def test_table_refuses_other_directions(table, bad):
    """True and a one-element array were taken as flank +1 (``direction == 1``)."""
    for call in (lambda: table.predict([0.2], [1.0], bad), lambda: table.torque_grid(bad)):
        with pytest.raises(ParameterError) as err:
            call()
        assert _one_line(err).startswith("TETable.direction: must be +1 or -1, got ")


@pytest.mark.parametrize(("good", "code"), GOOD, ids=repr)
def test_table_same_numbers_for_every_form_of_plus_minus_one(table, good, code):
    x = np.linspace(0.0, 1.0, 101)
    tq = np.linspace(-10.0, 10.0, 101)
    ref = table.predict(x, tq, code)
    assert np.array_equal(table.predict(x, tq, good).view(np.uint64), ref.view(np.uint64))
    assert np.array_equal(table.torque_grid(good), table.torque_grid(code))


@pytest.mark.parametrize("bad", [0, 0.5, 2, float("nan"), "neg", True], ids=repr)
def test_compensator_refuses_another_flank(table, bad):
    """Compensator(flank=0) started on +1 and flank=NaN on −1, silently."""
    with pytest.raises(ParameterError) as err:
        Compensator(table, CompensatorParams(), flank=bad)
    assert _one_line(err) == f"Compensator.flank: must be +1 or -1, got {bad!r}"
    comp = Compensator(table, CompensatorParams(), flank=-1)
    before = comp.state.copy()
    with pytest.raises(ParameterError):
        comp.reset(bad)
    assert np.array_equal(comp.state, before)


@pytest.mark.parametrize(("good", "code"), GOOD, ids=repr)
def test_compensator_accepts_every_form_of_plus_minus_one(table, good, code):
    a = Compensator(table, CompensatorParams(), flank=good)
    b = Compensator(table, CompensatorParams(), flank=code)
    assert a.flank == code
    assert np.array_equal(a.state.view(np.uint64), b.state.view(np.uint64))
