"""The compensator and ``te validate`` at the edges of the valid range (issue 12 item 3).

The table ``te validate`` and the compensator read spans where the model was measured
(:func:`~drivelash.te.runtime.table.measured_range`), the range ``te export`` writes — not
the wider span of the no-load runs a model used to store. Beyond the table the compensator
holds its edge value (as a SINUMERIK compensation table holds its first and last value,
docs/assumptions.md) and counts those cycles; ``te validate`` states the valid range and the
share of each protocol that ran outside it.
"""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.errors import ParameterError
from drivelash.te.protocol.bench import ValidationConfig, compensator_for, table_for
from drivelash.te.protocol.passes import pass_trajectory, run_pass
from drivelash.te.protocol.validate import outside_by_section, valid_range_report
from drivelash.te.runtime.compensator import S_TE_HAT, X_SLACK, Compensator, CompensatorParams
from drivelash.te.runtime.table import build_table, measured_range

from .analytic import BenchTE, SineTE

T_SC = 5e-3


def _cycles(x_lo: float, x_hi: float, v: float = 0.1) -> np.ndarray:
    """Set positions at the cycle instants of a pass at ``v`` [m/s], plus the look-ahead one."""
    return np.arange(x_lo, x_hi + 1e-12, v * T_SC)


def _run(table, x_d):
    c = Compensator(table, CompensatorParams(), 1)
    n = x_d.size - 1
    v, vte, vbl = c.run(x_d, np.full(n, 3.0), np.full(n, 5.0), np.zeros(n))
    return c, v, vte, vbl


def test_compensator_holds_the_edge_value_and_counts_the_cycles_outside():
    table = build_table(SineTE(), 0.1, 0.2, 0.1e-3, 10.0, 3)
    x_d = _cycles(0.05, 0.25)
    c, v, vte, vbl = _run(table, x_d)
    a, b = x_d[:-1], x_d[1:]
    out = (np.minimum(a, b) < 0.1 - X_SLACK) | (np.maximum(a, b) > table.x_grid[-1] + X_SLACK)
    beyond = (np.maximum(a, b) < 0.1) | (np.minimum(a, b) > table.x_grid[-1])
    assert 40 < out.sum() < x_d.size - 1 and beyond.sum() > 0
    assert c.cycles_outside == int(out.sum())
    # held, not extrapolated: no TE rate where both set positions lie beyond the grid ...
    np.testing.assert_array_equal(vte[beyond], 0.0)
    np.testing.assert_array_equal(vbl, 0.0)  # no flank change
    # ... so the compensator's running TE is the table's change over its grid, no more
    te = [table.predict(x, 3.0, 1)[()] for x in (0.1, table.x_grid[-1])]
    assert c.state[S_TE_HAT] == pytest.approx(te[1] - te[0], abs=1e-12)
    # and inside the grid the rate is the table's
    inside = ~out
    want = (table.predict(b[inside], 3.0, 1) - table.predict(a[inside], 3.0, 1)) / T_SC
    np.testing.assert_allclose(vte[inside], want, rtol=0, atol=1e-12)
    c.reset(1)
    assert c.cycles_outside == 0


def test_a_motion_inside_the_table_counts_nothing():
    # negative control: the same table, a pass within its grid
    table = build_table(SineTE(), 0.1, 0.2, 0.1e-3, 10.0, 3)
    c, *_ = _run(table, _cycles(0.1, 0.2))
    assert c.cycles_outside == 0


class _RunsSpanModel(SineTE):
    """Stored valid range 0 … 0.5 m (the runs' span); no-load curves measured on 0.005 … 0.495 m."""

    class context:  # noqa: N801 - an attribute namespace like ModelContext
        class valid_range:  # noqa: N801
            x_min, x_max, torque_max = 0.0, 0.5, 9.0

    def geometric_range(self):
        return 0.005, 0.495


