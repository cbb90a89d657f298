"""Identification limits of the acceptance's 66 drives at one window (a measurement, not a test).

The 18 bench scenarios and the 48 random drives of ``test_identify_two_mass_slow.py``, identified
with ``window_s`` = WINDOW (seconds, or ``auto``): K_S and J_l within 5 %, δ and δ1 within 1 mrad,
and whether each 95 % interval holds the truth (the online-estimator part of the acceptance is
left out: it does not depend on the window except through these values). One JSON line per drive,
then the totals. Session 26 (docs/assumptions.md, "Window from the resonance")::

    .venv/bin/python tests/identify/measure_window_gate.py auto 0.003   # "auto", capped at 3 ms
    .venv/bin/python tests/identify/measure_window_gate.py 0.001        # the default

≈ 4 min each on two cores.
"""

from __future__ import annotations

import json
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

LIMITS = {"K_S": 5.0, "J_l": 5.0, "delta": 1.0, "delta1": 1.0}  # %, %, mrad, mrad


def _score(name: str, dt, bl, trace, window) -> dict:
    from drivelash.estimation.identify_two_mass import identify_two_mass

    r = identify_two_mass(trace, dt.N, window_s=window)
    out: dict = {"name": name, "visible": bool(r.backlash_visible), "window_ms": 1e3 * r.fit["window_s"]}
    for n in ("K_S", "J_l"):
        out[n] = 100 * (r[n].value / getattr(dt, n) - 1) if r[n].identifiable else None
        out[n + "_covers"] = bool(r[n].identifiable and r[n].covers(getattr(dt, n)))
    for n, v in (("delta", bl.delta), ("delta1", bl.delta1)):
        out[n] = 1e3 * (r[n].value - v) if r[n].identifiable else None
        out[n + "_covers"] = bool(r[n].identifiable and r[n].covers(v))
    out["ok"] = out["visible"] and all(out[n] is not None and abs(out[n]) <= lim for n, lim in LIMITS.items())
    return out


def _job(job: tuple) -> list[dict]:
    kind, key, window = job
    if kind == "bench":
        from drivelash.sim.scenarios import get_scenario

        sc = get_scenario(key)
        return [_score(key, sc.plant_drivetrain, sc.plant_backlash, sc.simulate(), window)]
    from identify.test_identify_two_mass_slow import _random_cases

    return [_score(f"{key}/{c}", *drive, window) for c, *drive in _random_cases(key)]


def main(arg: str, cap: str | None = None) -> None:
    import importlib

    from drivelash.sim.scenarios import list_scenarios

    if cap is not None:  # the "auto" window's cap [s] (the workers are forked: they inherit it)
        importlib.import_module("drivelash.estimation.identify_two_mass").WINDOW_MAX_S = float(cap)

    window = arg if arg == "auto" else float(arg)
    jobs = [("seed", s, window) for s in range(4)]
    jobs += [("bench", s.name, window) for s in list_scenarios() if s.name.startswith("bench-")]
    rows = []
    with ProcessPoolExecutor(2) as ex:
        for outs in ex.map(_job, jobs):
            for o in outs:
                print(json.dumps(o), flush=True)
                rows.append(o)
    covers = {n: sum(r[n + "_covers"] for r in rows) for n in LIMITS}
    misses = [r["name"] for r in rows if not r["ok"]]
    print(
        f"within the limits: {len(rows) - len(misses)} of {len(rows)} (misses: {', '.join(misses)}); "
        f"intervals holding the truth: {covers}"
    )


if __name__ == "__main__":
    main(*(sys.argv[1:3] if len(sys.argv) > 1 else ["0.001"]))
