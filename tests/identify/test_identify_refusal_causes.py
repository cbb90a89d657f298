"""B12 (session 20, tester B): correct recordings refused as "torque sign … wrong".

A physically impossible fit (negative friction) is still refused — nothing is written — but the
warning now leads with the causes the recording points to (straight-line interpolated torque,
too little motion beyond the contacts, a sample rate below the verified one) and keeps "sign
wrong" for where the data support it: the velocity against its position's differences
(Pearson, 5 %) and J_m's sign (the torque accelerates the motor). Before, bench-0B with a
0.12 rad sine (the load moves 55 mrad beyond the 186 mrad gap) was refused with "beta_m = −0.2369
< 0: negative motor friction — torque sign or gain, or the velocity sign, is wrong, or …".
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from drivelash.estimation.identify_two_mass import identify_two_mass
from drivelash.io.trace import Trace
from drivelash.sim.scenarios import get_scenario

GENERIC = "torque sign or gain, or the velocity sign, is wrong"


def _bench(amplitude: float | None = None) -> Trace:
    sc = get_scenario("bench-0B")
    if amplitude is not None:
        sc = replace(sc, reference=replace(sc.reference, amplitude=amplitude))
    return sc.simulate(duration=8.0, seed=3)


def _friction_warnings(r) -> list[str]:
    return [w for w in r.warnings if "negative motor friction" in w or "negative load friction" in w]


def test_small_motion_is_named_not_the_signs():
    """small.toml of the findings with amplitude = 0.12: β_m = −0.2369 (95 % up to −0.0554), refused;
    the cause named first is the motion beyond the contacts, and the signs are said to agree."""
    r = identify_two_mass(_bench(0.12), 1.0)
    assert not r.plausible and not r["delta"].identifiable
    ws = _friction_warnings(r)
    assert ws, r.warnings
    for w in ws:
        assert GENERIC not in w, w
        causes = w.split(" friction — ", 1)[1]
        assert causes.startswith("too little motion beyond the contacts"), w
        assert "the signs agree with the data" in w, w
    ev = r.fit["refusal_evidence"]
    assert ev["load_travel"] < ev["dtheta_span"] and ev["velocity_r"]["motor"] > 0.9


def test_a_wrong_velocity_sign_is_still_named():
    """Negative control: the same bench recording (1 rad sine) with ω_m negated — the motor
    friction comes out negative and the warning says the velocity sign is wrong (r = −0.96)."""
    t = _bench()
    t = t.with_columns({"omega_m": -t["omega_m"]})
    r = identify_two_mass(t, 1.0)
    assert not r.plausible
    ws = [w for w in _friction_warnings(r) if "motor friction" in w]
    assert ws, r.warnings
    for w in ws:
        assert w.split(" friction — ", 1)[1].startswith("the velocity sign is wrong (omega_m runs against"), w
        assert "signs agree" not in w
    assert r.fit["refusal_evidence"]["velocity_r"]["motor"] < -0.9


def test_interpolated_torque_is_counted():
    from drivelash.estimation.identify_two_mass import interpolated_samples

    rng = np.random.default_rng(0)
    u = rng.normal(0.0, 0.01, 10_000)
    assert interpolated_samples(u) == 0
    assert interpolated_samples(np.round(u * 0)) == 0  # constant: standstill, not interpolation
    u[3000:7000] = np.linspace(u[3000], u[6999], 4000)  # a bridged gap of 4000 samples
    assert interpolated_samples(u) == 4000


@pytest.mark.parametrize(
    ("ev", "first"),
    [
        ({"interpolated": 4000}, "4000 samples of the torque are straight-line interpolation"),
        ({"rate_hz": 1000.0}, "the sample rate 1000 Hz is below the 2000 Hz"),
        ({}, "the drive has dynamics the two-mass model lacks — the signs agree"),
    ],
)
def test_friction_causes_lead_with_the_data(ev, first):
    from drivelash.estimation.identify_result import ParameterEstimate
    from drivelash.estimation.identify_two_mass import _friction_causes

    base = {
        "velocity_r": {"motor": 0.97, "load": 0.97},
        "velocity_p": {"motor": 0.0, "load": 0.0},
        "load_travel": 1.8,
        "dtheta_span": 0.19,
        "interpolated": 0,
        "rate_hz": 8000.0,
    }
    J_m = ParameterEstimate.normal("J_m", 8e-4, 5e-5)
    text = _friction_causes("load", {**base, **ev}, J_m)
    assert text.startswith(first), text
    assert GENERIC not in text
    # J_m's interval reaching 0 does not show the torque's sign: the sign stays among the causes
    weak = _friction_causes("load", base, ParameterEstimate.normal("J_m", 8e-4, 5e-4))
    assert "may be wrong" in weak and "signs agree" not in weak


def test_small_motion_verdict_does_not_claim_no_contact():
    """The same 0.12 rad recording's backlash verdict was "no contact: the shaft never carried
    torque" — false: the load travelled 55 mrad, driven beyond each contact (`estimate` gives
    185.73 ± 0.35 mrad for 186). "No contact" rests on the motor-only fit explaining the recording;
    this one is implausible, so the verdict decides nothing and says why (session 22)."""
    r = identify_two_mass(_bench(0.12), 1.0)
    assert "never carried torque" not in r.reason, r.reason
    assert r.reason.startswith("backlash not determined: no contact was confirmed"), r.reason
    assert "travelled 55.2 mrad" in r.reason and "beta_m" in r.reason
    assert not r.backlash_visible and r["delta"].low == 0.0 and r["delta"].high == np.inf
    for n in ("J_l", "K_S", "delta1"):
        assert "never carried torque" not in r[n].reason, (n, r[n].reason)


def test_motion_inside_the_gap_keeps_no_contact():
    """Negative control: a 0.06 rad sine stays inside the 186 mrad gap (the load never moves,
    ptp θ_l = 0) and the motor-only fit is plausible: "no contact" stands."""
    t = _bench(0.06)
    assert np.ptp(t["theta_l"]) == 0.0
    r = identify_two_mass(t, 1.0)
    assert r.plausible, r.warnings
    assert r.reason.startswith("no contact: the shaft never carried torque"), r.reason