def test_validate_table_spans_the_measured_range_not_the_stored_one():
    from drivelash.physics.rack_pinion import RackPinionBench

    m = _RunsSpanModel()
    tab = table_for(m, RackPinionBench(), ValidationConfig(), torque_max=9.0)
    assert measured_range(m) == (0.005, 0.495)
    # before: the stored valid range, 0 … 0.5 m, where the no-load curves are held flat
    assert tab.x0 == pytest.approx(0.005, abs=1e-12)
    assert tab.x_grid[-1] == pytest.approx(0.495, abs=1e-9)
    with pytest.raises(ParameterError, match=r"valid range \[0\.005, 0\.495\] m"):
        build_table(m, 0.0, 0.5, 1e-3, 9.0, 3)
    cfg = ValidationConfig().resolved(2.2, measured_range(m))
    assert cfg.x_range == (0.005, 0.495)


@pytest.fixture(scope="module")
def bench_sim():
    from drivelash.physics.rack_pinion import RackPinionBench, TransmissionErrorModel
    from drivelash.sim.rack_axis import RackAxisSimulator

    bench = RackPinionBench()
    return RackAxisSimulator(bench, TransmissionErrorModel.generate(bench, seed=3))


def test_a_pass_beyond_the_table_is_marked_per_sample_and_section(bench_sim):
    sim = bench_sim
    table = build_table(BenchTE(sim.bench, sim.te_model), 0.15, 0.25, 0.1e-3, 10.0, 11)
    params = compensator_for(sim.bench, table)
    v = 0.1
    _, x_d, v_d = pass_trajectory(sim, 0.1, 0.3, v, 1)
    comp = run_pass(sim, x_d, v_d, 1000.0, Compensator(table, params, 1))
    unc = run_pass(sim, x_d, v_d, 1000.0, None)
    assert not unc["outside"].any()
    # every 40 samples one cycle: outside where its set position (or the look-ahead) left 0.15 … 0.25
    nc = int(round(T_SC / sim.T_s))
    xs = comp["x_d"][::nc]
    nxt = np.append(xs[1:], x_d[min(xs.size * nc, x_d.size - 1)])
    want = (np.minimum(xs, nxt) < 0.15 - X_SLACK) | (np.maximum(xs, nxt) > table.x_grid[-1] + X_SLACK)
    np.testing.assert_array_equal(comp["outside"][::nc], want.astype(float))
    # per section: the share of its scored (constant-velocity) samples whose set position lies
    # beyond the table, to within one cycle (0.5 mm of the ~40 mm ramp-shortened half sections)
    edges = np.array([0.1, 0.2, 0.3])
    share = outside_by_section(comp, v, edges)
    m = np.abs(np.abs(comp["v_d"]) - v) < 1e-9
    sec = np.searchsorted(edges, comp["x_T"][m], side="right") - 1
    beyond = (comp["x_d"][m] < 0.15) | (comp["x_d"][m] > 0.25)
    ref = [np.mean(beyond[sec == i]) for i in (0, 1)]
    np.testing.assert_allclose(share, ref, atol=0.02)
    assert 0.3 < min(share) and max(share) < 0.6
    # negative control: the same pass within the table is never marked
    _, x_in, v_in = pass_trajectory(sim, 0.16, 0.24, v, 1)
    inside = run_pass(sim, x_in, v_in, 1000.0, Compensator(table, params, 1))
    assert not inside["outside"].any()


def test_the_summary_states_the_valid_range_and_what_ran_outside():
    table = build_table(SineTE(), 0.055, 0.445, 0.2e-3, 9.0, 3)
    rows = [{"x_start": 0.05 + 0.1 * i, "x_end": 0.15 + 0.1 * i, "outside_share": s}
            for i, s in enumerate((0.05, 0.0, 0.0, 0.05))]  # fmt: skip
    rep = valid_range_report((0.055, 0.445), table, (0.05, 0.45), {"passes": 0.025, "sine": 0.0}, rows)
    assert (rep["x_min"], rep["x_max"]) == (0.055, 0.445)
    assert (rep["table_x_min"], rep["table_x_max"]) == pytest.approx((0.055, 0.445))
    assert (rep["passes_x_min"], rep["passes_x_max"]) == (0.05, 0.45)
    assert rep["cycles_outside_share"] == {"passes": 0.025, "sine": 0.0}
    assert (rep["sections_outside"], rep["sections_scored"]) == (2, 4)
    assert "edge value" in rep["beyond_table"]
