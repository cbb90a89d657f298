"""Motor and load channels swapped on the symmetric N = 1 bench (B2): `estimate` must not say
"converged" (it did, with δ̂ = 189.9 ± 1.1 mrad for the true 186 — 7 σ off).

Reference: the simulator's truth (bench-0B δ = 186 mrad, bench-0C 105 mrad) and the same
recording unswapped (negative control: converged, no swap warning).
"""

from __future__ import annotations

import numpy as np
import pytest

import drivelash as dl
from drivelash.estimation.estimator import SWAP_CORRELATION

COLS = ["t", "theta_m", "omega_m", "theta_l", "omega_l", "torque_m"]
SWAP = {"theta_m": "theta_l", "theta_l": "theta_m", "omega_m": "omega_l", "omega_l": "omega_m"}


@pytest.mark.parametrize(("name", "seed"), [("bench-0B", 3), ("bench-0C", 2)])
def test_swapped_channels_are_not_converged(name, seed):
    from drivelash.sim.scenarios import get_scenario

    sc = get_scenario(name)
    tr = sc.simulate(duration=8.0, seed=seed)
    cols = {c: np.asarray(tr[c]) for c in COLS}
    params, delta1 = sc.estimator_drivetrain, sc.estimator_backlash.delta1
    ok = dl.estimate_backlash(dl.Trace(cols), params, delta1)
    assert ok.summary["converged"]
    assert abs(ok.delta - sc.plant_backlash.delta) < 1e-3  # the truth
    assert not any("channels are swapped" in w for w in ok.warnings)
    swapped = dl.estimate_backlash(dl.Trace({SWAP.get(c, c): v for c, v in cols.items()}), params, delta1)
    assert not swapped.summary["converged"]  # was: converged, interval excluding the truth
    w = [w for w in swapped.warnings if "channels are swapped" in w]
    assert len(w) == 1, swapped.warnings
    # the correlation the warning names, by hand (numpy): torque against Δθ = θ_m − θ_l of the swapped file
    rho = np.corrcoef(cols["theta_l"] - cols["theta_m"], cols["torque_m"])[0, 1]
    assert rho < -SWAP_CORRELATION
    assert f"correlation {rho:+.2f}" in w[0]
