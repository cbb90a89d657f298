"""Simulating the measurement campaign on the virtual rack-and-pinion bench (spec 02 §1, §6).

What a commissioning engineer records (``drivelash te campaign -o DIR``):

* ``geometric``: no-load passes over the travel in both directions at 10 mm/s
  (the geometric error TE_geo and the backlash);
* ``load``: passes in both directions under process loads 0 … 5000 N in 500 N steps
  at three travel velocities (default 20, 50, 100 mm/s = 1.2, 3, 6 m/min);
* ``sine``: a sinusoidal trajectory with direction changes (no load and 2000 N).

Each run is one Parquet :class:`~drivelash.io.trace.Trace` with the columns
``t`` [s], ``x_d`` [m], ``x_T`` [m], ``theta_m`` [rad], ``omega_m`` [rad/s],
``torque_m`` [N·m], ``F_load`` [N, magnitude against the motion], ``direction`` (±1,
commanded), stored at ``store_rate`` (default 1 kHz, decimated from the 8 kHz
control rate; the simulation has no sensor noise, so no anti-alias filter is
needed). ``manifest.json`` follows the published campaign schema
(:mod:`drivelash.io.campaign`): the axis (geometry, drive, gains) and the runs (file,
kind, load, velocity, direction), plus the ``simulator`` block (:class:`SimulatorBlock`)
with everything needed to regenerate the true drive: seed, TE-generator parameters,
engine settings and the campaign plan.

Reading a campaign directory back: :func:`drivelash.te.protocol.campaign.load_campaign`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import Field

from drivelash.errors import ParameterError
from drivelash.io.campaign import FORMAT_NAME, FORMAT_VERSION, MANIFEST, AxisBlock, CampaignManifest, RunEntry
from drivelash.io.jsondoc import Document
from drivelash.io.outputs import write_json
from drivelash.params import CascadeGains
from drivelash.physics.rack_pinion import (
    LocalDefect,
    RackPinionBench,
    TEGeneratorParams,
    TransmissionErrorModel,
)
from drivelash.sim.rack_axis import (
    AxisSimConfig,
    RackAxisSimulator,
    bench_gains,
    constant_velocity_pass,
    sine_trajectory,
)

__all__ = [
    "STORED_COLUMNS",
    "CampaignConfig",
    "RunSpec",
    "SimulatorBlock",
    "default_gains",
    "plan_runs",
    "run_campaign",
    "run_trajectory",
]

STORED_COLUMNS = ("t", "x_d", "x_T", "theta_m", "omega_m", "torque_m", "F_load", "direction")


@dataclass(frozen=True)
class CampaignConfig:
    """What the campaign records (defaults: the full protocol; see docs/assumptions.md).

    Parameters
    ----------
    geometric_velocity : float
        Speed of the no-load geometric passes [m/s] (10 mm/s, paper §II).
    velocities : tuple of float
        The three travel speeds of the load passes [m/s].
    loads : tuple of float
        Process loads [N] of the load passes.
    margin : float
        Distance kept from both travel ends [m]; passes run over [margin, travel − margin].
    stroke : float or None
        Pass length [m]; None = the whole travel minus margins (a shorter stroke is
        the ``quick`` campaign for tests).
    a_max : float
        Peak acceleration of the ramps [m/s²].
    dwell : float
        Rest before and after each motion [s].
    sine_amplitude, sine_frequency, sine_periods : float
        Sinusoidal trajectory x_c − A cos(2π f t) about mid-travel [m], [Hz], [-].
    sine_loads : tuple of float
        Loads [N] of the sinusoidal runs.
    store_rate : float
        Sampling rate of the stored traces [Hz] (an integer divisor of 1/T_s).
    """

    geometric_velocity: float = 0.01
    velocities: tuple[float, ...] = (0.02, 0.05, 0.1)
    loads: tuple[float, ...] = tuple(float(f) for f in range(0, 5001, 500))
    margin: float = 0.05
    stroke: float | None = None
    a_max: float = 0.5
    dwell: float = 0.1
    sine_amplitude: float = 0.25
    sine_frequency: float = 0.1
    sine_periods: float = 2.0
    sine_loads: tuple[float, ...] = (0.0, 2000.0)
    store_rate: float = 1000.0

    def __post_init__(self) -> None:
        for n in (
            "geometric_velocity",
            "a_max",
            "sine_amplitude",
            "sine_frequency",
            "sine_periods",
            "store_rate",
        ):
            v = getattr(self, n)
            if not (math.isfinite(v) and v > 0):
                raise ParameterError(type(self).__name__, n, f"must be finite and > 0, got {v!r}")
        if not self.velocities or any(not v > 0 for v in self.velocities):
            raise ParameterError(type(self).__name__, "velocities", "must be non-empty and > 0")
        if any(not f >= 0 for f in (*self.loads, *self.sine_loads)):
            raise ParameterError(type(self).__name__, "loads", "loads must be >= 0")
        if self.stroke is not None and not self.stroke > 0:
            raise ParameterError(type(self).__name__, "stroke", "must be > 0 or None")

    @classmethod
    def quick(cls) -> CampaignConfig:
        """A reduced campaign for tests: 0.4 m stroke, loads 0/2500/5000 N, one sine period."""
        return cls(
            stroke=0.4, loads=(0.0, 2500.0, 5000.0), sine_amplitude=0.1, sine_periods=1.0, sine_loads=(0.0,)
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable dict."""
        d = asdict(self)
        for k in ("velocities", "loads", "sine_loads"):
            d[k] = list(d[k])
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> CampaignConfig:
        """Inverse of :meth:`to_dict`."""
        kw = dict(d)
        for k in ("velocities", "loads", "sine_loads"):
            if k in kw:
                kw[k] = tuple(float(v) for v in kw[k])
        return cls(**kw)


