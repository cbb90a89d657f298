"""Recorded-pass campaigns for ``te score`` tests: the virtual bench, exported like a CNC trace."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from drivelash.io.trace import Trace

#: Columns a CNC trace would give (1 kHz): time, linear scale, motor angle, torque, motor speed.
CNC_COLUMNS = ("t", "x_T", "theta_m", "torque_m", "omega_m")


def write_passes(directory: Path, manifest: dict, passes: list[tuple[dict, dict]], with_x_d: bool,
                 decimate: int = 8) -> Path:  # fmt: skip
    """Write ``passes`` [(run entry, run_pass result)] as a campaign directory (1 kHz traces)."""
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    runs = []
    for entry, res in passes:
        cols = {k: res[k][::decimate] for k in CNC_COLUMNS}
        if with_x_d:
            cols["x_d"] = res["x_d"][::decimate]
        Trace(cols, {}).to_parquet(d / entry["file"])
        runs.append(dict(entry))
    m = dict(manifest)
    m["runs"] = runs
    (d / "manifest.json").write_text(json.dumps(m), encoding="utf-8")
    return d


def pass_improvements(rows: list[dict]) -> dict[tuple[int, float, float], float]:
    """Mean improvement per (direction, velocity, load) of section rows."""
    out: dict[tuple[int, float, float], list[float]] = {}
    for r in rows:
        out.setdefault((r["direction"], r["velocity"], r["load"]), []).append(r["improvement"])
    return {k: float(np.mean(v)) for k, v in out.items()}
