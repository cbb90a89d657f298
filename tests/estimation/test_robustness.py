"""Issue 11 items 2–4: the online estimator is never confidently wrong.

Every recording here comes from the *independent* simulator (tests/estimation/independent.py:
solve_ivp LSODA, continuous P/PI cascade, tanh friction — no code shared with drivelash.sim),
so the estimator cannot be tuned to its own simulator's quirks. The rule checked everywhere:
either |δ̂ − δ| is within the goal, or the result is not ``converged`` and says why (a
warning or an excitation verdict). ``converged`` together with a wrong δ̂ fails the test.

Fast part: the bench rig at 1 kHz for 12 s (one simulation of ≈ 2 s shared by the module),
δ1 offsets, ``--method paper`` with a wrong δ1, the parameter-mismatch sweep on the rig,
positions in degrees, a shifted load-encoder zero, a still load through the command line.
Slow part: gravity load on compliant drives, the stiff geared drive, the mismatch sweep on
the random drives of the generalisation test.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from drivelash.estimation.estimator import DeadzoneEstimator, EstimationResult
from drivelash.io.trace import Trace

from .independent import RIG, IndependentDrive, simulate_independent

T_S = 1e-3
DURATION = 12.0

#: Each parameter stated ×0.5 and ×2 (friction also ×3), singly and combined (issue 11).
MISMATCH = {
    "true": {},
    "K_S×0.5": dict(K_S=0.5),
    "K_S×2": dict(K_S=2.0),
    "J_l×0.5": dict(J_l=0.5),
    "J_l×2": dict(J_l=2.0),
    "D_S×0.5": dict(D_S=0.5),
    "D_S×2": dict(D_S=2.0),
    "T_Cl×0.5": dict(T_Cl=0.5),
    "T_Cl×2": dict(T_Cl=2.0),
    "T_Cl×3": dict(T_Cl=3.0),
    "all×0.5": dict(K_S=0.5, J_l=0.5, D_S=0.5, T_Cl=0.5),
    "all×2": dict(K_S=2.0, J_l=2.0, D_S=2.0, T_Cl=2.0),
    "K_S×0.5 J_l×1.5 T_Cl×3": dict(K_S=0.5, J_l=1.5, T_Cl=3.0),
    "K_S×2 J_l×0.5 T_Cl×3": dict(K_S=2.0, J_l=0.5, T_Cl=3.0),
}


def _run(drive: IndependentDrive, trace, delta1: float | None = None, method: str = "default", **scale):
    d1 = drive.delta1 if delta1 is None else delta1
    return DeadzoneEstimator(drive.drivetrain(**scale), d1, trace.T_s, method=method).run(trace)


def _flagged(r: EstimationResult) -> bool:
    """Not converged, with a stated cause (an excitation verdict or a blocking warning)."""
    blocking = [w for w in r.warnings if not w.startswith("note:")]
    return not r.converged and (not r.excitation_ok or bool(blocking))


def _accurate_or_flagged(r: EstimationResult, delta: float, tol: float) -> str | None:
    err = r.delta - delta
    if abs(err) <= tol or _flagged(r):
        return None
    return f"err {1e3 * err:+.2f} mrad, converged={r.converged}, warnings={r.warnings}, reason={r.reason}"


@pytest.fixture(scope="module")
def rig_trace():
    return simulate_independent(RIG, duration=DURATION, T_s=T_S)


def test_true_parameters_converge_accurately(rig_trace):
    """Negative control of the flags: with the true drive the estimate is accurate *and* claimed."""
    r = _run(RIG, rig_trace)
    assert r.converged and r.excitation_ok, (r.reason, r.warnings)
    assert abs(r.delta - RIG.delta) <= 1e-3
    # the 95 % interval from the estimator's own statistics covers the truth and is not vacuous
    lo, hi = r.delta_interval
    assert lo <= RIG.delta <= hi
    assert 0 < r.delta_std < 1e-3


# δ1 offsets of ±2, ±4, ±20 mrad and δ1 wrong by 90 % of its room either way
# (δ1 must stay in [0, δ]: +0.9 (δ − δ1) = +83.7 mrad, −0.9 δ1 = −83.7 mrad on the rig).
D1_OFFSETS = [2e-3, -2e-3, 4e-3, -4e-3, 20e-3, -20e-3, 0.9 * (RIG.delta - RIG.delta1), -0.9 * RIG.delta1]


@pytest.mark.parametrize("method", ["default", "paper"])
def test_delta1_offsets_accurate_or_flagged(rig_trace, method):
    bad = {}
    for e in D1_OFFSETS:
        r = _run(RIG, rig_trace, RIG.delta1 + e, method)
        msg = _accurate_or_flagged(r, RIG.delta, 1e-3)
        if msg:
            bad[f"{1e3 * e:+.1f} mrad"] = msg
        # the δ1 check runs and is reported whatever the method
        assert r.extra.get("delta1_check_result") in (
            "consistent",
            "switched",
            "inconsistent",
            "inconclusive",
        )
    assert not bad, bad


def test_default_law_corrects_delta1_offsets(rig_trace):
    """Item 4: the joint δ/δ1 law takes over and is accurate for +4 mrad (below the old 5 mrad
    switch threshold: the old law left +4 mrad as 6.5 mrad error), ±20 mrad and ±90 %."""
    for e in (4e-3, 20e-3, -20e-3, 0.9 * (RIG.delta - RIG.delta1), -0.9 * RIG.delta1):
        r = _run(RIG, rig_trace, RIG.delta1 + e)
        assert r.converged and abs(r.delta - RIG.delta) <= 1e-3, (e, r.delta - RIG.delta, r.warnings)
        assert r.extra["offset_switched"]


@pytest.mark.xfail(
    strict=True,
    reason="known miss: δ1 +2 / −2 / −4 mrad on the independent rig (12 s, 1 kHz): measured "
    "+1.98 / −3.73 / −6.22 mrad error, each flagged (δ1 inconsistent, not converged) but not "
    "corrected; goal: corrected within 1 mrad, because the joint law's switch conditions "
    "(residual ratio < 0.8, lower/upper asymmetry > 1.5) are not met when the offset is of the "
    "order of the contact deflection (≈ 1 mrad here) or moves the lower contact into the gap. "
    "Item 4's other route is met: with --identify the offline δ1 replaces the contradicted one "
    "(test_identify_supplies_delta1_the_recording_contradicts: −0.29 mrad for each)",
)
def test_default_law_corrects_small_delta1_offsets(rig_trace):
    for e in (2e-3, -2e-3, -4e-3):
        r = _run(RIG, rig_trace, RIG.delta1 + e)
        assert r.converged and abs(r.delta - RIG.delta) <= 1e-3, (e, r.delta - RIG.delta)


def _rig_config(delta1: float):
    """The rig's true drive train and a stated δ1 [rad] as a drive configuration."""
    from drivelash.io.config import loads_config

    dt = RIG.drivetrain()
    rows = "\n".join(
        f"{k} = {float(getattr(dt, k))!r}"
        for k in ("N", "J_m", "J_l", "K_S", "D_S", "T_Cm", "T_Cl", "beta_m", "beta_l")
    )
    return loads_config(f"[drivetrain]\n{rows}\n[backlash]\ndelta1 = {delta1!r}\n")


