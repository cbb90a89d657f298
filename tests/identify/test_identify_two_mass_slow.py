"""Acceptance of the offline two-mass identification (issue 11 item 1), slow.

- the 18 bench scenarios (60 s each) and the 48 random drives of the generalisation test
  (tests/estimation/test_generalisation.py, 40 s each): identified K_S and J_l within 5 %, δ and
  δ1 within 1 mrad; the online estimator fed with the identified parameters meets the limit it
  meets with the true ones (≤ 1 mrad MAEE over the last 20 s);
- interval honesty: over 100 noise seeds of bench-0B the 95 % intervals of δ and K_S cover the
  truth 90–98 % of the time;
- traces from an independent integrator (scipy's Dormand–Prince ``ode('dopri5')`` replaying
  the applied torque, sensor model applied here): same limits, truth inside the intervals.
"""

from __future__ import annotations

import functools
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

from drivelash.estimation.identify_result import Z95
from drivelash.estimation.identify_two_mass import identify_two_mass
from drivelash.io.trace import Trace
from drivelash.physics.drivetrain import plant_params_array, rhs
from drivelash.sim.scenarios import get_scenario, list_scenarios
from identify.acceptance import fmt, score

BENCH = [s.name for s in list_scenarios() if s.name.startswith("bench-")]


def _check_limits(name: str, s: dict) -> None:
    assert s["visible"], name
    assert abs(s["K_S_rel"]) <= 0.05, fmt(name, s)
    assert abs(s["J_l_rel"]) <= 0.05, fmt(name, s)
    assert abs(s["delta_err"]) <= 1e-3, fmt(name, s)
    assert abs(s["delta1_err"]) <= 1e-3, fmt(name, s)


@pytest.mark.slow
@pytest.mark.parametrize("name", BENCH)
def test_bench_scenario(name):
    sc = get_scenario(name)
    s = score(sc.plant_drivetrain, sc.plant_backlash, sc.simulate())
    _check_limits(name, s)
    assert s["maee_identified"] <= 1e-3, fmt(name, s)


#: Random drives that miss a limit of the acceptance, with the measured figures and the cause
#: (measured on main af360fa and, identically, at 069d50e where the identification was
#: introduced: none of them is a regression). Each is asserted at the full limits by the strict
#: xfail test below; every other case is asserted by ``test_random_drives``. Seed 0 / case 11
#: (J_l −5.43 %, K_S −4.80 %, intervals ≈ 4 σ off) left this list in session 4: the closed-loop
#: bracket gives J_l −2.75 %, K_S −2.44 %, δ +0.081 mrad with the truth inside the intervals
#: (``test_closed_loop_bracket_makes_seed0_case11_honest``). Seed 0 / case 0 (online MAEE with the
#: identified parameters 1.593 mrad, with the true ones 1.318) left it in session 10: the online
#: law's least-squares gain is capped at the shaft resonance (docs/assumptions.md, "P0 =
#: P_max"), and the drive is now asserted by ``test_random_drives`` like the others. Seed 1 / case 9
#: (K_S −7.05 %, J_l −7.52 %, δ −0.450 mrad: errors in variables of the fused Δθ and the closed-loop
#: torque) left it with the instrumental-variable refit (``iv_refit``, torque instrument only):
#: K_S −0.87 %, J_l −0.87 %, δ −0.050 mrad, J_m +6.9 % (was +65 %). Seed 1 / case 0 (K_S −7.10 %,
#: J_l −8.63 %, J_m +185 %: the weakly excited motor inertia's closed-loop bias) left it with the
#: same refit: K_S −4.72 %, J_l −4.97 % (0.03 pp inside the limit), J_m +104 %, δ −0.048 mrad,
#: truth inside every 95 % interval (|z| ≤ 0.44).
KNOWN_MISS = {
    (2, 8): "known miss: the upper contact (26 traversals, found at the true 27.8 mrad by the "
    "two-contact fit) is not confirmed by the motor-side shaft torque (0.0054 N·m, soft shaft "
    "K_S = 3.7 N·m/rad), so δ is 'not determined' and the load side of the one-flank fit is withheld "
    "where it disagrees with the two-contact fit; goal: both contacts seen, K_S, J_l within 5 %",
    (3, 7): "known miss: J_l measured +5.95 % (K_S +4.33 %), goal ±5 %; the truth lies inside the "
    "95 % intervals; because only ~3000 windows per flank are in contact on this very soft drive "
    "(K_S = 1.7 N·m/rad, δ = 0.28 rad)",
}


