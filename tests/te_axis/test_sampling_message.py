"""The sample-rate error quotes one limit per figure (finding A13, session 20 tester A).

Before: "needs <= 1.34 mm: record at >= 374 Hz" — 1.34 mm is the error limit (λ_c/2), 374 Hz
the warning limit (λ_c/10) at 100 mm/s; the rate of the error limit (75 Hz) was not given.
Reference by hand for the synthetic bench: λ_c = pitch/3; at v the error limit is
v/(λ_c/2) Hz, the warning limit v/(λ_c/10) Hz.
"""

from __future__ import annotations

import dataclasses

from drivelash.te.protocol.plausibility import check_runs

from .synth import BENCH, record, standard_runs


def test_both_rates_are_named_with_their_limits():
    runs = [dataclasses.replace(r, lo=0.05, hi=0.45) for r in standard_runs()]
    recs = [record(r, f"run{i:02d}.csv") for i, r in enumerate(runs)]
    r, sub = recs[4], slice(None, None, 50)  # 100 mm/s sampled at 20 Hz: 5 mm between samples
    recs[4] = dataclasses.replace(
        r, t=r.t[sub], x_T=r.x_T[sub], theta_m=r.theta_m[sub], torque_m=r.torque_m[sub]
    )
    rep = check_runs(recs, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0)
    (f,) = [f for f in rep.findings if f.check == "sampling"]
    lam_c = BENCH.tooth_pitch / 3
    v = 0.1
    err_hz, warn_hz = v / (0.5 * lam_c), v / (0.1 * lam_c)
    assert f"needs <= {0.5 * lam_c * 1e3:.3g} mm (>= {err_hz:.0f} Hz at this speed)" in f.message, f.message
    assert f"record at >= {warn_hz:.0f} Hz to avoid the coarse-sampling warning too" in f.message