@pytest.mark.parametrize("e", [2e-3, -2e-3, -4e-3])
def test_identify_supplies_delta1_the_recording_contradicts(rig_trace, e):
    """Item 4 of issue 11, its second route: with ``--identify`` the offline result supplies δ1.
    A configured δ1 off by +2 / −2 / −4 mrad — the offsets the online law flags but does not
    correct (strict xfail above) — lies outside the identified δ1's interval (rig: 92.885 mrad,
    [92.73, 93.04]): the identified δ1 is used, with a warning naming both, and δ̂ is within 1 mrad
    and converged. Negative controls: the online law alone on the same configuration is off by
    more than 1 mrad and not converged; the true δ1 is kept (no warning)."""
    from drivelash.estimation.backlash_api import estimate_with_identification

    est = estimate_with_identification(rig_trace, _rig_config(RIG.delta1 + e))
    s = est.summary
    assert s["delta1_source"] == "identification" and s["delta1_configured"] == RIG.delta1 + e
    assert abs(s["delta1"] - RIG.delta1) <= 0.3e-3, s["delta1"]
    assert any(w.startswith("[backlash] delta1 = ") and "is used" in w for w in s["warnings"]), s["warnings"]
    # both values and the interval to the µrad (with 4 significant digits the interval of the
    # README's bench-0A run printed as "[513.5, 513.5] mrad")
    w = next(w for w in s["warnings"] if w.startswith("[backlash]"))
    assert f"delta1 = {1e3 * (RIG.delta1 + e):.3f} mrad" in w and f"δ1 = {1e3 * s['delta1']:.3f} mrad" in w, w
    assert s["converged"] and abs(s["delta"] - RIG.delta) <= 1e-3, (s["delta"] - RIG.delta, s["warnings"])
    alone = _run(RIG, rig_trace, RIG.delta1 + e)
    assert not alone.converged and abs(alone.delta - RIG.delta) > 1e-3
    # README figures: "δ̂ within 0.29 mrad, where the online law alone is off by +2.0 / −3.7 / −6.2 mrad"
    assert s["delta"] - RIG.delta == pytest.approx(-0.288e-3, abs=0.005e-3)
    assert alone.delta - RIG.delta == pytest.approx(
        {2e-3: 1.976e-3, -2e-3: -3.729e-3, -4e-3: -6.222e-3}[e], abs=0.05e-3
    )
    if e == 2e-3:
        kept = estimate_with_identification(rig_trace, _rig_config(RIG.delta1)).summary
        assert kept["delta1_source"] == "config" and "delta1_configured" not in kept
        assert not any(w.startswith("[backlash] delta1") for w in kept["warnings"])
        assert kept["converged"] and abs(kept["delta"] - RIG.delta) <= 1e-3