def _random_cases(seed: int):
    from estimation.test_generalisation import random_drive

    rng = np.random.default_rng(seed)
    for case in range(12):
        yield (case, *random_drive(rng, case))


def _check_random(seed: int, case: int, drivetrain, bl, trace) -> str:
    s = score(drivetrain, bl, trace)
    name = f"seed {seed} case {case}"
    _check_limits(name, s)
    # the limit the online law meets with the true parameters (≤ 1 mrad), with the identified ones
    assert s["maee_identified"] <= max(1e-3, s["maee_true"]), fmt(name, s)
    return fmt(name, s)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_random_drives(seed):
    """The 48 drives of the generalisation test (same generator, same seeds); the known misses
    are asserted at the same limits by ``test_random_drive_known_miss`` (strict xfails, so each
    must still miss). README: "46 of the 48 random drives … the other two are known misses"."""
    assert len(KNOWN_MISS) == 2
    lines = [
        _check_random(seed, case, *drive)
        for case, *drive in _random_cases(seed)
        if (seed, case) not in KNOWN_MISS
    ]
    print("\n".join(lines))


@pytest.mark.slow
@pytest.mark.parametrize(
    "seed,case",
    [pytest.param(*k, marks=pytest.mark.xfail(strict=True, reason=v)) for k, v in KNOWN_MISS.items()],
)
def test_random_drive_known_miss(seed, case):
    for k, *drive in _random_cases(seed):
        if k == case:
            _check_random(seed, case, *drive)
            break


# --------------------------------------------------------------------------------------
# interval honesty
# --------------------------------------------------------------------------------------
COVERAGE_SCENARIO = "bench-0B"
COVERAGE_SEEDS = range(100)


def _z_scores(seed: int, window_s: float | str = 1e-3) -> tuple[float, float]:
    sc = get_scenario(COVERAGE_SCENARIO)
    r = identify_two_mass(sc.simulate(seed=seed), sc.plant_drivetrain.N, window_s=window_s)
    zd = (r["delta"].value - sc.plant_backlash.delta) / r["delta"].std
    zk = (r["K_S"].value - sc.plant_drivetrain.K_S) / r["K_S"].std
    return float(zd), float(zk)


@pytest.mark.slow
def test_interval_coverage_over_100_seeds():
    """Measured: see docs/assumptions.md ("Offline two-mass identification")."""
    with ProcessPoolExecutor(2) as pool:
        z = np.array(list(pool.map(_z_scores, COVERAGE_SEEDS)))
    cover = np.mean(np.abs(z) <= 1.959963984540054, axis=0)
    print(f"coverage of the 95 % intervals over {len(z)} seeds: δ {cover[0]:.2f}, K_S {cover[1]:.2f}")
    assert 0.90 <= cover[0] <= 0.98, cover
    assert 0.90 <= cover[1] <= 0.98, cover
    # README: "on bench-0B they still cover 94–97 % over 100 noise seeds" (δ 0.94, K_S 0.97 with the
    # torque-instrument IV step where the Hausman test rejects least squares; δ 0.95, K_S 0.96 before it)
    assert 0.94 <= cover[0] <= 0.97 and 0.94 <= cover[1] <= 0.97, cover


def _z_scores_auto(seed: int) -> tuple[float, float]:
    return _z_scores(seed, "auto")


@pytest.mark.slow
def test_auto_window_intervals_on_bench_0b():
    """docs/assumptions.md ("Window from the resonance"): with ``window = "auto"`` (≈ 3.6 ms on
    bench-0B) the 95 % intervals cover the truth on 98 % (δ) and 95 % (K_S) of 100 seeds — within
    the 90–98 % the acceptance asks of the default (the coverage test above). Until session 24's
    bracket covariance (:func:`test_bracket_covariance_is_the_centres_own`) they covered 100 % / 99 %:
    too wide, one of the reasons "auto" is not the default."""
    with ProcessPoolExecutor(2) as pool:
        z = np.array(list(pool.map(_z_scores_auto, COVERAGE_SEEDS)))
    cover = np.mean(np.abs(z) <= 1.959963984540054, axis=0)
    print(f"auto window: coverage over {len(z)} seeds δ {cover[0]:.2f}, K_S {cover[1]:.2f}")
    assert 0.90 <= cover[0] <= 0.98 and 0.90 <= cover[1] <= 0.98, cover
    assert cover[0] == pytest.approx(0.98, abs=0.011) and cover[1] == pytest.approx(0.95, abs=0.011), cover