@dataclass(frozen=True)
class RunSpec:
    """One planned run: kind, load [N], velocity [m/s], direction (±1, 0 for sine)."""

    kind: str
    load: float
    velocity: float
    direction: int

    @property
    def file(self) -> str:
        """File name of the run's trace."""
        d = {1: "pos", -1: "neg", 0: "both"}[self.direction]
        return f"{self.kind}_v{self.velocity * 1000:g}mmps_F{self.load:g}N_{d}.parquet"


def plan_runs(config: CampaignConfig) -> list[RunSpec]:
    """The ordered list of runs of a campaign."""
    runs = [RunSpec("geometric", 0.0, config.geometric_velocity, d) for d in (1, -1)]
    for v in config.velocities:
        for F in config.loads:
            for d in (1, -1):
                runs.append(RunSpec("load", float(F), float(v), d))
    w = 2 * math.pi * config.sine_frequency * config.sine_amplitude
    for F in config.sine_loads:
        runs.append(RunSpec("sine", float(F), float(w), 0))
    return runs


#: Shortest constant-velocity pass a campaign records [m].
MIN_PASS = 0.1


def pass_bounds(bench: RackPinionBench, config: CampaignConfig) -> tuple[float, float]:
    """Positions [m] the passes run between: [margin, travel − margin], shortened to ``stroke``."""
    lo = config.margin
    hi = bench.travel - config.margin
    if config.stroke is not None:
        hi = min(hi, lo + config.stroke)
    return lo, hi


def unique_files(specs: Sequence[RunSpec]) -> list[str]:
    """The file name of each run; repeated runs get ``_2``, ``_3``, … before the suffix."""
    seen: dict[str, int] = {}
    out = []
    for s in specs:
        f = s.file
        seen[f] = seen.get(f, 0) + 1
        out.append(f if seen[f] == 1 else f.replace(".parquet", f"_{seen[f]}.parquet"))
    return out