@pytest.mark.parametrize("e", [10e-3, -36e-3])
def test_paper_method_wrong_delta1_is_flagged(rig_trace, e):
    """``--method paper`` with δ1 off by +10 / −36 mrad: δ̂ follows δ1, so it must be flagged."""
    r = _run(RIG, rig_trace, RIG.delta1 + e, "paper")
    assert abs(r.delta - RIG.delta) > 5e-3  # the paper law does take the wrong δ1 over (control)
    assert not r.converged
    assert any("δ1 is inconsistent" in w for w in r.warnings), r.warnings


def test_mismatch_sweep_rig(rig_trace):
    """Each of K_S, J_l, D_S, T_Cl ×0.5 / ×2 (friction ×3), singly and combined: |δ̂ − δ| ≤ 2 mrad
    or flagged and not converged; never worse than the paper law by > 1 mrad without a flag."""
    bad = {}
    for name, scale in MISMATCH.items():
        r = _run(RIG, rig_trace, **scale)
        rp = _run(RIG, rig_trace, method="paper", **scale)
        msg = _accurate_or_flagged(r, RIG.delta, 2e-3)
        if msg:
            bad[name] = msg
        if r.converged and abs(r.delta - RIG.delta) > abs(rp.delta - RIG.delta) + 1e-3:
            bad[name + " (vs paper)"] = (
                f"{1e3 * (r.delta - RIG.delta):+.2f} vs {1e3 * (rp.delta - RIG.delta):+.2f}"
            )
    assert not bad, bad


def test_mismatch_sweep_rig_paper_law(rig_trace):
    """The plausibility checks hold for ``--method paper`` too: accurate within 2 mrad or flagged.
    (Was a known miss: K_S×0.5, J_l×1.5, T_Cl×3 converged at −3.6 mrad with no flag.)"""
    bad = {}
    for name, scale in MISMATCH.items():
        rp = _run(RIG, rig_trace, method="paper", **scale)
        msg = _accurate_or_flagged(rp, RIG.delta, 2e-3)
        if msg:
            bad[name] = msg
    assert not bad, bad