#: Seeds of the bracket diagnosis below (16: the relative standard error of a spread is ≈ 18 %).
BRACKET_SEEDS = range(16)


def _bracket_at_auto_window(seed: int) -> dict[str, tuple[float, float]]:
    """(K_S, δ) figures of the closed-loop bracket on bench-0B at the auto window (29 samples)."""
    import importlib

    from statsmodels.stats.sandwich_covariance import S_hac_simple

    m = importlib.import_module("drivelash.estimation.identify_two_mass")
    sc = get_scenario(COVERAGE_SCENARIO)
    trace = sc.simulate(seed=seed)
    window_s = 29 * trace.T_s
    data = m.window_data(trace, sc.plant_drivetrain.N, window_s=window_s)
    start = m.grid_start(data)
    f0 = m.fit_two_mass(data, start=start, iv=False)
    f1 = m.closed_loop_refit(data, f0, start, iv=False)
    free = list(f0.problem.free)
    a = np.zeros((2, len(free)))
    a[0, free.index(m.I_KS)] = 1.0
    a[1, free.index(m.I_CHI)], a[1, free.index(m.I_CLO)] = 1.0, -1.0

    def influence(fit) -> np.ndarray:  # per-window influence on (K_S, δ)
        x = fit.p[fit.problem.free]
        J = fit.problem.jacobian(x)
        return fit.problem.scores(x) @ np.linalg.pinv(J.T @ J) @ a.T

    i0, i1 = influence(f0), influence(f1)
    centre = 0.5 * (i0 + i1)
    rep = identify_two_mass(trace, sc.plant_drivetrain.N, window_s=window_s)
    return {
        "alpha": (f1.start_weight, f1.start_weight),
        "corr": tuple(float(np.corrcoef(i0[:, k], i1[:, k])[0, 1]) for k in range(2)),
        "centre_sd": tuple(np.sqrt(np.diag(S_hac_simple(centre, nlags=m.andrews_bandwidth(centre))))),
        "look_back_sd_lag0": tuple(np.sqrt(np.diag(S_hac_simple(i0, nlags=0)))),
        "look_back_sd_lag60": tuple(np.sqrt(np.diag(S_hac_simple(i0, nlags=60)))),
        "centre_sd_lag0": tuple(np.sqrt(np.diag(S_hac_simple(centre, nlags=0)))),
        "reported_sd": (rep["K_S"].std, rep["delta"].std),
        "reported": (rep["K_S"].value, rep["delta"].value),
    }


