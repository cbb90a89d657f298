"""Issue 10 acceptance on a simulated fleet of 20 machines × 3 axes × 60 recordings (slow).

Figures are printed (``pytest -s``) and quoted in the closing note:
- every excited recording within 1 mrad of the true δ; no unexcited recording in a trend;
- forecast made at half of each growing axis's life: within ±15 % of the true remaining time on
  ≥ 90 % of the growing axes, 90 % interval coverage in [80 %, 98 %];
- jumps detected on their second recording (within 2), none before; no alarm on a flat axis.
"""

from __future__ import annotations

import json
from datetime import datetime, timedelta

import numpy as np
import pytest

from drivelash.wear import Store, ingest, load_fleet
from drivelash.wear.alarms import fleet_summary
from drivelash.wear.trend import analyse

pytestmark = pytest.mark.slow
FLEET = {"machines": 20, "axes": 3, "recordings": 60, "seed": 10}


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    from drivelash.sim.fleet import simulate_fleet

    out = tmp_path_factory.mktemp("accept") / "fleet"
    simulate_fleet(out, **FLEET, workers=2)
    st = Store(out / "wear.sqlite")
    rep = ingest(load_fleet(out / "fleet.toml"), st, workers=2)
    truth = json.loads((out / "truth.json").read_text())
    print(f"\ningest: {rep.planned} recordings, {rep.failed} failed, {rep.wall_s:.0f} s")
    return out, st, truth


def _errors(out, st, truth):
    index = {str(out / r["file"]): r for a in truth["axes"].values() for r in a["recordings"]}
    rows = st.estimates()
    assert len(rows) == sum(len(a["recordings"]) for a in truth["axes"].values())
    return index, rows


def test_every_excited_recording_within_1_mrad(fleet):
    """The goal as stated: every excited recording (the estimator's verdict, which must agree with
    the truth) within 1 mrad — converged or not: a recording the estimator cannot settle on is
    still an excited recording, so its error counts here (it is kept out of the trend, below).
    And no truly excited recording is judged unexcited (it would silently leave the trend).

    Measured 2026-11-27 (session 8) at the fleet's default estimate_rate_hz = 1000 (every 8th
    sample of the 8 kHz recordings estimated; docs/assumptions.md, "Estimation rate"): 3320
    excited, all truly excited, none missed; max |δ̂ − δ| 0.462 mrad, median 0.0417 mrad; all
    converged; forecasts 38/38 within ±15 % (worst 3.3 %), coverage 37/38 = 0.974; jumps on the
    2nd recording; 212 unexcited = truth; 68 failed = the 68 corrupt files.

    Every sample (before session 8), measured 2026-11-27 (h3-ingest, fleet and store compared
    against main 6c44024): 3320 excited recordings, all truly excited, none missed; max |δ̂ − δ|
    0.153 mrad, median 0.0128 mrad; all converged. Before the estimator's flank recovery
    (docs/assumptions.md): max 4.123 mrad (M12-Z_20260209T070100: flank overshot at 0.12 s beyond
    the Δθ the motion reaches in contact, no gradient there, not converged) and 33 truly excited
    recordings of M12-Z and M20-Y judged unexcited ("information during 0.0 % of the last window",
    the same overshoot). The four tests of this file pass on that store (forecast: 38/38 within
    ±15 %, coverage 34/38 = 0.895; jumps on their 2nd recording; 212 unexcited flagged, truth
    212)."""
    out, st, truth = fleet
    index, rows = _errors(out, st, truth)
    exc = [r for r in rows if r["status"] == "ok" and r["excitation_ok"]]
    errs = [abs(r["delta"] - index[r["path"]]["delta"]) for r in exc]
    worst = max(exc, key=lambda r: abs(r["delta"] - index[r["path"]]["delta"]))
    print(
        f"\nexcited: {len(errs)} (truly excited: {sum(index[r['path']]['excited'] for r in exc)}), "
        f"max |δ̂ − δ| {1e3 * max(errs):.3f} mrad, median {1e3 * np.median(errs):.4f} mrad; "
        f"worst {worst['path'].rsplit('/', 1)[-1]}: converged {worst['converged']}, "
        f"delta_std {1e3 * (worst['delta_std'] or np.nan):.2f} mrad; not converged: "
        f"{sum(not r['converged'] for r in exc)}"
    )
    assert all(index[r["path"]]["excited"] for r in exc)
    rates = np.array([r["estimate_rate_hz"] for r in exc])  # the default: every 8th sample
    assert np.allclose(rates, 1000.0, rtol=1e-9, atol=0)
    missed = [
        r["path"]
        for r in rows
        if r["status"] == "ok" and not r["excitation_ok"] and index[r["path"]]["excited"]
    ]
    assert missed == [], missed
    assert max(errs) <= 1e-3