def test_paper_law_is_checked_against_the_default_law(rig_trace):
    """What flags the paper law's −3.6 mrad: the default law (stiffness scale learnt) on the same
    recording puts δ elsewhere, and the paper law's interval must reach it."""
    rp = _run(RIG, rig_trace, method="paper", K_S=0.5, J_l=1.5, T_Cl=3.0)
    assert abs(rp.delta - RIG.delta) > 2e-3  # control: the paper law is that far off
    assert rp.extra["law_disagreement"] > 2e-3
    assert not rp.converged and any("paper law and the default law" in w for w in rp.warnings)
    lo, hi = rp.delta_interval
    assert lo <= RIG.delta <= hi and lo <= rp.extra["delta_default_law"] <= hi
    # with the true parameters the two laws agree and the paper law keeps its claim
    r0 = _run(RIG, rig_trace, method="paper")
    assert r0.extra["law_disagreement"] < 2e-3 and r0.converged, (r0.extra["law_disagreement"], r0.warnings)


#: A geared drive with coarse encoders (random drive ind0.5 of the independent sweep): N = 10,
#: 2048 counts on both encoders, so the load sees counts of 3.07 mrad (load encoder) and
#: 0.31 mrad (motor encoder / N).
GEARED = IndependentDrive(
    J_m=7.68e-4, J_l=6.09e-3, N=10.0, K_S=57.2, D_S=0.0274, T_Cm=0.0192, T_Cl=0.0161,
    beta_m=0.001, beta_l=8.05e-4, delta=0.2627, delta1=0.0649,
)  # fmt: skip
GEARED_RUN = dict(duration=20.0, T_s=5e-4, amplitude=1.42, frequency=0.70, bandwidth=48.0, torque_limit=28.6,
                  counts=2048, sigma_omega=0.01, seed=5)  # fmt: skip


@pytest.fixture(scope="module")
def geared_traces():
    return {r: simulate_independent(GEARED, reading=r, **GEARED_RUN) for r in ("floor", "round")}


def test_encoder_reading_convention_is_covered(geared_traces):
    """The +2.1 mrad bias of ind0.1/ind0.5 with the true parameters: encoders that truncate
    offset Δθ = θ_m/N − θ_l by q/2 (1 − 1/N) = 1.38 mrad here, exactly as a δ1 error would, and
    nothing in the data tells truncation from rounding. Rounding encoders: accurate; truncating
    ones: ≈ +2 mrad (the offset, amplified through κ). Either way the interval covers the truth
    and convergence is not claimed (it was, at +2.1 mrad ± 1.0, before the reading-convention
    bound), since ±2 mrad cannot be promised with these encoders and a δ1 from the drawing."""
    q = 2 * math.pi / 2048
    rr = _run(GEARED, geared_traces["round"])
    assert rr.extra["encoder_count_load"] == pytest.approx(q, rel=1e-9)
    assert rr.extra["encoder_count_motor"] == pytest.approx(q, rel=1e-9)
    assert rr.extra["encoder_offset"] == pytest.approx(0.5 * q * (1 - 1 / GEARED.N), rel=1e-9)
    assert abs(rr.delta - GEARED.delta) <= 1e-3, (rr.delta - GEARED.delta, rr.warnings)
    lo, hi = rr.delta_interval
    assert lo <= GEARED.delta <= hi
    rf = _run(GEARED, geared_traces["floor"])
    assert rf.delta - GEARED.delta > 1.5e-3  # control: the truncation bias is there
    lo, hi = rf.delta_interval
    assert lo <= GEARED.delta <= hi, (rf.delta - GEARED.delta, rf.delta_std)
    assert _flagged(rf) and any("encoders' counts" in w for w in rf.warnings), rf.warnings


@pytest.mark.parametrize("reading", ["truncate", "nearest"])
def test_stated_encoder_reading_is_used(geared_traces, reading):
    """A stated convention removes the margin: truncation is corrected in δ1 (the +2 mrad of
    the truncating run becomes ≤ 1 mrad), rounding needs nothing; both then converge."""
    tr = geared_traces["floor" if reading == "truncate" else "round"]
    r = DeadzoneEstimator(GEARED.drivetrain(), GEARED.delta1, tr.T_s, encoder_reading=reading).run(tr)
    assert r.extra["encoder_reading"] == reading and r.extra["encoder_offset_bound"] == 0.0
    assert r.converged and abs(r.delta - GEARED.delta) <= 1e-3, (r.delta - GEARED.delta, r.warnings)
    # the recording's own metadata states it just as well (the project's simulator does)
    r2 = _run(GEARED, Trace(dict(tr.columns), {**tr.meta, "encoder_reading": reading}))
    assert r2.delta == r.delta and r2.converged