@pytest.mark.slow
def test_bracket_covariance_is_the_centres_own():
    """docs/assumptions.md ("Closed-loop bracket", "Window from the resonance"): the auto window's
    intervals were too wide because of the closed-loop bracket, not the Newey–West bandwidth
    (session 23's lead, refuted in session 24). Measured over 16 seeds of bench-0B at 29-sample
    windows: the bracket's decorrelating start weight is α = 0.70, so its two fits' influence
    functions correlate only 0.72 and their centre averages noise out. The centre's own sandwich
    (the averaged influence functions, Andrews bandwidth) is K_S 0.144, δ 0.0161 mrad against a
    spread of the reported estimates of 0.167 / 0.0150. Until session 24 the bracket reported
    (C₀ + C₁)/2 + ΔΔᵀ/z²₉₅ — 0.178 / 0.0208 (× 1.24 / × 1.29 the centre's sandwich); now the
    centre's sandwich, Δ only where it is more than noise: 0.150 / 0.0174 (× 1.04 / × 1.08; the
    rest is the max(IV, LS) rule and the sensitivity terms). Negative control of the cause: the
    look-back fit's sandwich differs by 2 % between lag 0 and lag 60."""
    with ProcessPoolExecutor(2) as pool:
        rows = list(pool.map(_bracket_at_auto_window, BRACKET_SEEDS))

    def mean(k: str) -> np.ndarray:
        return np.mean([r[k] for r in rows], axis=0)

    spread = np.std([r["reported"] for r in rows], axis=0, ddof=1)
    print({k: mean(k) for k in rows[0]}, "spread", spread)
    assert 0.6 <= mean("alpha")[0] <= 0.8, mean("alpha")
    assert np.all(mean("corr") < 0.8), mean("corr")
    # the centre's sandwich is the spread (± the 16-seed sampling error, ≈ 18 %)
    ratio = spread / mean("centre_sd")
    assert np.all((0.75 <= ratio) & (ratio <= 1.33)), (spread, mean("centre_sd"))
    # the reported standard errors are the centre's (measured × 1.04 / × 1.08; × 1.24 / × 1.29
    # with the old (C₀ + C₁)/2 + ΔΔᵀ/z²₉₅)
    wide = mean("reported_sd") / mean("centre_sd")
    assert np.all((1.0 <= wide) & (wide <= 1.12)), wide
    # not the bandwidth
    lag = mean("look_back_sd_lag60") / mean("look_back_sd_lag0")
    assert np.all(np.abs(lag - 1.0) < 0.03), lag


# --------------------------------------------------------------------------------------
# interval honesty on the 48 random drives ("no confidently wrong estimate")
# --------------------------------------------------------------------------------------
#: Share of the random drives (those on which the parameters are identified) whose 95 %
#: intervals of both parameters hold the truth (docs/assumptions.md, "Window-length sensitivity").
HONEST_SHARE = 0.90
#: ... and no estimate farther from the truth than this many of its standard errors.
HONEST_MAX_Z = 4.0


@functools.cache
def _random_z() -> tuple[tuple[str, dict[str, float], dict[str, float]], ...]:
    """(drive, z with the reported std, z with the noise-only std) of K_S, J_l, δ, δ1 on the 48
    random drives (identified parameters only)."""
    rows = []
    for seed in range(4):
        for case, drivetrain, bl, trace in _random_cases(seed):
            r = identify_two_mass(trace, drivetrain.N)
            truth = {"K_S": drivetrain.K_S, "J_l": drivetrain.J_l, "delta": bl.delta, "delta1": bl.delta1}
            noise = r.fit.get("systematic", {}).get("std_noise", {})
            z, z0 = {}, {}
            for n, v in truth.items():
                if r[n].identifiable:
                    z[n] = (r[n].value - v) / r[n].std
                    z0[n] = (r[n].value - v) / noise[n]
            rows.append((f"{seed}/{case}", z, z0))
    return tuple(rows)


def _honesty(names: tuple[str, ...], which: int) -> tuple[int, int, float, str]:
    """(drives with both covered, drives with both identified, max |z|, drive of the max)."""
    covered = count = 0
    zmax, worst = 0.0, ""
    for row in _random_z():
        z = row[which]
        if not all(n in z for n in names):
            continue
        count += 1
        covered += all(abs(z[n]) <= Z95 for n in names)
        for n in names:
            if abs(z[n]) > zmax:
                zmax, worst = abs(z[n]), f"{row[0]} {n}"
    return covered, count, zmax, worst


