"""Two-mass identification of a linear (prismatic) axis in SI units (session 35, tester G, G1).

A linear axis recorded in m, m/s and N came out with every parameter "not determined" (all 5614
windows "in the gap", "deflection below what the recording resolves" for a 24 µm deflection =
240 encoder counts), while the same samples declared ×1000 as rad identified within 0.5 % of the
truth. Cause: the contact grid's linear solves (:func:`grid_start`) are regularised by 1e-12 of
the *mean* diagonal of their Gram matrices, which the force column (~90 N) dominates — on an axis
whose Δθ spans 5e-5 m the contact columns (~1e-5 m per window) fell below that ridge, and the grid
chose contacts as if the shaft carried no force. The grid now measures a linear axis's lengths in
mm (:func:`grid_length_scale`), the numbers its ridge was validated at on rotary axes in rad.
"""

from __future__ import annotations

import math

import pytest

from drivelash.estimation.identify_two_mass import identify_two_mass
from identify.linear_axis import TRUTH, as_rotary, linear_axis_trace

#: Length scale of the "×1000 as rad" copy.
K = 1e3
#: How each parameter scales when lengths are multiplied by K (forces unchanged): F = m ẍ, F = k x,
#: F = d ẋ, F = β ẋ — masses, stiffness and damping /K; Coulomb friction and offset ×1; gap ×K.
SCALE = {
    "J_m": 1 / K, "J_l": 1 / K, "K_S": 1 / K, "D_S": 1 / K, "beta_m": 1 / K, "beta_l": 1 / K,
    "T_Cm": 1.0, "T_Cl": 1.0, "torque_offset": 1.0, "delta": K, "delta1": K,
}  # fmt: skip


@pytest.fixture(scope="module")
def linear():
    """2 s at 8 kHz, a ±10 mm 1.5 Hz sine through a 20 µm gap (8 crossings); its identification in
    SI and that of the same samples ×1000 declared as rad."""
    tr = linear_axis_trace(20e-6, 10e-6, duration=2.0, freq=1.5)
    return tr, identify_two_mass(tr, 1.0), identify_two_mass(as_rotary(tr, K), 1.0)


def test_linear_axis_in_si_identifies_like_the_same_data_declared_as_rad(linear):
    """Same physics in another unit, same result: every value and interval bound of the SI fit,
    scaled as physics says, equals the ×1000-as-rad fit's to 1e-6 relative (measured: ≤ 2e-8 on
    the tester's lin20 / lin28 / lin50 recordings; the fit is the same least-squares problem in
    other units, so only rounding differs). Before the fix: J_m, J_l, K_S, δ, δ1 not determined."""
    _, si, rad = linear
    assert si.backlash_visible and rad.backlash_visible, si.verdict
    for n, q in rad.parameters.items():
        p = si.parameters[n]
        assert p.identifiable and q.identifiable, (n, p.reason)
        tol = 1e-6 * max(abs(q.high - q.low), abs(q.value))
        for a, b in ((p.value, q.value), (p.low, q.low), (p.high, q.high)):
            assert math.isclose(a * SCALE[n], b, rel_tol=0.0, abs_tol=tol), (n, a * SCALE[n], b)


def test_linear_axis_in_si_recovers_the_truth(linear):
    """Masses, stiffness, gap and flank in SI: the truth inside each 95 % interval, and within
    2 % (J_m, J_l), 1 % (K_S) and 0.5 % (δ, δ1). Measured on this 2 s recording: J_m −0.7 %,
    J_l +0.1 %, K_S +0.3 %, δ +0.10 %, δ1 +0.11 %."""
    _, si, _ = linear
    truth = {**TRUTH, "delta": 20e-6, "delta1": 10e-6}
    limits = {"J_m": 0.02, "J_l": 0.02, "K_S": 0.01, "delta": 0.005, "delta1": 0.005}
    for n, lim in limits.items():
        p = si[n]
        assert p.covers(truth[n]), (n, p.value, p.interval_text())
        assert abs(p.value / truth[n] - 1.0) <= lim, (n, p.value)