def test_encoder_count_is_measured_whatever_the_blocks():
    """Pass 1 reads each encoder's count from the recording (smallest non-zero step), the same
    for any chunking; an unquantised signal gives only its slowest step (µrad, a negligible
    bound), or 0 when that is below 2π/2²⁴."""
    from drivelash.estimation.motion import MotionScanner

    t = np.arange(20000) * 1e-3
    x = 0.7 * np.sin(2 * np.pi * 0.5 * t)
    q_m, q_l = 2 * np.pi / 1024, 2 * np.pi / 65536
    th_m, th_l = np.floor(x / q_m) * q_m, np.round(x / q_l) * q_l
    for block in (len(t), 7, 4096):
        sc = MotionScanner(1.0)
        for a in range(0, len(t), block):
            sc.feed(t[a : a + block], th_m[a : a + block], th_l[a : a + block])
        s = sc.summary()
        assert s.count_m == pytest.approx(q_m, rel=1e-9) and s.count_l == pytest.approx(q_l, rel=1e-9)
    sc = MotionScanner(1.0)
    sc.feed(t, x, x)
    assert 0.0 <= sc.summary().count_m < 1e-5 and 0.0 <= sc.summary().count_l < 1e-5
    sc = MotionScanner(1.0)
    sc.feed(t, np.zeros_like(x), x * 1e-3)  # a still motor; a load moving by ≤ 3.5 nrad steps
    assert sc.summary().count_m == 0.0 and sc.summary().count_l == 0.0


def test_encoder_offset_bound_vanishes_for_equal_counts(rig_trace):
    """Same counts on both sides of a 1:1 drive (the bench rig): the offsets cancel, no widening."""
    r = _run(RIG, rig_trace)
    assert r.extra["encoder_count_load"] == pytest.approx(2 * math.pi / 2048, rel=1e-9)
    assert r.extra["encoder_offset_bound"] == 0.0


@pytest.mark.parametrize("method", ["default", "paper"])
def test_degrees_hit_the_bound_and_are_flagged(method):
    """Positions and velocities both in degrees (consistent, so the unit check passes)."""
    tr = simulate_independent(RIG, duration=DURATION, T_s=T_S, unit=180.0 / math.pi)
    r = _run(RIG, tr, method=method)
    assert not r.converged
    assert any("upper bound" in w for w in r.warnings), r.warnings


@pytest.mark.parametrize("shift", [0.2, -0.2])
def test_load_encoder_zero_shift(shift):
    """A load-encoder zero shifted by ±0.2 rad: corrected by the δ1 check, or flagged."""
    tr = simulate_independent(RIG, duration=DURATION, T_s=T_S, load_zero_shift=shift)
    for method in ("default", "paper"):
        r = _run(RIG, tr, method=method)
        msg = _accurate_or_flagged(r, RIG.delta, 2e-3)
        assert msg is None, (method, msg)


def test_estimate_never_exceeds_observed_range(rig_trace):
    """δ̂ larger than the whole observed Δθ range is never claimed (δ1 +83.7 mrad, paper law)."""
    r = _run(RIG, rig_trace, RIG.delta1 + 0.9 * (RIG.delta - RIG.delta1), "paper")
    assert r.delta > r.extra["dtheta_range"]
    assert not r.converged
    assert any("exceeds the whole Δθ range" in w for w in r.warnings)


