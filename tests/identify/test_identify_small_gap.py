"""A small gap on bench-0B: the two-mass identification's intervals miss (session 22, a known miss).

A sweep of bench-0B variants (session 22; the cases rebuilt here with ``bench_variant``, 8 s at
8 kHz, seeds 1–6) found the identification honest at the bench's own 186 mrad gap (K_S, J_l, δ inside
every interval; the 100-seed coverage test measures 0.94 / 0.97) but biased at smaller gaps, with
intervals that exclude the truth. K_S outside its interval in 4 of 18 runs: δ = 5 mrad seeds 1 and
3 (+10.0 %, +12.2 %), 50 mrad seeds 2 and 3 (−7.5 %, +8.1 %; J_l −10.6 %, +15.4 % outside too);
δ outside in 4 of 18: +0.49 / +0.51 mrad at 5 mrad, +0.47 at 20 mrad, +0.30 at 50 mrad (|z| ≤ 3.07;
measured in session 24 with the bracket's centre covariance — before it, 20 mrad seed 3 instead of
50 mrad seed 3 missed K_S, and δ missed in 5).
Not the encoders: 65536-count encoders give the same biases (seed 1, 5 mrad: K_S +9.7 %, δ +10.4 %).
The random drives of the acceptance (δ 10–500 mrad on other drives) meet the 5 % / 1 mrad limits;
here the shaft deflects up to ≈ 10 mrad beyond the contacts (Δθ spans −6.1 … +12.3 mrad around
contacts at ±2.5 mrad). Narrowed to the windows' acceleration targets built from the recorded
velocities' noise (docs/assumptions.md, "Gaps much smaller than the shaft's deflection": true-velocity
targets remove it, K_S −0.86 %), not fixed in the default 1 ms window; ``window_s="auto"`` (a
sixth of the resonance period, 3.6 ms here) holds the truth on this case and 50 of the sweep's 54
intervals (the default 43) — the tests below. The goal is kept: the 95 %
intervals hold the truth. The measured values are asserted so that the known miss cannot drift
unnoticed.
"""

from __future__ import annotations

import pytest

from drivelash.estimation.identify_two_mass import identify_two_mass
from identify.acceptance import bench_variant


@pytest.fixture(scope="module")
def small_gap():
    plant, trace = bench_variant(0.005, 0.0025, 1)  # bench-0B's shaft, δ = 5 mrad, seed 1
    return plant, identify_two_mass(trace, 1.0)


@pytest.mark.xfail(
    strict=True,
    reason="known miss: bench-0B with δ = 5 mrad (seed 1): K_S 36.22 [33.71, 38.74] N·m/rad for 32.94 "
    "(+10.0 %), δ 5.49 [5.07, 5.92] mrad for 5.00 — both intervals exclude the truth; goal: the 95 % "
    "intervals hold it (as at the bench's own 186 mrad gap); because the identification is biased at "
    "gaps much smaller than the shaft's deflection — narrowed to the window accelerations built from the "
    "recorded velocity noise, not fixed in the default (window = 'auto' or 4 ms holds the truth: "
    "test_the_auto_window_holds_the_truth, test_a_longer_window_holds_the_truth)",
)
def test_small_gap_intervals_hold_the_truth(small_gap):
    plant, r = small_gap
    assert r["K_S"].identifiable and r["K_S"].covers(plant.K_S), r["K_S"]
    assert r["delta"].identifiable and r["delta"].covers(0.005), r["delta"]


def test_small_gap_measured_as_stated(small_gap):
    """The figures of the known miss above (and of docs/assumptions.md), as measured."""
    plant, r = small_gap
    assert r.backlash_visible
    assert r["K_S"].value / plant.K_S - 1 == pytest.approx(0.100, abs=0.01)
    # [33.44, 39.00] before session 24's bracket covariance
    assert (r["K_S"].low, r["K_S"].high) == pytest.approx((33.71, 38.74), abs=0.03)
    assert 1e3 * r["delta"].value == pytest.approx(5.49, abs=0.03)
    assert 1e3 * r["delta"].low == pytest.approx(5.07, abs=0.03)
    assert 1e3 * r["delta"].high == pytest.approx(5.92, abs=0.03)


def test_a_longer_window_holds_the_truth(small_gap):
    """The workaround README names: ``[identification] window = 0.004`` (32 samples; the target
    noise shrinks with the window, the integral equation stays exact). Measured (session 22) on
    δ = 5 and 20 mrad, seeds 1 and 3, and the bench's 186 mrad: K_S within 2.5 %, every K_S, J_l
    and δ interval holding the truth (6 of 6). Asserted here on the case above, with the default's
    miss as the negative control."""
    plant, r_default = small_gap
    assert not r_default["K_S"].covers(plant.K_S)  # the known miss, at the default 1 ms
    _, trace = bench_variant(0.005, 0.0025, 1)
    r = identify_two_mass(trace, 1.0, window_s=0.004)
    assert abs(r["K_S"].value / plant.K_S - 1) <= 0.05 and r["K_S"].covers(plant.K_S), r["K_S"]
    assert r["J_l"].covers(plant.J_l), r["J_l"]
    assert r["delta"].covers(0.005) and abs(r["delta"].value - 0.005) < 1e-4, r["delta"]


