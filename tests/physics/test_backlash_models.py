"""Backlash physics: deadzone (10) at hand-computed points, smooth (12) → (10), ∂T_l/∂δ (50)."""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.physics.backlash import deadzone_torque, dtorque_ddelta, smooth_torque

K_S, D_S, DELTA, DELTA1 = 10.0, 0.5, 0.2, 0.05  # contacts at −0.05 and +0.15 rad


@pytest.mark.parametrize(
    ("dtheta", "domega", "expected"),
    [
        # lower flank: K_S (Δθ + δ1) + D_S Δω = 10·(−0.10) + 0.5·0.2
        (-0.15, 0.2, -0.9),
        # upper flank: K_S (Δθ + δ1 − δ) + D_S Δω = 10·(0.10) + 0.5·(−0.4)
        (0.25, -0.4, 0.8),
        # inside the gap: no torque whatever the relative velocity
        (0.0, 3.0, 0.0),
        (0.1, -2.0, 0.0),
        # the contact points themselves belong to the gap (10): −δ1 ≤ Δθ ≤ δ − δ1
        (-0.05, 1.0, 0.0),
        (0.15, 1.0, 0.0),
        # just beyond the upper contact: damping term only, K_S·1e-9 + D_S·1
        (0.15 + 1e-9, 1.0, 10.0 * 1e-9 + 0.5),
    ],
)
def test_deadzone_torque_hand_computed(dtheta: float, domega: float, expected: float) -> None:
    assert deadzone_torque(dtheta, domega, K_S, D_S, DELTA, DELTA1) == pytest.approx(expected, abs=1e-12)


def _max_dev_outside(alpha: float, domega: float) -> float:
    contacts = np.array([-DELTA1, DELTA - DELTA1])
    x = np.linspace(-0.6, 0.6, 200_001)
    x = x[x != 0.0]  # (12) switches its sgn(Δθ) term at 0, away from both contacts
    far = np.min(np.abs(x[:, None] - contacts[None, :]), axis=1) > 10.0 / alpha
    dev = smooth_torque(x, domega, K_S, D_S, DELTA, DELTA1, alpha) - deadzone_torque(
        x, domega, K_S, D_S, DELTA, DELTA1
    )
    return float(np.max(np.abs(dev[far])))


def test_smooth_model_converges_to_deadzone() -> None:
    alphas = [1e2, 1e3, 1e4, 1e5]
    dev0 = [_max_dev_outside(a, 0.0) for a in alphas]
    # Δω = 0: the largest deviation sits in the gap just above Δθ = 0, where (12) has
    # T = (δ1 − δ)·K_BL and K_BL ≈ (K_S/π)(1/(α(δ − δ1)) + 1/(α δ1)) (atan tails), i.e.
    # |T − 0| ≈ K_S δ / (π α δ1): it shrinks like 1/α.
    for a, d in zip(alphas[1:], dev0[1:], strict=True):
        assert d == pytest.approx(K_S * DELTA / (np.pi * a * DELTA1), rel=0.01)
    assert all(b < a / 1.5 for a, b in zip(dev0, dev0[1:], strict=False))
    # Δω ≠ 0: the damping part of (12) near a contact, (D_S/K_S)Δω·K_BL at distance 10/α,
    # is D_S Δω (1/2 − atan(10)/π) whatever α: the deviation shrinks towards that floor.
    dev1 = [_max_dev_outside(a, 0.7) for a in alphas]
    assert all(b < a for a, b in zip(dev1, dev1[1:], strict=False))
    assert dev1[-1] == pytest.approx(D_S * 0.7 * (0.5 - np.arctan(10.0) / np.pi), rel=0.03)


@pytest.mark.parametrize("alpha", [50.0, 300.0, 1000.0])
def test_dtorque_ddelta_matches_central_differences(alpha: float) -> None:
    rng = np.random.default_rng(7)
    dtheta = rng.uniform(-0.4, 0.4, 400)
    dtheta = dtheta[np.abs(dtheta) > 1e-3]  # keep sgn(Δθ) fixed over the difference
    domega = rng.uniform(-2.0, 2.0, dtheta.size)
    h = 1e-4 / alpha  # step well inside the transition width 1/α
    fd = (
        smooth_torque(dtheta, domega, K_S, D_S, DELTA + h, DELTA1, alpha)
        - smooth_torque(dtheta, domega, K_S, D_S, DELTA - h, DELTA1, alpha)
    ) / (2 * h)
    an = dtorque_ddelta(dtheta, domega, K_S, D_S, DELTA, DELTA1, alpha)
    # rel 1e-6 of each value, floored at 1e-6·K_S where the sensitivity vanishes (far in the gap)
    np.testing.assert_allclose(an, fd, rtol=1e-6, atol=1e-6 * K_S)
    assert np.max(np.abs(an)) > K_S  # the test does look at non-trivial values


def test_ufuncs_are_built_on_first_use_not_at_import() -> None:
    """Importing the physics modules builds no ufunc: eager ``vectorize`` signatures compiled (or
    loaded from numba's cache) all eight in every process that imported them — ≈ 1.2 s of each
    CLI start (session 26). A fresh interpreter imports the estimator, which imports both modules;
    then the first use builds the ufunc, with the kernel's docstring, and keeps it."""
    import json
    import subprocess
    import sys

    code = (
        "import json\n"
        "import drivelash.estimation.deadzone\n"
        "from drivelash.physics import backlash, friction\n"
        "names = ['deadzone_torque', 'smooth_stiffness', 'smooth_torque', 'chi1', 'chi2',"
        " 'dtorque_ddelta', 'excitation']\n"
        "before = [n for n in names if n in vars(backlash)]\n"
        "before += ['friction'] if 'friction' in vars(friction) else []\n"
        "v = float(backlash.deadzone_torque(0.5, 0.0, 10.0, 0.0, 0.2, 0.1))\n"
        "print(json.dumps({'before': before, 'v': v, 'kept': 'deadzone_torque' in vars(backlash),"
        " 'doc': backlash.deadzone_torque.__doc__ == backlash.deadzone_torque_scalar.__doc__,"
        " 'listed': all(n in dir(backlash) for n in names)}))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    res = json.loads(out.stdout.strip().splitlines()[-1])
    assert res["before"] == [], res
    assert res["v"] == pytest.approx(10.0 * (0.5 + 0.1 - 0.2)), res  # upper flank, K_S (Δθ + δ1 − δ)
    assert res["kept"] and res["doc"] and res["listed"], res
    with pytest.raises(AttributeError, match="no attribute 'chi3'"):
        import drivelash.physics.backlash as b

        _ = b.chi3