def test_still_load_is_a_verdict_not_an_error(tmp_path, capsys):
    """Motion inside the gap with a quantised load encoder (θ_l constant): exit 0,
    ``excitation_ok = false`` with the reason in the JSON."""
    from cli_runner import run_in_process

    tr = simulate_independent(RIG, duration=6.0, T_s=T_S, amplitude=0.02)
    assert np.ptp(tr["theta_l"]) == 0.0  # the load encoder never moves
    data = tmp_path / "still.parquet"
    tr.to_parquet(data)
    cfg = tmp_path / "drive.toml"
    d = RIG.drivetrain()
    cfg.write_text(
        "[drivetrain]\n"
        + "".join(f"{k} = {getattr(d, k)!r}\n" for k in ("J_m", "J_l", "N", "K_S", "D_S", "T_Cm", "T_Cl"))
        + f"beta_m = {d.beta_m!r}\nbeta_l = {d.beta_l!r}\n[backlash]\ndelta1 = {RIG.delta1!r}\n",
        encoding="utf-8",
    )
    out = tmp_path / "o.json"
    code, _, _ = run_in_process(["estimate", str(data), "--config", str(cfg), "--json", str(out)], capsys)
    assert code == 0
    s = json.loads(out.read_text())
    assert s["excitation_ok"] is False and s["converged"] is False
    assert "inside the deadzone" in s["reason"]


# ----------------------------------------------------------------------------------
# slow: gravity, stiff geared drive, random drives
# ----------------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("K_S", [50.0, 200.0])
def test_gravity_load_accurate_or_flagged(K_S):
    """A constant 0.5 N·m load torque (gravity) on K_S = 50 and 200 drives: within 5 % of δ
    or flagged and not converged — never the old "63 traversals, converged, 15 % high"."""
    drive = replace(RIG, K_S=K_S, T_ext=0.5)
    tr = simulate_independent(drive, duration=20.0, T_s=T_S if K_S < 100 else 5e-4)
    for method in ("default", "paper"):
        r = _run(drive, tr, method=method)
        msg = _accurate_or_flagged(r, drive.delta, 0.05 * drive.delta)
        assert msg is None, (method, msg)


#: A stiff geared drive (N = 10, K_S = 2000 N·m/rad, 1 kHz): contact torques far below
#: 1 mrad of deflection (the old fixed threshold called it "contact on one side only").
STIFF = replace(
    RIG, N=10.0, K_S=2000.0, J_l=0.05, J_m=5e-4, delta=0.01, delta1=0.005, T_Cl=0.5, T_Cm=0.02,
    beta_l=0.05, beta_m=1e-3, D_S=2.0,
)  # fmt: skip


@pytest.mark.slow
def test_stiff_geared_drive_is_excited_and_accurate_or_flagged():
    tr = simulate_independent(STIFF, duration=20.0, T_s=T_S, torque_limit=50.0)
    for method in ("default", "paper"):
        r = _run(STIFF, tr, method=method)
        assert r.excitation_ok, (method, r.reason)  # not falsely "unexcited"
        msg = _accurate_or_flagged(r, STIFF.delta, 2e-3)
        assert msg is None, (method, msg)


@pytest.mark.slow
def test_stiff_drive_contact_threshold_is_configurable():
    """The contact threshold is a key: set absurdly high, the verdict says the shaft torque
    never exceeded it (so the key is really used)."""
    tr = simulate_independent(STIFF, duration=10.0, T_s=T_S, torque_limit=50.0)
    r = DeadzoneEstimator(STIFF.drivetrain(), STIFF.delta1, T_S, T_thr=1e3).run(tr)
    assert r.config.T_thr == 1e3
    assert not r.excitation_ok and "contact threshold" in r.reason


@pytest.mark.slow
def test_mismatch_sweep_independent_random_drives():
    """The sweep on 12 random drives of the independent simulator (the table of the closing
    note: ``tests/estimation/mismatch_sweep.py independent 0``): never confidently wrong, never
    converged and worse than the paper law by more than 1 mrad — for both laws.

    Was a known miss (13 confidently wrong, then 3): the truncating encoders' Δθ offset on
    ind0.1/ind0.5 (reading-convention bound) and the switched joint law on ind0.1 with a wrong
    K_S / T_Cl and the load-observer torque (twice the model part)."""
    from .mismatch_sweep import independent_drives, sweep

    rows = sweep(independent_drives(0))
    bad = [
        (r.drive, r.case, 1e3 * r.err, 1e3 * r.err_paper)
        for r in rows
        if r.confidently_wrong or r.worse_than_paper or r.paper_confidently_wrong
    ]
    assert not bad, bad