def run_trajectory(
    spec: RunSpec, bench: RackPinionBench, config: CampaignConfig, T_s: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Set-point trajectory (t, x_d, v_d) of one run."""
    lo, hi = pass_bounds(bench, config)
    if spec.kind == "sine":
        xc = 0.5 * (lo + hi)
        A = min(config.sine_amplitude, 0.5 * (hi - lo))
        return sine_trajectory(xc, A, config.sine_frequency, config.sine_periods, T_s, config.dwell)
    a, b = (lo, hi) if spec.direction > 0 else (hi, lo)
    return constant_velocity_pass(a, b, spec.velocity, T_s, config.a_max, config.dwell)


def _simulate_one(
    sim: RackAxisSimulator, spec: RunSpec, config: CampaignConfig, out_dir: Path, file: str
) -> tuple[dict[str, Any], float]:
    _, x_d, v_d = run_trajectory(spec, sim.bench, config, sim.T_s)
    dec = int(round(1.0 / (config.store_rate * sim.T_s)))
    tr = sim.run(
        x_d,
        v_d,
        spec.load,
        decimate=dec,
        meta={"kind": spec.kind, "load": spec.load, "velocity": spec.velocity, "direction": spec.direction},
    )
    tr = tr.select(STORED_COLUMNS)
    tr.save(out_dir / file)
    entry = {
        "file": file,
        "kind": spec.kind,
        "load": spec.load,
        "velocity": spec.velocity,
        "direction": spec.direction,
        "samples": len(tr),
        "duration": float(x_d.size * sim.T_s),
    }
    return entry, float(x_d.size * sim.T_s)


#: Largest RK4 substep count a manifest may ask for (the engine's default is 4).
MAX_SUBSTEPS = 64


class SimulatorBlock(Document):
    """``simulator`` block of a simulated campaign: everything that regenerates the true drive.

    Attributes
    ----------
    seed : int
        Seed of the TE generator (and of the sensor noise).
    te_generator : TEGeneratorParams
        Distribution parameters of the generator.
    defects : list of LocalDefect
        Local rack defects added to the generated TE (wear).
    sim_config : AxisSimConfig
        Engine settings.
    campaign : CampaignConfig
        The recorded plan (velocities, loads, stroke, sine, store rate).
    runs : list of RunSpec, optional
        The runs, when given explicitly (an axis file's run list) instead of planned from
        ``campaign``.
    """

    seed: int = Field(ge=0, lt=2**63)
    te_generator: TEGeneratorParams = Field(default_factory=TEGeneratorParams)
    defects: list[LocalDefect] = Field(default_factory=list)
    sim_config: AxisSimConfig = Field(default_factory=AxisSimConfig)
    campaign: CampaignConfig = Field(default_factory=CampaignConfig)
    runs: list[RunSpec] | None = None

    def model_post_init(self, __context: Any) -> None:
        """Bound the engine's effort (a manifest must not ask for a simulation that never ends)."""
        if self.sim_config.n_sub > MAX_SUBSTEPS:
            raise ValueError(f"sim_config.n_sub must be <= {MAX_SUBSTEPS}, got {self.sim_config.n_sub}")
        if self.sim_config.table_dx < 1e-6:
            raise ValueError(f"sim_config.table_dx must be >= 1e-6 m, got {self.sim_config.table_dx}")

    def dump(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return self.model_dump(mode="json")

    def te_model(self, bench: RackPinionBench) -> TransmissionErrorModel:
        """The true TE of the drive on ``bench``."""
        m = TransmissionErrorModel.generate(bench, int(self.seed), self.te_generator)
        for d in self.defects:
            m = m.with_local_defect(d.x_center, d.width, d.amplitude, d.direction)
        return m


def default_gains(bench: RackPinionBench) -> CascadeGains:
    """Loop gains of the virtual bench for any axis: the bench tuning at the bench's bandwidths.

    K_v, T_n, the torque limit and the feed-forward as on the paper's bench (spec 02 §2);
    K_p scaled with the axis inertia J_s so the velocity loop keeps the bench's crossover
    K_p/J_s (≈ 1.8e3 rad/s). On the paper's bench this is exactly
    :func:`~drivelash.sim.rack_axis.bench_gains`.
    """
    ref = bench_gains()
    k = bench.J_s / RackPinionBench().J_s
    return CascadeGains(
        K_v=ref.K_v, K_p=ref.K_p * k, T_n=ref.T_n, torque_limit=ref.torque_limit, k_ff=ref.k_ff, T_s=ref.T_s
    )


def run_campaign(
    out_dir: str | Path,
    seed: int = 0,
    config: CampaignConfig | None = None,
    bench: RackPinionBench | None = None,
    te_params: TEGeneratorParams | None = None,
    gains: CascadeGains | None = None,
    sim_config: AxisSimConfig | None = None,
    workers: int = 2,
    runs: Sequence[RunSpec] | None = None,
) -> dict[str, Any]:
    """Simulate the campaign and write the traces and ``manifest.json`` into ``out_dir``.

    Parameters
    ----------
    out_dir : str or Path
        Output directory (created).
    seed : int
        Seed of the drive (TE generator); same seed ⇒ identical campaign.
    config : CampaignConfig, optional
        Runs to record; default the full protocol.
    bench, te_params, gains, sim_config : optional
        Bench, TE-generator parameters, cascade gains, engine settings.
    workers : int
        Threads simulating runs in parallel (the kernel releases the GIL).
    runs : sequence of RunSpec, optional
        The runs to record (e.g. an axis file's run list); default :func:`plan_runs`.

    Returns
    -------
    dict
        The manifest, plus ``"timing"`` (wall time [s], simulated time [s], real-time
        factor) which is *not* written to the file (so the file is reproducible).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    config = config or CampaignConfig()
    bench = bench or RackPinionBench()
    te_params = te_params or TEGeneratorParams()
    te_model = TransmissionErrorModel.generate(bench, int(seed), te_params)
    sim = RackAxisSimulator(
        bench, te_model, gains=gains or default_gains(bench), seed=int(seed), config=sim_config
    )
    dec = 1.0 / (config.store_rate * sim.T_s)
    if abs(dec - round(dec)) > 1e-9 or round(dec) < 1:
        raise ParameterError("CampaignConfig", "store_rate", "1/(store_rate T_s) must be a whole number")
    specs = list(runs) if runs is not None else plan_runs(config)
    if not specs:
        raise ParameterError("run_campaign", "runs", "no run to record")
    lo, hi = pass_bounds(bench, config)
    if hi - lo < MIN_PASS:
        raise ParameterError(
            "CampaignConfig",
            "stroke",
            f"passes over [{lo:.4g}, {hi:.4g}] m are shorter than {MIN_PASS:g} m"
            " (the preprocessing trims 30 mm at each end): lengthen the travel or the stroke",
        )
    files = unique_files(specs)
    # compile (or load the cache) once before the threads start
    sim.run(np.zeros(8), np.zeros(8))
    t0 = time.perf_counter()
    with ThreadPoolExecutor(max_workers=max(1, int(workers))) as pool:
        jobs = list(zip(specs, files, strict=True))
        results = list(pool.map(lambda sf: _simulate_one(sim, sf[0], config, out, sf[1]), jobs))
    wall = time.perf_counter() - t0
    simulated = sum(r[1] for r in results)
    manifest = CampaignManifest(
        format=FORMAT_NAME,
        version=FORMAT_VERSION,
        source="simulated",
        axis=AxisBlock.of(bench, sim.gains),
        columns=list(STORED_COLUMNS),
        runs=[RunEntry(**r[0]) for r in results],
        store_rate=config.store_rate,
        simulator=SimulatorBlock(
            seed=int(seed),
            te_generator=te_params,
            defects=[],
            sim_config=sim.config,
            campaign=config,
            runs=list(runs) if runs is not None else None,
        ).dump(),
    )
    write_json(out / MANIFEST, manifest.dump())
    result = manifest.dump()
    result["timing"] = {"wall_s": wall, "simulated_s": simulated, "real_time_factor": simulated / wall}
    return result