def test_the_auto_window_holds_the_truth(small_gap):
    """README: ``[identification] window = "auto"`` (a sixth of the resonance period the 1 ms fit
    shows, 1–4 ms) picks ≈ 3.6 ms on bench-0B's drive (its resonance: 44.8 Hz) and holds the truth
    where the default misses (the fixture's miss is the negative control)."""
    plant, r_default = small_gap
    assert not r_default["K_S"].covers(plant.K_S)
    _, trace = bench_variant(0.005, 0.0025, 1)
    r = identify_two_mass(trace, 1.0, window_s="auto")
    choice = r.fit["window_choice"]
    f_true = (plant.K_S * (1 / plant.J_l + 1 / (plant.N**2 * plant.J_m))) ** 0.5 / (2 * 3.141592653589793)
    assert choice["f_res"] == pytest.approx(f_true, rel=0.05)  # 46.2 Hz fitted for 44.8
    assert r.fit["window_samples"] == round(choice["window_s"] / 1.25e-4) == 29  # 3.625 ms at 8 kHz
    assert r["K_S"].value / plant.K_S - 1 == pytest.approx(-0.0414, abs=0.005)
    for n, v in (("K_S", plant.K_S), ("J_l", plant.J_l), ("delta", 0.005)):
        assert r[n].identifiable and r[n].covers(v), (n, r[n])
    assert abs(r["delta"].value - 0.005) < 1e-4


# slow since session 33 (11.5 s of `make test`): the opt-in window's config key and report;
# the auto window's own figure stays fast (test_the_auto_window_holds_the_truth).
@pytest.mark.slow
def test_auto_window_from_the_config_and_in_the_report(small_gap, tmp_path):
    """``[identification] window = "auto"`` in a drive TOML gives the same fit as
    ``window_s="auto"``, and the report's fit table names the window chosen and why (README)."""
    import drivelash as dl
    from drivelash.report.identify_figures import write_two_mass_report

    _, trace = bench_variant(0.005, 0.0025, 1)
    cfg = tmp_path / "drive.toml"
    cfg.write_text('[drivetrain]\nN = 1.0\n\n[identification]\nmodel = "two-mass"\nwindow = "auto"\n')
    r = dl.identify_drive(trace, str(cfg))
    assert r.fit["window_samples"] == 29 and r.fit["window_choice"]["reason"].startswith("'auto': a sixth")
    assert r["K_S"].value == identify_two_mass(trace, 1.0, window_s="auto")["K_S"].value
    html = write_two_mass_report(tmp_path / "id.html", trace, r).read_text()
    assert "window chosen" in html and "a sixth of the period of the shaft resonance" in html
    # control: the default's report says the window was fixed
    html0 = write_two_mass_report(tmp_path / "id0.html", trace, small_gap[1]).read_text()
    assert "fixed: 1 ms ([identification] window; default 1 ms)" in html0  # the length used (s30 L3)


def test_auto_window_rejects_nonsense():
    from drivelash.errors import ParameterError

    _, trace = bench_variant(0.005, 0.0025, 1)
    for bad in ("fast", -1e-3, 0.0, float("nan")):
        with pytest.raises(ParameterError, match="window"):
            identify_two_mass(trace, 1.0, window_s=bad)


@pytest.mark.parametrize("value", ['"Auto"', "0", "-0.001", "true"])
def test_a_bad_window_key_is_one_line(value, tmp_path):
    """``[identification] window`` other than a length > 0 or "auto": one line naming file and key."""
    from drivelash.errors import ConfigError
    from drivelash.io.config import load_config

    f = tmp_path / "drive.toml"
    f.write_text(f'[identification]\nmodel = "two-mass"\nwindow = {value}\n')
    with pytest.raises(ConfigError) as e:
        load_config(f)
    msg = str(e.value)
    assert "\n" not in msg and "drive.toml" in msg and "key 'window'" in msg and "'auto'" in msg, msg


def _sweep_case(args: tuple) -> tuple[bool, bool, bool]:
    """(K_S, J_l, δ interval misses the truth) for one bench-0B variant (δ, seed[, window])."""
    delta, seed, *window = args
    plant, trace = bench_variant(delta, delta / 2, seed)
    r = identify_two_mass(trace, 1.0, window_s=window[0] if window else 1e-3)
    truth = (("K_S", plant.K_S), ("J_l", plant.J_l), ("delta", delta))
    return tuple(not (r[n].identifiable and r[n].covers(v)) for n, v in truth)


