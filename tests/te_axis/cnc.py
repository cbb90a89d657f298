"""A campaign of the virtual bench written as a CNC would record it, and the axis file to import it.

One CSV per pass with the units of a drive trace: time in ms, set and scale positions in
mm, the motor encoder in integer counts, the motor current in A (torque / torque constant).
:func:`export_cnc` also writes ``axis.toml`` with the run list, the column mapping and the
bench's geometry and drive — the input of ``drivelash te import``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

#: Motor encoder resolution [counts/rev] (25-bit single-turn, e.g. EnDat 2.2 motor encoders).
COUNTS_PER_REV = 2**25
#: Motor torque constant [N·m/A] (1FT7-class servo motor).
K_T = 1.8


def write_pass(tr, path: Path, counts_per_rev: int = COUNTS_PER_REV, k_t: float = K_T,
               sign: int = 1, zero_mm: float = 0.0) -> Path:  # fmt: skip
    """One pass as a CNC trace CSV (``sign`` −1 flips the encoder, ``zero_mm`` shifts the scale)."""
    t_ms = tr["t"] * 1e3
    cols = {
        "time_ms": np.round(t_ms, 6),
        "pos_set_mm": tr["x_d"] * 1e3,
        "pos_scale_mm": tr["x_T"] * 1e3 + zero_mm,
        "enc_motor": np.rint(sign * tr["theta_m"] * counts_per_rev / (2 * math.pi)).astype(np.int64),
        "current_A": tr["torque_m"] / k_t,
    }
    with path.open("w") as fh:
        fh.write(",".join(cols) + "\n")
        for i in range(t_ms.size):
            fh.write(
                f"{cols['time_ms'][i]:.6f},{cols['pos_set_mm'][i]:.9f},{cols['pos_scale_mm'][i]:.9f},"
                f"{cols['enc_motor'][i]:d},{cols['current_A'][i]:.9g}\n"
            )
    return path


def axis_toml(camp, runs: list[tuple[str, object]], counts_per_rev: int = COUNTS_PER_REV, k_t: float = K_T,
              with_velocity: bool = True) -> str:  # fmt: skip
    """The axis file of a campaign's bench and a run list ``[(csv name, CampaignRun), …]``."""
    b = camp.bench
    lines = ["# axis description written by tests/te_axis/cnc.py", "[geometry]"]
    for k, v in b.geometry.__dict__.items():
        if v is not None:
            lines.append(f"{k} = {v!r}")
    lines.append("[drive]")
    lines += [f"{k} = {v!r}" for k, v in b.drive.__dict__.items()]
    if camp.gains is not None:
        lines.append("[gains]")
        lines += [f"{k} = {v!r}" for k, v in camp.gains.__dict__.items()]
    lines += [
        "[columns.time_ms]", 'column = "t"', 'unit = "ms"',
        "[columns.pos_set_mm]", 'column = "x_d"', 'unit = "mm"',
        "[columns.pos_scale_mm]", 'column = "x_T"', 'unit = "mm"',
        "[columns.enc_motor]", 'column = "theta_m"', 'unit = "counts"', f"counts_per_rev = {counts_per_rev}",
        "[columns.current_A]", 'column = "torque_m"', 'unit = "A"', f"torque_constant = {k_t!r}",
    ]  # fmt: skip
    for name, r in runs:
        lines += ["[[runs]]", f'kind = "{r.kind}"', f"direction = {r.direction}", f"load = {r.load!r}",
                  f'file = "{name}"']  # fmt: skip
        if with_velocity and r.kind != "sine":
            lines.append(f"velocity = {r.velocity!r}")
    return "\n".join(lines) + "\n"


def export_cnc(camp, out: Path, kinds=("geometric", "load", "sine"), **kw) -> Path:
    """Every run of ``camp`` of the given kinds as CNC CSVs in ``out``; returns ``out/axis.toml``."""
    out.mkdir(parents=True, exist_ok=True)
    runs = []
    for r in camp.runs:
        if r.kind not in kinds:
            continue
        name = f"{r.name}.csv"
        write_pass(r.trace(), out / name, **kw)
        runs.append((name, r))
    path = out / "axis.toml"
    path.write_text(axis_toml(camp, runs))
    return path