@pytest.mark.slow
def test_random_drive_intervals_of_K_S_and_J_l_are_honest():
    """On ≥ 90 % of the random drives the 95 % intervals of K_S and J_l both hold the truth and no
    |z| exceeds 4. Negative control: the noise-only (HAC) intervals, the identification before
    the window-length sensitivity, cover both on about half the drives with |z| up to 221."""
    covered, count, zmax, worst = _honesty(("K_S", "J_l"), 1)
    print(f"K_S and J_l covered on {covered}/{count} drives, max |z| {zmax:.2f} ({worst})")
    assert count >= 40
    assert covered >= HONEST_SHARE * count, (covered, count)
    assert zmax <= HONEST_MAX_Z, (zmax, worst)
    covered0, count0, zmax0, _ = _honesty(("K_S", "J_l"), 2)
    assert count0 == count and covered0 < 0.6 * count and zmax0 > 50.0, (covered0, zmax0)
    # README figures, each at its value: "43 of the 47 random drives that identify both (23 with
    # the noise-only intervals, |z| up to 177; now at most 3.2)". Tolerance: one drive either way
    # (a drive at |z| ≈ 1.96 may flip with another machine's floating-point order), 177 to 1 %.
    # (Measured 43, 23, 176.9 and 3.04 (1/6 K_S; 3.16 before the fused-position term); before the
    # instrumental-variable step: 43, 21, 221 and 3.15 with the least-squares noise intervals.)
    assert count == 47 and abs(covered - 43) <= 1 and abs(covered0 - 23) <= 1, (covered, covered0)
    assert zmax <= 3.2 and zmax0 == pytest.approx(177, rel=0.01), (zmax, zmax0)


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason="known miss: the 95 % intervals of δ and δ1 both hold the truth on 41 of the 47 drives "
    "with both identified (0.87; 37 before the fused-position and start-velocity terms), max |z| 4.16 "
    "(seed 3 / case 8, δ1 +5.0 µrad; 5.26 before); goal ≥ 90 % and |z| ≤ 4 as for K_S and J_l; "
    "because of the 6 left, 3/8 and 1/5 carry a window-independent bias of the noise-free "
    "equations (3/8: +9.4 µrad with exact positions, no quantisation, no velocity noise, no Stribeck "
    "friction; 1/5: the simulator's regularised Coulomb friction), 1/6 and 1/10 a fused-position "
    "error 3–5 times its modelled standard error (1024-count encoders, noisy velocities), 2/3 and 3/1 "
    "|z| 2.1–2.2 from the velocity noise (docs/assumptions.md)",
)
def test_random_drive_intervals_of_delta_are_honest():
    covered, count, zmax, worst = _honesty(("delta", "delta1"), 1)
    print(f"δ and δ1 covered on {covered}/{count} drives, max |z| {zmax:.2f} ({worst})")
    assert covered >= HONEST_SHARE * count and zmax <= HONEST_MAX_Z, (covered, count, zmax, worst)


# --------------------------------------------------------------------------------------
# independent integrator
# --------------------------------------------------------------------------------------
def dopri5_trace(name: str, duration: float, seed: int) -> tuple[Trace, Trace]:
    """Replay the torque of a simulated run through scipy's ``ode('dopri5')`` (not our RK4),
    then apply the scenario's encoders and a fresh velocity noise."""
    from scipy.integrate import ode

    sc = get_scenario(name)
    ref = sc.simulate(duration=duration, seed=seed, return_states=True)
    p = plant_params_array(sc.plant_drivetrain, sc.plant_backlash, model="deadzone", omega_reg=sc.omega_reg)
    u, T_s = ref["u"], sc.T_s
    d, d1 = sc.plant_backlash.delta, sc.plant_backlash.delta1
    solver = ode(lambda t, y, uk: rhs(y, uk, d, d1, p)).set_integrator(
        "dopri5", rtol=1e-9, atol=1e-12, nsteps=10000
    )
    solver.set_initial_value(np.zeros(4), 0.0)
    X = np.empty((u.size, 4))
    X[0] = 0.0
    for k in range(u.size - 1):
        solver.set_f_params(float(u[k]))
        X[k + 1] = solver.integrate((k + 1) * T_s)
    rng = np.random.default_rng(10_000 + seed)
    q = 2 * np.pi / sc.sensors.counts_m
    sig = sc.sensors.sigma_omega_m
    trace = Trace(
        {
            "t": ref["t"],
            "theta_m": q * np.round(X[:, 1] / q),
            "omega_m": X[:, 0] + sig * rng.standard_normal(u.size),
            "theta_l": q * np.round(X[:, 3] / q),
            "omega_l": X[:, 2] + sig * rng.standard_normal(u.size),
            "torque_m": u,
        }
    )
    return trace, ref


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_independent_integrator(seed):
    """δ, δ1 within 1 mrad, K_S and J_l within 5 %, and the truth inside the 99 % band of the
    interval (|z| < 2.58) on traces integrated by dopri5, not by the project's simulator."""
    sc = get_scenario("bench-0C")
    trace, ref = dopri5_trace("bench-0C", 12.0, seed)
    # the replay agrees with the engine (same plant, other integrator)
    assert np.max(np.abs(trace["torque_m"] - ref["u"])) == 0.0
    r = identify_two_mass(trace, 1.0)
    truth = {"delta": sc.plant_backlash.delta, "delta1": sc.plant_backlash.delta1}
    for n in ("K_S", "J_l"):
        assert abs(r[n].value / getattr(sc.plant_drivetrain, n) - 1) <= 0.05, (n, r[n])
        assert abs(r[n].value - getattr(sc.plant_drivetrain, n)) <= 2.58 * r[n].std, (n, r[n])
    for n, v in truth.items():
        assert abs(r[n].value - v) <= 1e-3, (n, r[n])
        assert abs(r[n].value - v) <= 2.58 * r[n].std, (n, r[n])