_D1_INTERVAL_MISS = pytest.mark.xfail(
    strict=True,
    reason="known miss: default law, δ1 +2 mrad on the independent rig: error +1.976 mrad, 95 % "
    "half-width 1.972 mrad (misses the truth by 4 µrad); because the joint δ/δ1 law itself does "
    "not correct an offset of the order of the contact deflection (the δ1 ±2/−4 mrad known miss "
    "above), so the distance to it does not reach the truth either; flagged and not converged",
)


@pytest.mark.parametrize("method", [pytest.param("default", marks=_D1_INTERVAL_MISS), "paper"])
def test_interval_reaches_the_joint_law_when_delta1_is_inconsistent(rig_trace, method):
    """A δ1 the data contradict (check "inconsistent", not switched): the 95 % interval must hold
    the truth, since the joint δ/δ1 law's δ is an alternative the data support (it is added to the
    half-width like the paper/default disagreement). Negative control: without that term the
    interval misses the truth on at least one offset (a narrow interval around the wrong δ1's δ̂:
    bench-0A with bench-0B's δ1 and --method paper showed ±1.9 mrad around a 419 mrad error)."""
    seen = missed_without = 0
    for e in D1_OFFSETS:
        r = _run(RIG, rig_trace, RIG.delta1 + e, method)
        if r.extra.get("delta1_check_result") != "inconsistent":
            continue
        seen += 1
        gap = r.extra["delta1_check_gap"]
        assert gap == pytest.approx(abs(r.delta - r.extra["delta1_check_delta"]), abs=0)
        lo, hi = r.delta_interval
        assert lo <= RIG.delta <= hi, (method, e, r.delta - RIG.delta, r.delta_std)
        half_without = 1.96 * r.delta_std - gap
        missed_without += abs(r.delta - RIG.delta) > half_without
    assert seen >= 1 and missed_without >= 1, (seen, missed_without)


def test_estimate_outside_the_observed_range_is_no_measurement_and_delta1_is_named():
    """Found by an exploratory tester (session 13): bench-0C (δ 105, δ1 52.5 mrad), 4 s, seed 1,
    with examples/drive_bench.toml's δ1 = 93 mrad (bench-0B's): δ̂ 145.5 mrad (> the 120.8 mrad
    Δθ range; the recording did cross the true gap) was printed ± 1.00 mrad (so a wear history
    would take it: unconverged with u95 ≤ 5 mrad) and "δ1 check: consistent". The δ1 check now
    names the δ1 the data give, and the interval reaches the joint law's δ (the truth)."""
    import drivelash as dl
    from drivelash.sim.scenarios import get_scenario

    sc = get_scenario("bench-0C")
    tr = sc.simulate(duration=4.0, seed=1)
    truth = sc.plant_backlash
    cfg = dl.load_config(Path(__file__).parents[2] / "examples" / "drive_bench.toml")
    r = dl.estimate_backlash(tr, cfg)
    assert r.delta > r.summary["dtheta_range"]
    assert not r.converged
    assert r.summary["delta1_check_result"] == "inconsistent"
    lo, hi = r.summary["delta_interval_95"]
    assert lo <= truth.delta <= hi
    assert 1.96 * r.summary["delta_std"] > 5e-3  # not usable in a wear trend (UNCONVERGED_MAX_U95)
    # the joint law's δ1 and δ: the truth within 3 mrad (measured 51.1 / 103.6 for 52.5 / 105)
    assert abs(r.summary["delta1_estimate"] - truth.delta1) < 3e-3
    assert abs(r.result.extra["delta1_check_delta"] - truth.delta) < 3e-3
    # named: δ1 inconsistent (since session 34 by the lower-contact asymmetry directly, before by
    # the range; the message then names the distance) and δ̂ beyond the observed range
    assert any("δ1 is inconsistent" in w and "configured δ1 = 93.0 mrad" in w for w in r.warnings), r.warnings
    assert any("exceeds the whole Δθ range observed" in w for w in r.warnings), r.warnings
    # negative control: the true δ1 — a measurement, no δ1 warning
    ok = dl.estimate_backlash(tr, cfg, delta1=truth.delta1)
    assert ok.excitation_ok and ok.delta <= ok.summary["dtheta_range"]
    assert ok.summary["delta1_check_result"] != "inconsistent"
    assert abs(ok.delta - truth.delta) < 2e-3