#: The sweep's runs where a 95 % interval misses under ``window = "auto"`` (session 24, with the
#: bracket's centre covariance): (δ, seed) → (K_S, J_l, δ) missed. Measured z: 5 mrad seed 5 J_l
#: −2.08, δ −2.38; 20 mrad seed 5 δ −2.26; 50 mrad seed 3 K_S −2.70 (−2.6 %).
AUTO_SWEEP_MISSES = {
    (0.005, 5): (False, True, True),
    (0.02, 5): (False, False, True),
    (0.05, 3): (True, False, False),
}


@pytest.mark.slow
def test_auto_window_sweep_measured_as_stated():
    """README: with ``window = "auto"`` the sweep above (5, 20, 50 mrad, seeds 1–6) has 50 of its 54
    K_S, J_l and δ intervals holding the truth (the default: 43 — K_S misses 4, J_l 3, δ 4 — with |z| up to
    3.07 and K_S up to +12 %); the four misses are just outside (|z| 2.08–2.70), about what 95 %
    intervals give (2.7 expected). Until session 24's bracket covariance "auto" held all 54 — with
    intervals too wide (bench-0B coverage 1.00 / 0.99)."""
    from concurrent.futures import ProcessPoolExecutor

    cases = [(d, s) for d in (0.005, 0.02, 0.05) for s in range(1, 7)]
    with ProcessPoolExecutor(2) as ex:
        res = list(ex.map(_sweep_case, [(d, s, "auto") for d, s in cases]))
    misses = {c: m for c, m in zip(cases, res, strict=True) if any(m)}
    assert misses == AUTO_SWEEP_MISSES, misses


@pytest.mark.slow
def test_auto_window_keeps_the_fast_drive_at_1ms():
    """The drive a fixed 4 ms window breaks (random drive 1/0, 332 Hz: K_S −17.5 %) keeps the 1 ms
    fit under ``"auto"`` (a sixth of its period is 0.5 ms, clipped to 1 ms): the same numbers as the
    default."""
    import numpy as np

    from estimation.test_generalisation import random_drive

    dt, _, trace = random_drive(np.random.default_rng(1), 0)
    r = identify_two_mass(trace, dt.N, window_s="auto")
    ref = identify_two_mass(trace, dt.N)
    assert r.fit["window_choice"]["window_s"] == 1e-3 and r.fit["window_s"] == ref.fit["window_s"]
    assert r["K_S"].value == ref["K_S"].value
    assert r["K_S"].value / dt.K_S - 1 == pytest.approx(-0.0472, abs=0.002)


@pytest.mark.slow
def test_auto_window_on_the_random_drives_3_7_and_3_2():
    """docs/assumptions.md ("Window from the resonance"), why "auto" is not the default: on the
    random drives it fixes 3/7 (J_l +5.95 % at 1 ms, a known miss) but takes 3/2 from within the
    limits to J_l −5.06 % (its 36.8 Hz resonance → 4 ms); measured as stated."""
    from identify.test_identify_two_mass_slow import _random_cases

    def drive(seed: int, case: int):
        return next(tuple(d) for k, *d in _random_cases(seed) if k == case)

    dt, bl, trace = drive(3, 7)
    r = identify_two_mass(trace, dt.N, window_s="auto")
    assert abs(r["J_l"].value / dt.J_l - 1) <= 0.05 and abs(r["K_S"].value / dt.K_S - 1) <= 0.05
    assert abs(r["delta"].value - bl.delta) <= 1e-3
    dt, bl, trace = drive(3, 2)
    r = identify_two_mass(trace, dt.N, window_s="auto")
    assert r.fit["window_s"] == pytest.approx(4e-3)
    assert r["J_l"].value / dt.J_l - 1 == pytest.approx(-0.0506, abs=0.001)


#: Random drives 3/0 and 3/2 (two-mass resonances 36.6 and 36.8 Hz, so "auto" asks for 4.5 ms and
#: the cap decides) identified at fixed windows [ms] → (K_S, J_l) error [%], measured in session 26.
CAP_SWEEP = {  # fmt: skip
    (3, 0): {
        2.0: (-5.50, -4.60),
        2.5: (-5.33, -4.80),
        3.0: (-6.66, -6.33),
        3.5: (-5.66, -5.55),
        4.0: (-2.75, -2.31),
    },
    (3, 2): {
        2.0: (0.38, -0.28),
        2.5: (0.50, 0.30),
        3.0: (-0.84, -1.44),
        3.5: (-4.12, -4.22),
        4.0: (-4.89, -5.06),
    },
}


