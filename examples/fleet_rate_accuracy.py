"""How accurate is the wear tracker's δ̂ at a reduced estimation rate? Against a simulated fleet's truth.

Run from the repository root on a fleet written by ``drivelash simulate fleet`` (the issue-10
acceptance fleet: ``--machines 20 --axes 3 --recordings 60 --seed 10``)::

    .venv/bin/python examples/fleet_rate_accuracy.py FLEET_DIR [--rates full,1000,500]

For each rate it loads every readable recording as ``drivelash track ingest`` does
(:func:`drivelash.io.load_trace` with ``max_rate_hz``, the fleet's drive configurations) and runs
the estimator (:func:`drivelash.estimation.pipeline.estimate_trace`), then prints, over the truly
excited recordings the estimator also calls excited: max and median |δ̂ − δ| [mrad], how many
converged, how many excitation verdicts disagree with the truth, the share with |δ̂ − δ| > 2σ(δ̂)
(4.6 % for an honest normal σ) and the estimator's CPU time. docs/assumptions.md ("Estimation
rate") quotes its figures for the acceptance fleet.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from drivelash.errors import DrivelashError
from drivelash.estimation.estimator import INPUT_COLUMNS
from drivelash.estimation.pipeline import estimate_trace
from drivelash.io import load_trace
from drivelash.wear.fleet import load_fleet


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("fleet", type=Path)
    ap.add_argument("--rates", default="full,1000,500", help="comma-separated Hz or 'full'")
    a = ap.parse_args()
    fleet = load_fleet(a.fleet / "fleet.toml")
    truth = {
        str(a.fleet / r["file"]): r
        for ax in json.loads((a.fleet / "truth.json").read_text())["axes"].values()
        for r in ax["recordings"]
    }
    print(f"{'rate':>6} {'n':>5} {'max mrad':>9} {'median':>8} {'converged':>10} {'verdicts off':>12} "
          f"{'|z|>2':>6} {'CPU s':>6}")  # fmt: skip
    for rate in a.rates.split(","):
        hz = None if rate == "full" else float(rate)
        err, z, conv, off, cpu = [], [], 0, 0, 0.0
        for ax in fleet.axes:
            for p in ax.files():
                try:
                    tr = load_trace(p, ax.drive, required=INPUT_COLUMNS, max_rate_hz=hz)
                except DrivelashError:
                    continue  # the corrupt ones
                c0 = time.process_time()
                res, _ = estimate_trace(ax.drive, tr, ax.method, keep="decimated")
                cpu += time.process_time() - c0
                t = truth[str(p)]
                off += bool(res.excitation_ok) != bool(t["excited"])
                if t["excited"] and res.excitation_ok:
                    e = abs(res.delta - t["delta"])
                    err.append(1e3 * e)
                    conv += bool(res.converged)
                    if np.isfinite(res.delta_std) and res.delta_std > 0:
                        z.append(e / res.delta_std)
        print(
            f"{rate:>6} {len(err):5d} {max(err):9.3f} {np.median(err):8.4f} {conv:10d} {off:12d} "
            f"{np.mean(np.array(z) > 2):6.3f} {cpu:6.1f}"
        )


if __name__ == "__main__":
    main()