# --------------------------------------------------------------------------------------
# not confidently wrong on the known misses
# --------------------------------------------------------------------------------------
@pytest.mark.slow
def test_unconfirmed_contact_is_not_confident():
    """Seed 2 / case 8: a second contact found but not confirmed — no K_S, J_l, J_m or δ is
    reported as a value: each is 'not determined' with its reason, and a bound it carries holds
    the truth. Negative control: before this check the case reported K_S +357 % as an
    identifiable value whose 95 % interval excluded the truth, and a lower bound δ ≥ 48.4 mrad
    on a 45.9 mrad gap."""
    for k, drivetrain, bl, trace in _random_cases(2):
        if k != 8:
            continue
        r = identify_two_mass(trace, drivetrain.N)
        assert not r.backlash_visible
        truth = {"K_S": drivetrain.K_S, "J_l": drivetrain.J_l, "delta": bl.delta}
        for n, v in truth.items():
            q = r[n]
            assert not q.identifiable, (n, q)
            assert q.reason, n
            assert q.low <= v <= q.high, (n, q, v)
        break


@pytest.mark.slow
@pytest.mark.parametrize("seed,case", [(1, 0), (1, 9)])
def test_unphysical_grid_start_is_not_the_answer(seed, case, monkeypatch):
    """Seeds 1 / cases 0 and 9: the grid's best contact pair comes with a negative 1/J_m; the fit
    from it alone (the identification until session 9) ends at J_m < 0, 'not determined'. The
    second start from the best pair with physical signs explains the data better (lower
    n_m log SSE_m + n_l log SSE_l) and is kept: every parameter determined, the fit plausible,
    the truth inside the 95 % intervals of J_m, J_l, K_S, δ and δ1, δ and δ1 within 1 mrad."""
    from drivelash.estimation.identify_two_mass import (
        I_JM,
        concentrated_objective,
        fit_bracketed,
        grid_start,
        window_data,
    )

    for k, drivetrain, bl, trace in _random_cases(seed):
        if k != case:
            continue
        data = window_data(trace, drivetrain.N)
        start = grid_start(data)
        assert not start.physical
        old = fit_bracketed(data, start=start)  # negative control: the first start alone
        assert old.p[I_JM] < 0.0
        new = fit_bracketed(data, start=grid_start(data, physical=True))
        assert new.p[I_JM] > 0.0
        assert concentrated_objective(new) < concentrated_objective(old)
        r = identify_two_mass(trace, drivetrain.N)
        assert r.backlash_visible and r.plausible and not r.warnings, r.warnings
        truth = {
            "J_m": drivetrain.J_m, "J_l": drivetrain.J_l, "K_S": drivetrain.K_S,
            "delta": bl.delta, "delta1": bl.delta1,
        }  # fmt: skip
        for n, v in truth.items():
            q = r[n]
            assert q.identifiable and q.low <= v <= q.high, (n, q, v)
        assert abs(r["delta"].value - bl.delta) <= 1e-3
        assert abs(r["delta1"].value - bl.delta1) <= 1e-3
        # measured K_S / J_l: 1/0 −4.72 / −4.97 %, 1/9 −0.87 / −0.87 % with the instrumental-variable
        # step (the robust Hausman test rejects least squares on both); least squares alone (before
        # it) −7.10 / −8.63 and −7.05 / −7.52 %
        lo, hi = {0: (-0.055, -0.045), 9: (-0.015, -0.005)}[case]
        h = r.fit["systematic"]["hausman"]
        assert any(t.get("rejected") for t in (h, *h.values()) if isinstance(t, dict)), h
        for n in ("K_S", "J_l"):
            assert lo <= r[n].value / truth[n] - 1 <= hi, (n, r[n].value / truth[n] - 1)
        # J_m's interval reaches 0 on both: the reader is told it is weakly determined
        assert r["J_m"].note.startswith("weakly determined"), r["J_m"]
        # negative control, the README's "K_S −7.1 % → …": with a Hausman test that never rejects,
        # least squares stands everywhere and K_S is where it was before the IV step
        import drivelash.estimation.identify_two_mass as itm

        monkeypatch.setattr(itm, "HAUSMAN_LEVEL", 1.0)
        ls = identify_two_mass(trace, drivetrain.N)
        assert ls["K_S"].value / truth["K_S"] - 1 == pytest.approx(-0.071, abs=0.001)
        break


