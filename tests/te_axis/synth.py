"""A small synthetic axis recorded as CNC traces (no simulator): for the fast import and plausibility tests.

The table moves at constant speed over [lo, hi]; the transmission error is a drift, a
runout with the pinion circumference, a tooth mesh, a per-direction offset (backlash) and
a compliance term; the motor angle follows from TE = x_T − θ_M r_eff, the torque from
the load and the friction through the lever r_eff.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from drivelash.physics.rack_pinion import RackPinionBench

BENCH = RackPinionBench(travel=1.0)
K_T = 1.8
CPR = 2**25


@dataclass
class Run:
    """One recorded pass (what to write and how to spoil it)."""

    kind: str
    direction: int
    load: float
    velocity: float
    lo: float = 0.05
    hi: float = 0.95
    sign: int = 1  # encoder sign in the file
    zero_mm: float = 0.0  # scale zero offset in the file [mm]
    name: str = ""
    extra: dict = field(default_factory=dict)
    hold: float = 0.0  # standstill [s] added after the pass, holding one current (see columns)
    clip: float | None = None  # |current| clipped at this [A] (a recorder's range)


def te_of(x: np.ndarray, d: int, F: float) -> np.ndarray:
    """The synthetic TE [m] at position x [m], direction d, mesh force F [N]."""
    pitch, circ = BENCH.tooth_pitch, BENCH.circumference
    return (
        5e-6 * x
        + 25e-6 * np.sin(2 * np.pi * x / circ)
        + 5e-6 * np.sin(2 * np.pi * x / pitch) / (1 + F / 3000)
        - d * 20e-6
        - d * 4e-9 * F
    )


def columns(run: Run, rate: float = 1000.0) -> dict[str, np.ndarray]:
    """The CNC columns of one pass (ms, mm, counts, A)."""
    length = run.hi - run.lo
    T = length / run.velocity
    t = np.arange(0.0, T + 0.5, 1.0 / rate)
    s = np.clip((t - 0.25) / T, 0.0, 1.0)
    x = run.lo + length * s if run.direction > 0 else run.hi - length * s
    F = run.load + BENCH.F_CT
    te = te_of(x, run.direction, F)
    theta = (x - te) / BENCH.r_eff
    moving = (s > 0) & (s < 1)
    torque = np.where(moving, run.direction * F * BENCH.r_eff / 0.95 + run.direction * BENCH.T_Cm, 0.0)
    torque = torque + 0.01 * np.sin(2 * np.pi * t * 3.3)
    current = torque / K_T
    if run.hold > 0:
        # a CNC's standstill: the drive holds the load with one quantised current (1 mA) before
        # the pass and for ``hold`` s after it (finding TH12)
        extra = np.arange(1, int(round(run.hold * rate)) + 1) / rate
        t = np.concatenate((t, t[-1] + extra))
        x = np.concatenate((x, np.full(extra.size, x[-1])))
        theta = np.concatenate((theta, np.full(extra.size, theta[-1])))
        moving = np.concatenate((moving, np.zeros(extra.size, bool)))
        current = np.concatenate((current, np.zeros(extra.size)))
        current[~moving] = round(0.5 * run.direction * F * BENCH.r_eff / K_T, 3)
    if run.clip is not None:
        current = np.clip(current, -run.clip, run.clip)
    return {
        "time_ms": t * 1e3,
        "pos_set_mm": x * 1e3,
        "pos_scale_mm": x * 1e3 + run.zero_mm,
        "enc_motor": np.rint(run.sign * theta * CPR / (2 * math.pi)),
        "current_A": current,
    }


def standard_runs(loads=(0.0, 1000.0, 2000.0, 3000.0), velocity: float = 0.1) -> list[Run]:
    """Geometric passes at 20 mm/s and load passes, both directions."""
    runs = [Run("geometric", d, 0.0, 0.02) for d in (1, -1)]
    runs += [Run("load", d, F, velocity) for F in loads for d in (1, -1)]
    return runs


def write_axis(
    out: Path, runs: list[Run], extra_toml: str = "", current_unit: str = "A", declared: str | None = None
) -> Path:
    """CSV files and ``axis.toml`` of ``runs`` in ``out``; returns the axis file (the current
    written in ``current_unit``, "A" or "mA", and declared as ``declared``, default the same)."""
    out.mkdir(parents=True, exist_ok=True)
    b = BENCH
    lines = [
        "[geometry]", f"m_n = {b.m_n!r}", f"n_t = {b.n_t}", f"helix_angle = {b.helix_angle!r}",
        f"i_PG = {b.i_PG!r}", f"travel = {b.travel!r}",
        "[columns.time_ms]", 'column = "t"', 'unit = "ms"',
        "[columns.pos_set_mm]", 'column = "x_d"', 'unit = "mm"',
        "[columns.pos_scale_mm]", 'column = "x_T"', 'unit = "mm"',
        "[columns.enc_motor]", 'column = "theta_m"', 'unit = "counts"', f"counts_per_rev = {CPR}",
        "[columns.current_A]", 'column = "torque_m"', f'unit = "{declared or current_unit}"',
        f"torque_constant = {K_T!r}",
    ]  # fmt: skip
    for i, r in enumerate(runs):
        name = r.name or f"run{i:02d}_{r.kind}_{r.load:g}_{'pos' if r.direction > 0 else 'neg'}.csv"
        cols = columns(r)
        cols["current_A"] = cols["current_A"] * {"A": 1.0, "mA": 1e3}[current_unit]
        with (out / name).open("w") as fh:
            fh.write(",".join(cols) + "\n")
            for row in zip(*cols.values(), strict=True):
                fh.write(f"{row[0]:.3f},{row[1]:.9f},{row[2]:.9f},{int(row[3])},{row[4]:.9g}\n")
        lines += ["[[runs]]", f'kind = "{r.kind}"', f"direction = {r.direction}", f"load = {r.load!r}",
                  f"velocity = {r.velocity!r}", f'file = "{name}"']  # fmt: skip
    path = out / "axis.toml"
    path.write_text("\n".join(lines) + "\n" + extra_toml)
    return path


def record(run: Run, label: str | None = None):
    """The pass as a plausibility :class:`~drivelash.te.protocol.plausibility.RunRecord` (SI, as imported)."""
    from drivelash.te.protocol.plausibility import RunRecord

    c = columns(run)
    return RunRecord(
        label or run.name or f"{run.kind}_{run.load:g}_{run.direction:+d}.csv",
        run.kind,
        run.direction,
        run.load,
        run.velocity,
        c["time_ms"] * 1e-3,
        c["pos_scale_mm"] * 1e-3,
        c["enc_motor"] * 2 * math.pi / CPR,
        c["current_A"] * K_T,
    )