def test_unexcited_never_in_a_trend_and_trend_estimates_within_1_mrad(fleet):
    """No unexcited (or corrupt) recording enters a trend: every truly unexcited recording is
    flagged, every corrupt one is a failed row with its reason, and every estimate a trend uses
    (ok, excited, converged) is within 1 mrad of the true δ."""
    out, st, truth = fleet
    index, rows = _errors(out, st, truth)
    n_unexc_truth = sum(1 for r in index.values() if not r["excited"] and not r["corrupt"])
    flagged = [r for r in rows if r["status"] == "ok" and not r["excitation_ok"]]
    failed = [r for r in rows if r["status"] == "failed"]
    used = [r for s in fleet_summary(st) for r in s["used_rows"]]
    errs = [abs(r["delta"] - index[r["path"]]["delta"]) for r in used]
    print(
        f"\nin trends: {len(used)} estimates, max |δ̂ − δ| {1e3 * max(errs):.3f} mrad; "
        f"unexcited flagged {len(flagged)} (truth {n_unexc_truth}); failed {len(failed)} "
        f"(truth corrupt {sum(1 for r in index.values() if r['corrupt'])})"
    )
    for r in rows:  # every truly unexcited recording is flagged
        if not index[r["path"]]["excited"] and not index[r["path"]]["corrupt"]:
            assert r["status"] == "ok" and not r["excitation_ok"], r["path"]
        if index[r["path"]]["corrupt"]:
            assert r["status"] == "failed" and r["reason"].startswith(r["path"])
    for r in used:
        assert index[r["path"]]["excited"] and not index[r["path"]]["corrupt"]
    assert max(errs) <= 1e-3


def test_forecast_at_half_life(fleet):
    """The 90 % interval includes the axis's systematic uncertainty (trend.systematic_std): with the
    fit's band of the mean alone it covered 22/38 = 0.579 (the estimates' error per axis, ±0.05 mrad,
    does not average out over recordings; their scatter is 0.01 mrad)."""
    out, st, truth = fleet
    start = datetime.fromisoformat(truth["start"]).replace(tzinfo=None)
    within, covered, n = 0, 0, 0
    worst = 0.0
    for name, a in truth["axes"].items():
        if a["law"] not in ("linear", "accelerating"):
            continue
        L = a["crossing_day"]
        cut = start + timedelta(days=L / 2)
        rows = [r for r in st.estimates(name) if r["start_time"] is not None and r["start_time"] <= cut]
        tr, used = analyse(rows, a["threshold_rad"])
        fc = tr.forecast
        true_cross = start + timedelta(days=L)
        last = used[-1]["start_time"]
        remaining = (true_cross - last).total_seconds() / 86400
        pred = tr.to_time(fc.t_cross) if fc and fc.t_cross is not None else None
        err = abs((pred - true_cross).total_seconds() / 86400) / remaining if pred else np.inf
        early = tr.to_time(fc.t_early) if fc else None
        late = tr.to_time(fc.t_late) if fc and fc.t_late is not None and np.isfinite(fc.t_late) else None
        cov = (
            early is not None
            and early <= true_cross
            and (late is None and np.isinf(fc.t_late) or late >= true_cross)
        )
        n += 1
        within += err <= 0.15
        covered += bool(cov)
        worst = max(worst, err)
    print(
        f"growing axes {n}: within ±15 % {within}/{n} = {within / n:.3f}; worst {worst:.3f}; "
        f"90 % interval coverage {covered}/{n} = {covered / n:.3f}"
    )
    assert n >= 20
    assert within / n >= 0.90
    assert 0.80 <= covered / n <= 0.98


def test_jumps_within_two_recordings_and_no_alarm_on_flat_axes(fleet):
    out, st, truth = fleet
    start = datetime.fromisoformat(truth["start"]).replace(tzinfo=None)
    delays = []
    for name, a in truth["axes"].items():
        rows = st.estimates(name)
        if a["law"] == "flat":
            s = next(x for x in fleet_summary(st) if x["axis"] == name)
            assert s["alarms"] == [] and s["change_points"] == [], name
            continue
        if a["law"] != "jump":
            continue
        t_jump = start + timedelta(days=a["params"]["t_jump"])
        _, used = analyse(rows, a["threshold_rad"])
        j = next(i for i, r in enumerate(used) if r["start_time"] >= t_jump)
        found = None
        for end in range(j, min(j + 4, len(used))):
            used_paths = {r["path"] for r in used[: end + 1]}
            tr, _ = analyse([r for r in rows if r["path"] in used_paths], a["threshold_rad"])
            pos = [c for c in tr.change_points if c.size > 0]
            if end == j:
                assert pos == [], f"{name}: a jump claimed on its first recording"
            if pos:
                assert tr.to_time(pos[0].t_days) >= t_jump - timedelta(hours=1)
                found = end - j + 1
                break
        delays.append(found)
        before = [r for r in rows if r["start_time"] is not None and r["start_time"] < t_jump]
        tr_b, _ = analyse(before, a["threshold_rad"])
        assert [c for c in tr_b.change_points if c.size > 0] == [], f"{name}: jump before the jump"
    print(f"jump axes {len(delays)}: detected on recording {delays} after the jump")
    assert delays and all(d is not None and d <= 2 for d in delays)
