"""Engine accuracy against scipy solve_ivp under the same zero-order-hold torque."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from drivelash.physics.drivetrain import plant_params_array
from drivelash.sim.crosscheck import replay_solve_ivp
from drivelash.sim.scenarios import get_scenario

README_ERR = 3e-6  # rad, README: "within 3e-6 rad of `solve_ivp`"


# slow since session 33 (14.4 s of `make test`'s budget): the README's 3e-6 rad figure over 5 s;
# its first second stays fast (test_bench0A_first_second_within_the_readme_figure, below).
@pytest.mark.slow
def test_bench0A_5s_matches_solve_ivp() -> None:
    """5 s of bench-0A: |θ − θ_ivp| ≤ 3e-6 rad on both sides, the figure README.md quotes
    ("within 3e-6 rad of solve_ivp"; measured 2.95e-6 / 2.15e-6 rad), and the worst is that
    figure within 5 % (not an unrelated, much smaller error either).

    solve_ivp (DOP853, rtol 1e-11, atol 1e-12) replays the engine's torque sequence one
    control period at a time; its own error is far below the tolerance. The noiseless
    plant states (``return_states=True``) are compared, not the quantised outputs.
    """
    sc = get_scenario("bench-0A")
    tr = sc.simulate(duration=5.0, return_states=True)
    p = plant_params_array(sc.plant_drivetrain, sc.plant_backlash, model=sc.model, omega_reg=sc.omega_reg)
    X = replay_solve_ivp(np.zeros(4), tr["u"], tr["delta_true"], tr["delta1_true"], p, sc.T_s)
    err_m = np.max(np.abs(X[:, 1] - tr["theta_m_true"]))
    err_l = np.max(np.abs(X[:, 3] - tr["theta_l_true"]))
    print(f"bench-0A 5 s: max |theta_m err| = {err_m:.2e} rad, max |theta_l err| = {err_l:.2e} rad")
    assert max(err_m, err_l) <= README_ERR
    assert max(err_m, err_l) == pytest.approx(README_ERR, rel=0.05)
    # the run is not trivial: the coupling crosses its 1.027 rad gap several times
    dth = tr["theta_m_true"] - tr["theta_l_true"]
    assert np.ptp(dth) > sc.plant_backlash.delta


def test_bench0A_first_second_within_the_readme_figure() -> None:
    """The fast part of the check above (make test): the first 1 s of bench-0A within the README's
    3e-6 rad of ``solve_ivp`` on both sides, and the worst is that figure within 5 % (measured
    2.95e-6 rad, the 5 s run's worst), through the upper contact (Δθ up to 0.5215 rad > δ1 =
    0.5135) and most of the way back across the gap (Δθ down to −0.486 rad). Negative control:
    the same replay against a drive whose load inertia is 1 % off is outside it within 0.25 s."""
    sc = get_scenario("bench-0A")
    tr = sc.simulate(duration=1.0, return_states=True)
    p = plant_params_array(sc.plant_drivetrain, sc.plant_backlash, model=sc.model, omega_reg=sc.omega_reg)
    X = replay_solve_ivp(np.zeros(4), tr["u"], tr["delta_true"], tr["delta1_true"], p, sc.T_s)
    err = max(np.max(np.abs(X[:, 1] - tr["theta_m_true"])), np.max(np.abs(X[:, 3] - tr["theta_l_true"])))
    assert err <= README_ERR, err
    assert err == pytest.approx(README_ERR, rel=0.05)
    dth = tr["theta_m_true"] - tr["theta_l_true"]
    assert dth.max() > sc.plant_backlash.delta1 and dth.min() < 0.0
    wrong = dataclasses.replace(sc.plant_drivetrain, J_l=1.01 * sc.plant_drivetrain.J_l)
    pw = plant_params_array(wrong, sc.plant_backlash, model=sc.model, omega_reg=sc.omega_reg)
    k = len(tr["u"]) // 4  # the first 0.25 s is enough to see it
    Xw = replay_solve_ivp(np.zeros(4), tr["u"][:k], tr["delta_true"][:k], tr["delta1_true"][:k], pw, sc.T_s)
    assert np.max(np.abs(Xw[:, 3] - tr["theta_l_true"][:k])) > 10 * README_ERR
