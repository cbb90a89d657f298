"""B9, first half (session 20, tester B): below 2 kHz the two-mass identification's δ interval is
not honest — a known miss, kept as a goal.

bench-0B (δ = 186 mrad, δ1 = 93 mrad), 8 s, seed 3, recorded at 1 kHz (every 8th sample of the
8 kHz simulation, as a drive's trace samples): δ = 187.55 [187.20, 187.90] mrad. README and
docs/assumptions.md ("Sample rates below 2 kHz") quote this figure and say the identification is
verified down to 2 kHz; ruled out as causes: the window length (8 kHz with 2 ms windows gives
186.08), a decimate-by-2 widening (shift +0.21 mrad against a 1.55 mrad bias); part of it is the
torque held over the sample (exact 1 ms means: 187.26 [186.29, 188.23]).
"""

from __future__ import annotations

import pytest

from drivelash.estimation.identify_two_mass import identify_two_mass
from drivelash.io.trace import Trace
from drivelash.sim.scenarios import get_scenario

RECORDED = ["t", "theta_m", "omega_m", "theta_l", "omega_l", "torque_m"]


@pytest.fixture(scope="module")
def at_1khz():
    tr = get_scenario("bench-0B").simulate(duration=8.0, seed=3)
    return identify_two_mass(Trace({c: tr[c][::8].copy() for c in RECORDED}, meta=dict(tr.meta)), 1.0)


def test_the_readme_figure_at_1khz(at_1khz):
    """The figure README quotes (rounded to 0.01 mrad there)."""
    d = at_1khz["delta"]
    assert (round(1e3 * d.value, 2), round(1e3 * d.low, 2), round(1e3 * d.high, 2)) == (
        187.55,
        187.20,
        187.90,
    )


@pytest.mark.xfail(
    strict=True,
    reason="known miss (B9): at 1 kHz δ = 187.55 [187.20, 187.90] mrad for the true 186 mrad (and δ1 93.73 "
    "[93.58, 93.89] for 93); goal: the 95 % interval holds the truth at a drive's usual trace rate; "
    "because a discretisation bias of the windowed equation error below 2 kHz is not in the intervals "
    "(docs/assumptions.md, 'Sample rates below 2 kHz')",
)
def test_delta_interval_holds_the_truth_at_1khz(at_1khz):
    assert at_1khz["delta"].covers(0.186), at_1khz["delta"]