@pytest.mark.slow
def test_no_cap_of_the_auto_window_holds_both_slow_random_drives():
    """docs/assumptions.md ("Window from the resonance"), why no other cap makes "auto" the
    default (session 25's lead, a 3 ms cap, refuted in session 26): on two random drives of the
    acceptance with the same 36.7 Hz resonance, no window between 2 and 4 ms keeps both within
    the 5 % limits — 3/2 needs ≤ 3 ms, 3/0 holds only at 4 ms (and at the default 1 ms: K_S
    −3.55 %). Their 95 % intervals hold the truth at every window (|z| ≤ 1.72): the longer
    windows' scatter, not a hidden bias. Every figure measured as stated (±0.05 pp)."""
    from concurrent.futures import ProcessPoolExecutor

    jobs = [(s, c, w) for (s, c), row in CAP_SWEEP.items() for w in row]
    with ProcessPoolExecutor(2) as ex:
        got = list(ex.map(_cap_case, jobs))
    for (s, c, w), (k, j, covered) in zip(jobs, got, strict=True):
        assert (k, j) == pytest.approx(CAP_SWEEP[s, c][w], abs=0.05), (s, c, w, k, j)
        assert covered, (s, c, w)
    for w in CAP_SWEEP[3, 0]:
        assert max(abs(v) for row in CAP_SWEEP.values() for v in row[w]) > 5.0, w


def _cap_case(args: tuple) -> tuple[float, float, bool]:
    """(K_S %, J_l %, both 95 % intervals hold the truth) of random drive seed/case at a window [ms]."""
    from identify.test_identify_two_mass_slow import _random_cases

    seed, case, w = args
    dt, _, trace = next(tuple(d) for k, *d in _random_cases(seed) if k == case)
    r = identify_two_mass(trace, dt.N, window_s=w * 1e-3)
    return (
        round(100 * (r["K_S"].value / dt.K_S - 1), 2),
        round(100 * (r["J_l"].value / dt.J_l - 1), 2),
        r["K_S"].covers(dt.K_S) and r["J_l"].covers(dt.J_l),
    )


@pytest.mark.slow
@pytest.mark.parametrize(
    ("delta", "seed"), [(0.005, 1), (0.005, 3), (0.02, 1), (0.02, 3), (0.186, 1), (0.186, 3)]
)
def test_a_longer_window_holds_the_truth_on_every_measured_case(delta, seed):
    """README: "a fixed `window = 0.004` holds 6 of 6 runs at 5, 20 and 186 mrad" (every K_S, J_l and
    δ interval; K_S within 2.5 %)."""
    plant, trace = bench_variant(delta, delta / 2, seed)
    r = identify_two_mass(trace, 1.0, window_s=0.004)
    assert abs(r["K_S"].value / plant.K_S - 1) <= 0.025, r["K_S"]
    for n, v in (("K_S", plant.K_S), ("J_l", plant.J_l), ("delta", delta)):
        assert r[n].identifiable and r[n].covers(v), (n, r[n])


@pytest.mark.slow
def test_small_gap_sweep_measured_as_stated():
    """README / docs: at 5, 20 and 50 mrad, seeds 1–6, K_S's interval misses the truth in 4 of 18
    runs, J_l's in 3 and δ's in 4 (the known miss's extent, measured as stated; 5 before session 24's
    bracket covariance)."""
    from concurrent.futures import ProcessPoolExecutor

    cases = [(d, s) for d in (0.005, 0.02, 0.05) for s in range(1, 7)]
    with ProcessPoolExecutor(2) as ex:
        res = list(ex.map(_sweep_case, cases))
    misses = list(zip(cases, res, strict=True))
    assert sum(k for k, _, _ in res) == 4 and sum(d for _, _, d in res) == 4, misses
    assert sum(j for _, j, _ in res) == 3, misses  # README: 43 of the 54 intervals hold


@pytest.mark.slow
def test_a_4ms_window_breaks_the_fast_random_drive():
    """README: "(a fixed `window = 0.004` …) gives that drive K_S −17 %" — random
    drive seed 1 / case 0 of the acceptance (K_S −4.72 % at the default 1 ms)."""
    import numpy as np

    from estimation.test_generalisation import random_drive

    rng = np.random.default_rng(1)
    dt, bl, trace = random_drive(rng, 0)
    f_res = np.sqrt(dt.K_S * (1 / dt.J_l + 1 / (dt.N**2 * dt.J_m))) / (2 * np.pi)
    assert f_res == pytest.approx(332, abs=1)
    r = identify_two_mass(trace, dt.N, window_s=0.004)
    assert r["K_S"].value / dt.K_S - 1 == pytest.approx(-0.175, abs=0.01)
