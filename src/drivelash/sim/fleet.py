"""Simulated fleets for the wear tracker: many axes, a wear law each, one short recording a day.

:func:`simulate_fleet` writes, under an output directory::

    fleet.toml                        the inventory (``drivelash track ingest fleet.toml``)
    drives/<machine>-<axis>.toml      each axis's drive configuration (estimator side)
    recordings/<machine>/<axis>/<machine>-<axis>_<YYYYmmddTHHMMSS>.parquet
    truth.json                        wear law, threshold, true δ of every recording, which
                                      recordings are unexcited or corrupt, true crossing day

Each axis is a drive train drawn around the test-bench rig (spec 01 §4): inertias, shaft
stiffness and damping, load friction scaled by 10^U(−0.2, 0.2), gear ratio N ∈ {1, 2, 3},
encoders of 2048/8192/65536 counts, velocity noise σ ∈ {0, 0.01, 0.03} rad/s, δ1 a fixed
fraction U(0.2, 0.8) of the initial δ (the homing flank: wear opens the other side).
Recordings are :data:`RECORDING_SECONDS` s of θ_r = A sin(2π f t) with f = 1 Hz,
A = 1.5 rad at the load, simulated by :func:`drivelash.sim.engine.simulate` (deadzone plant,
125 µs). Wear laws over days t (δ in rad):

* ``flat``: δ0;
* ``linear``: δ0 + r t;
* ``accelerating``: δ0 + v (e^{kt} − 1)/k (wear-out phase);
* ``jump``: slow linear wear plus a sudden step J at day t_j (a damaged tooth).

The threshold is δ0 + G with G ~ U(40, 100) mrad; growing axes reach it after L ~ U(0.7, 1.7)·R
days (R recordings, one a day), flat ones never. A recording is unexcited with probability
:data:`P_UNEXCITED` (a single stroke, or out and back once) and corrupt with
probability :data:`P_CORRUPT` (truncated file, NaN samples, or not a recording at all). Every
number is in docs/assumptions.md ("Simulated fleet").
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import ParameterError

__all__ = ["FleetPlan", "simulate_fleet", "wear_law"]

RECORDING_SECONDS = 8.0
REVERSAL_HZ = 1.0
AMPLITUDE_RAD = 1.5
T_S = 125e-6
P_UNEXCITED = 0.06
P_CORRUPT = 0.02
LAWS = ("flat", "linear", "accelerating", "jump")
LAW_P = (0.2, 0.35, 0.3, 0.15)
START = datetime(2026, 1, 5, 6, 0, tzinfo=UTC)
AXIS_NAMES = ("X", "Y", "Z", "A", "B", "C", "U", "V", "W")


def wear_law(law: str, p: dict[str, float], t: np.ndarray | float) -> np.ndarray:
    """True δ(t) [rad] of a law with parameters ``p`` at days ``t``."""
    t = np.asarray(t, dtype=float)
    d0 = p["delta0"]
    if law == "flat":
        return np.full_like(t, d0)
    if law == "linear":
        return d0 + p["r"] * t
    if law == "accelerating":
        k = p["k"]
        return d0 + p["v"] * np.expm1(k * t) / k
    if law == "jump":
        return d0 + p["r"] * t + p["J"] * (t >= p["t_jump"])
    raise ParameterError("wear_law", "law", f"unknown law {law!r}")


def _crossing(law: str, p: dict[str, float], thr: float) -> float | None:
    d0 = p["delta0"]
    if law == "linear":
        return (thr - d0) / p["r"]
    if law == "accelerating":
        return math.log1p((thr - d0) * p["k"] / p["v"]) / p["k"]
    if law == "jump":
        before = (thr - d0) / p["r"]
        if before < p["t_jump"]:
            return before
        return max(p["t_jump"], (thr - d0 - p["J"]) / p["r"])
    return None


@dataclass(frozen=True)
class _Axis:
    name: str
    drivetrain: Any
    delta1: float
    counts: int
    sigma: float
    law: str
    params: dict[str, float]
    threshold: float


@dataclass(frozen=True)
class FleetPlan:
    """What :func:`simulate_fleet` wrote (also in ``truth.json``).

    Attributes
    ----------
    out : Path
        The fleet directory.
    fleet_toml, truth_json : Path
        The inventory and the true δ of every recording.
    recordings : int
        Recordings written.
    unexcited : int
        Of those, recordings without sufficient excitation (a single stroke, or out and back
        once).
    corrupt : int
        Of those, recordings made unreadable on purpose (truncated, NaN, garbage).
    """

    out: Path
    fleet_toml: Path
    truth_json: Path
    recordings: int
    unexcited: int
    corrupt: int


def _draw_axes(rng: np.random.Generator, machines: int, axes: int, R: int) -> list[_Axis]:
    from drivelash.sim.scenarios import RIG_DRIVETRAIN

    out = []
    for m in range(machines):
        for a in range(axes):
            name = f"M{m + 1:02d}/{AXIS_NAMES[a % len(AXIS_NAMES)]}{'' if a < len(AXIS_NAMES) else a}"

            def s() -> float:
                return float(10 ** rng.uniform(-0.2, 0.2))

            dt = replace(
                RIG_DRIVETRAIN,
                J_m=RIG_DRIVETRAIN.J_m * s(),
                J_l=RIG_DRIVETRAIN.J_l * s(),
                K_S=RIG_DRIVETRAIN.K_S * s(),
                D_S=RIG_DRIVETRAIN.D_S * s(),
                T_Cl=RIG_DRIVETRAIN.T_Cl * s(),
                N=float(rng.choice([1.0, 2.0, 3.0])),
            )
            d0 = float(rng.uniform(0.03, 0.10))
            G = float(rng.uniform(0.04, 0.10))
            law = str(rng.choice(LAWS, p=LAW_P))
            L = float(rng.uniform(0.7, 1.7)) * R
            p: dict[str, float] = {"delta0": d0}
            if law == "linear":
                p["r"] = G / L
            elif law == "accelerating":
                ratio = float(rng.uniform(4.0, 12.0))  # growth rate at L over the initial one
                k = math.log(ratio) / L
                p.update(k=k, v=G * k / math.expm1(k * L))
            elif law == "jump":
                p.update(
                    r=G / (3.0 * L),
                    J=float(rng.uniform(0.015, 0.04)),
                    t_jump=float(round(rng.uniform(0.3, 0.7) * R)),
                )
            out.append(
                _Axis(
                    name=name,
                    drivetrain=dt,
                    delta1=d0 * float(rng.uniform(0.2, 0.8)),
                    counts=int(rng.choice([2048, 8192, 65536])),
                    sigma=float(rng.choice([0.0, 0.01, 0.03])),
                    law=law,
                    params=p,
                    threshold=d0 + G,
                )
            )
    return out


def _recording(job: tuple) -> None:
    """Simulate and write one recording (a worker's job)."""
    from drivelash.control.cascade import gains_from_bandwidth
    from drivelash.control.references import position_sine
    from drivelash.io.trace import Trace
    from drivelash.params import BacklashParams, SensorParams
    from drivelash.sim.engine import simulate

    ax, path, delta, kind, corrupt, seed, start, duration = job
    dt = ax.drivetrain
    if kind == "one-way":  # a quarter sine: one stroke, no reversal within the recording
        amp, f = AMPLITUDE_RAD, 0.25 / duration
    elif kind == "one-reversal":  # out and back once: each flank is met once, no gap traversal pair
        amp, f = AMPLITUDE_RAD, 0.5 / duration
    else:
        amp, f = AMPLITUDE_RAD, REVERSAL_HZ
    ref = position_sine(duration, T_S, amp * dt.N, f)
    g = replace(gains_from_bandwidth(dt, 100.0), torque_limit=13.0, T_s=T_S)
    sens = SensorParams(
        counts_m=ax.counts, counts_l=ax.counts, sigma_omega_m=ax.sigma, sigma_omega_l=ax.sigma
    )
    bl = BacklashParams(delta=float(delta), delta1=ax.delta1)
    tr = simulate(dt, bl, g, ref, sensors=sens, seed=seed).to_trace()
    cols = {k: tr[k] for k in ("t", "theta_m", "omega_m", "theta_l", "omega_l", "torque_m")}
    if corrupt == "nan":
        cols["omega_l"] = cols["omega_l"].copy()
        cols["omega_l"][len(cols["omega_l"]) // 3] = np.nan
    meta = {"start_time": start.isoformat(), "fleet_axis": ax.name, "generator": "drivelash simulate fleet"}
    meta["encoder_reading"] = tr.meta["encoder_reading"]  # the simulator's quantiser (estimator uses it)
    path.parent.mkdir(parents=True, exist_ok=True)
    Trace(cols, meta).to_parquet(path)
    if corrupt == "truncated":
        data = path.read_bytes()
        path.write_bytes(data[: len(data) // 2])
    elif corrupt == "garbage":
        path.write_bytes(np.random.default_rng(seed).bytes(4096))


def _drive_toml(ax: _Axis) -> str:
    import tomli_w

    est = replace(ax.drivetrain, T_Sm=0.0, T_Sl=0.0)  # the estimator's friction model is (6)-(7)
    d = {k: float(v) for k, v in est.to_dict().items() if k not in ("T_Sm", "T_Sl", "omega_s")}
    head = (
        f"# drive configuration of simulated axis {ax.name} (estimator side; the simulated plant\n"
        "# also has static friction). Use: drivelash estimate REC --config this.toml\n"
    )
    return head + tomli_w.dumps({"drivetrain": d, "backlash": {"delta1": ax.delta1}})


def simulate_fleet(
    out: str | Path,
    machines: int = 3,
    axes: int = 2,
    recordings: int = 30,
    seed: int = 0,
    *,
    duration: float = RECORDING_SECONDS,
    workers: int = 1,
    progress: Callable[[int, int], None] | None = None,
) -> FleetPlan:
    """Write a simulated fleet (recordings, drive configs, ``fleet.toml``, ``truth.json``).

    Parameters
    ----------
    out : str or Path
        Output directory (created; must not already hold a fleet).
    machines, axes, recordings : int
        Machines, axes per machine, recordings per axis (one a day).
    seed : int
        Seed of everything (same seed → byte-identical recordings).
    duration : float
        Length of each recording [s].
    workers : int
        Processes simulating recordings.
    progress : callable, optional
        ``progress(done, total)``.

    Raises
    ------
    ParameterError
        A count below its minimum, ``duration`` < 2 s, or ``out`` already holding a fleet.
    """
    for name, v, lo in (("machines", machines, 1), ("axes", axes, 1), ("recordings", recordings, 2)):
        if not (isinstance(v, int) and v >= lo):
            raise ParameterError("simulate fleet", name, f"must be an integer >= {lo}, got {v!r}")
    if not (math.isfinite(duration) and duration >= 2.0):
        raise ParameterError("simulate fleet", "duration", f"must be >= 2 s, got {duration!r}")
    out = Path(out)
    if (out / "fleet.toml").exists():
        raise ParameterError(
            "simulate fleet", "out", f"{out} already holds a fleet (fleet.toml); choose a new directory"
        )
    rng = np.random.default_rng(seed)
    axes_ = _draw_axes(rng, machines, axes, recordings)
    (out / "drives").mkdir(parents=True, exist_ok=True)
    jobs = []
    truth: dict[str, Any] = {
        "seed": seed,
        "recording_seconds": duration,
        "start": START.isoformat(),
        "axes": {},
    }
    fleet_lines = [
        "# simulated fleet (drivelash simulate fleet); truth in truth.json",
        "[fleet]",
        f'name = "simulated fleet, seed {seed}"',
        'db = "wear.sqlite"',
        "horizon_days = 30",
        "not_excited_alarm = 5",
        "estimate_rate_hz = 1000  # estimate on every 8th sample of the 8 kHz recordings ('full': all)",
        'time = { from = "filename", pattern = \'_(\\d{8}T\\d{6})\\.\', format = "%Y%m%dT%H%M%S" }',
        "",
    ]
    n_unexc = n_corrupt = 0
    for ai, ax in enumerate(axes_):
        tag = ax.name.replace("/", "-")
        (out / "drives" / f"{tag}.toml").write_text(_drive_toml(ax), encoding="utf-8")
        recs = []
        for i in range(recordings):
            minutes = int(rng.integers(0, 120))
            start = START + timedelta(days=i, minutes=minutes)
            day = i + minutes / 1440.0  # the true δ is the wear law at the recording's start time
            delta = float(wear_law(ax.law, ax.params, day))
            u = rng.random()
            kind = "normal"
            if u < P_UNEXCITED:
                kind = "one-way" if rng.random() < 0.5 else "one-reversal"
            corrupt = None
            if rng.random() < P_CORRUPT:
                corrupt = str(rng.choice(["truncated", "nan", "garbage"]))
            rel = (
                Path("recordings")
                / ax.name.split("/")[0]
                / ax.name.split("/")[1]
                / f"{tag}_{start.strftime('%Y%m%dT%H%M%S')}.parquet"
            )
            jobs.append(
                (ax, out / rel, delta, kind, corrupt, seed * 1_000_003 + ai * 10_007 + i, start, duration)
            )
            n_unexc += kind != "normal" and corrupt is None
            n_corrupt += corrupt is not None
            recs.append(
                {
                    "file": str(rel),
                    "day": day,
                    "start": start.isoformat(),
                    "delta": delta,
                    "excited": kind == "normal",
                    "motion": kind,
                    "corrupt": corrupt,
                }
            )
        cross = _crossing(ax.law, ax.params, ax.threshold)
        truth["axes"][ax.name] = {
            "law": ax.law,
            "params": ax.params,
            "threshold_rad": ax.threshold,
            "crossing_day": cross,
            "delta1": ax.delta1,
            "N": ax.drivetrain.N,
            "encoder_counts": ax.counts,
            "sigma_omega": ax.sigma,
            "drive": f"drives/{tag}.toml",
            "recordings": recs,
        }
        fleet_lines += [
            "[[axis]]",
            f'id = "{ax.name}"',
            f'drive = "drives/{tag}.toml"',
            f'recordings = "recordings/{ax.name}/*.parquet"',
            f"threshold = {ax.threshold!r}",
            "",
        ]
    done = 0
    if workers > 1:
        from drivelash._pool import process_pool

        with process_pool(workers) as pool:  # Ctrl-C: cancelled and terminated at once
            for _ in pool.map(_recording, jobs, chunksize=8):
                done += 1
                if progress:
                    progress(done, len(jobs))
    else:
        for j in jobs:
            _recording(j)
            done += 1
            if progress:
                progress(done, len(jobs))
    (out / "truth.json").write_text(json.dumps(truth, indent=1) + "\n", encoding="utf-8")
    (out / "fleet.toml").write_text("\n".join(fleet_lines), encoding="utf-8")
    return FleetPlan(out, out / "fleet.toml", out / "truth.json", len(jobs), n_unexc, n_corrupt)