# --------------------------------------------------------------------------------------
# closed-loop velocity noise: the bracket (seed 0 / case 11)
# --------------------------------------------------------------------------------------
@pytest.mark.slow
def test_closed_loop_bracket_makes_seed0_case11_honest():
    """The controller acts on the recorded velocity; its answer to the noise of the samples
    before a window is in the window's torque. Negative control: the plain look-back
    least-squares fit (the identification before session 4, without the instrumental-variable
    step that now also removes most of that bias: J_l 1.3 σ off) puts J_l −5.43 %, K_S −4.80 %
    with 95 % intervals ≈ 4 σ off the truth; the decorrelated end of the bracket (first-order
    start weight α ≈ 1.12) alone is within 0.1 %; the reported centre is within 5 % with the
    truth inside the 95 % intervals of J_l, K_S, δ and δ1 (docs/assumptions.md, "Closed-loop
    bracket")."""
    import importlib

    itm = importlib.import_module("drivelash.estimation.identify_two_mass")

    for k, drivetrain, bl, trace in _random_cases(0):
        if k != 11:
            continue
        data = itm.window_data(trace, drivetrain.N)
        assert data.info["velocity_feedback_gain"] is not None
        start = itm.grid_start(data)
        plain = itm.fit_two_mass(data, start=start, iv=False)  # least squares, as before session 4
        sd = np.sqrt(np.diag(plain.cov_free))
        for i in (itm.I_JL, itm.I_KS):
            v, s = plain.p[i], sd[plain.problem.free.index(i)]
            truth = drivetrain.J_l if i == itm.I_JL else drivetrain.K_S
            assert abs(v - truth) > 3 * s, (itm.PARAM_NAMES[i], v, s, truth)  # confidently wrong
        # README: "off by −5.4 % in J_l … now −0.4 %" (to the README's 0.1 %)
        assert plain.p[itm.I_JL] / drivetrain.J_l - 1 == pytest.approx(-0.054, abs=0.001)
        decorrelated = itm.closed_loop_refit(data, plain, start, iv=False)
        assert decorrelated is not None and 1.0 < decorrelated.start_weight < 1.3
        assert abs(decorrelated.p[itm.I_JL] / drivetrain.J_l - 1) < 0.002
        assert abs(decorrelated.p[itm.I_KS] / drivetrain.K_S - 1) < 0.002
        r = identify_two_mass(trace, drivetrain.N)
        for n, v in (("J_l", drivetrain.J_l), ("K_S", drivetrain.K_S)):
            assert abs(r[n].value / v - 1) <= 0.05 and r[n].low <= v <= r[n].high, (n, r[n], v)
        assert r["J_l"].value / drivetrain.J_l - 1 == pytest.approx(-0.004, abs=0.001)
        for n, v in (("delta", bl.delta), ("delta1", bl.delta1)):
            assert abs(r[n].value - v) <= 1e-3 and r[n].low <= v <= r[n].high, (n, r[n], v)
        # the report is the bracket of the default fits (IV where the Hausman test rejects least
        # squares): its α is that of their decorrelated end
        default = itm.closed_loop_refit(data, itm.fit_two_mass(data, start=start), start)
        assert r.fit["start_weight"] == default.start_weight
        break
