"""Demo step: a small simulated fleet — simulate, ingest, status, report."""

from __future__ import annotations

import shutil
from pathlib import Path

from rich.console import Console

#: The demo fleet: 2 machines × 2 axes × 16 daily recordings of 8 s (kept small: the demo is fast).
DEMO_FLEET = {"machines": 2, "axes": 2, "recordings": 16, "seed": 2}


def demo_fleet(out_dir: Path, console: Console) -> None:
    """Write ``fleet/`` (recordings, fleet.toml, truth.json, wear.sqlite) and ``fleet.html``."""
    from drivelash.commands.track import run_ingest, run_report, run_status
    from drivelash.sim.fleet import simulate_fleet

    d = Path(out_dir) / "fleet"
    if d.exists():  # the demo's own output from an earlier run
        shutil.rmtree(d)
    plan = simulate_fleet(d, **DEMO_FLEET, workers=2)
    console.print(
        f"fleet: simulated {plan.recordings} recordings ({plan.unexcited} unexcited, {plan.corrupt} corrupt) "
        f"-> {plan.fleet_toml}"
    )
    rep = run_ingest(plan.fleet_toml, workers=2, quiet=True)
    console.print(
        f"fleet: ingested {rep.planned} recordings in {rep.wall_s:.1f} s "
        f"({rep.failed} failed, stored with reasons)"
    )
    db = str(d / "wear.sqlite")
    label = "fleet/wear.sqlite (SQLite, in this output directory)"
    run_status(db, label=label)
    report = Path(out_dir) / "fleet.html"
    run_report(db, report, quiet=True, label=label)
    console.print(f"fleet: report -> {report}")
