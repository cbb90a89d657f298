"""How often the online estimate is "converged" and wrong when the configured δ1 is off.

Run from the repository root::

    .venv/bin/python examples/delta1_check_sweep.py [--durations 6,10,20] [--offsets-mrad 0,-10,10,-3]

For each of the 18 bench scenarios (``drivelash scenarios``), each duration [s] and each δ1
offset [mrad], it simulates the scenario (seed 0), runs ``drivelash.estimate_backlash`` with the
scenario's own estimator drive parameters and δ1 + offset, and prints one line per run: δ̂ − δ,
the 95 % half-width, ``converged``, the δ1 check's verdict, how far its joint law moved over the
last window and where it ended relative to δ̂. The summary counts, per duration and for the true
vs an offset δ1, the runs that converged, that converged *outside* their interval by more than
2 mrad ("converged and wrong"), and whose interval holds the truth. The figures of
docs/assumptions.md, "δ1 check: a settled joint law", come from this script (about 25 s on one
core once the kernels are compiled).
"""

from __future__ import annotations

import argparse
from collections import Counter

import drivelash as dl
from drivelash.sim.scenarios import list_scenarios


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--durations", default="6,10,20", help="recording lengths [s], comma-separated")
    ap.add_argument("--offsets-mrad", default="0,-10,10,-3", help="δ1 offsets [mrad], comma-separated")
    args = ap.parse_args()
    durations = [float(x) for x in args.durations.split(",")]
    offsets = [1e-3 * float(x) for x in args.offsets_mrad.split(",")]
    total, conv, wrong, covered = Counter(), Counter(), Counter(), Counter()
    for sc in (s for s in list_scenarios() if s.name.startswith("bench")):
        p = sc.estimator_drivetrain
        for dur in durations:
            tr = sc.simulate(duration=dur, seed=0)
            truth = float(tr["delta_true"][-1])
            for off in offsets:
                d1 = sc.estimator_backlash.delta1 + off
                if d1 < 0:
                    continue
                est = dl.estimate_backlash(tr, p, d1)
                x = est.result.extra
                err = est.delta - truth
                std = est.summary.get("delta_std")
                hw = 1.96 * std if std is not None else float("nan")
                bad = est.converged and abs(err) > max(2e-3, hw)
                key = (dur, "true δ1" if off == 0 else "δ1 off")
                total[key] += 1
                conv[key] += est.converged
                wrong[key] += bad
                covered[key] += abs(err) <= hw
                print(
                    f"{sc.name} {dur:4.0f} s δ1 {1e3 * off:+5.1f} mrad: δ̂−δ {1e3 * err:+7.2f} "
                    f"± {1e3 * hw:6.2f} mrad, converged {est.converged!s:5}, "
                    f"check {x.get('delta1_check_result')!s:12} "
                    f"moved {1e3 * x.get('delta1_check_movement', float('nan')):6.2f} "
                    f"ended {1e3 * x.get('delta1_check_apart', float('nan')):6.2f} mrad from δ̂"
                    + ("   CONVERGED AND WRONG" if bad else ""),
                    flush=True,
                )
    print("\nduration, δ1: runs / converged / converged and wrong / interval holds the truth")
    for key in sorted(total):
        print(f"  {key[0]:4.0f} s, {key[1]}: {total[key]} / {conv[key]} / {wrong[key]} / {covered[key]}")


if __name__ == "__main__":
    main()
