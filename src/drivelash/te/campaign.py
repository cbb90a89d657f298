"""The measurement campaign on the virtual rack-and-pinion bench (spec 02 §1, §6).

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
needed). ``manifest.json`` lists the runs (file, kind, load, velocity, direction,
seed) and everything needed to regenerate the true drive: bench, TE-generator
parameters, seed, gains and engine settings.

Reading::

    camp = load_campaign(DIR)
    camp.runs                  # list[CampaignRun]; run.trace() loads the Trace
    camp.bench, camp.gains     # RackPinionBench, CascadeGains
    camp.true_te_model()       # TransmissionErrorModel for scoring
    camp.true_te(run)          # the true TE along a run (quasi-static, at the transmitted force)
    camp.simulator()           # RackAxisSimulator of the same drive
    camp.select(kind="load", direction=1, velocity=0.05)
    plot_te_over_position(camp, "fig2.png")   # the paper's Fig. 2 from the recording
"""

from __future__ import annotations

import json
import math
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import DataError, ParameterError
from drivelash.io.trace import Trace
from drivelash.params import CascadeGains
from drivelash.physics.rack_pinion import RackPinionBench, TEGeneratorParams, TransmissionErrorModel
from drivelash.sim.rack_axis import (
    AxisSimConfig,
    RackAxisSimulator,
    constant_velocity_pass,
    sine_trajectory,
)

FORMAT = "drivelash.te_campaign/1"
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


def run_trajectory(
    spec: RunSpec, bench: RackPinionBench, config: CampaignConfig, T_s: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Set-point trajectory (t, x_d, v_d) of one run."""
    lo = config.margin
    hi = bench.travel - config.margin
    if config.stroke is not None:
        hi = min(hi, lo + config.stroke)
    if spec.kind == "sine":
        xc = 0.5 * (lo + hi)
        A = min(config.sine_amplitude, 0.5 * (hi - lo))
        return sine_trajectory(xc, A, config.sine_frequency, config.sine_periods, T_s, config.dwell)
    a, b = (lo, hi) if spec.direction > 0 else (hi, lo)
    return constant_velocity_pass(a, b, spec.velocity, T_s, config.a_max, config.dwell)


def _simulate_one(
    sim: RackAxisSimulator, spec: RunSpec, config: CampaignConfig, out_dir: Path, seed: int
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
    tr.save(out_dir / spec.file)
    entry = {
        "file": spec.file,
        "kind": spec.kind,
        "load": spec.load,
        "velocity": spec.velocity,
        "direction": spec.direction,
        "seed": seed,
        "samples": len(tr),
        "duration": float(x_d.size * sim.T_s),
    }
    return entry, float(x_d.size * sim.T_s)


def run_campaign(
    out_dir: str | Path,
    seed: int = 0,
    config: CampaignConfig | None = None,
    bench: RackPinionBench | None = None,
    te_params: TEGeneratorParams | None = None,
    gains: CascadeGains | None = None,
    sim_config: AxisSimConfig | None = None,
    workers: int = 2,
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
    sim = RackAxisSimulator(bench, te_model, gains=gains, seed=int(seed), config=sim_config)
    dec = 1.0 / (config.store_rate * sim.T_s)
    if abs(dec - round(dec)) > 1e-9 or round(dec) < 1:
        raise ParameterError("CampaignConfig", "store_rate", "1/(store_rate T_s) must be a whole number")
    specs = plan_runs(config)
    # compile (or load the cache) once before the threads start
    sim.run(np.zeros(8), np.zeros(8))
    t0 = time.perf_counter()
    with ThreadPoolExecutor(max_workers=max(1, int(workers))) as pool:
        results = list(pool.map(lambda s: _simulate_one(sim, s, config, out, int(seed)), specs))
    wall = time.perf_counter() - t0
    simulated = sum(r[1] for r in results)
    manifest = {
        "format": FORMAT,
        "seed": int(seed),
        "te_model": te_model.to_dict(),
        "bench": bench.to_dict(),
        "te_generator": te_params.to_dict(),
        "gains": asdict(sim.gains),
        "sim_config": asdict(sim.config),
        "campaign": config.to_dict(),
        "T_s": sim.T_s,
        "store_rate": config.store_rate,
        "columns": list(STORED_COLUMNS),
        "runs": [r[0] for r in results],
    }
    (out / "manifest.json").write_text(json.dumps(manifest, indent=1), encoding="utf-8")
    manifest = dict(manifest)
    manifest["timing"] = {"wall_s": wall, "simulated_s": simulated, "real_time_factor": simulated / wall}
    return manifest


@dataclass(frozen=True)
class CampaignRun:
    """One recorded run (see the manifest fields)."""

    path: Path
    kind: str
    load: float
    velocity: float
    direction: int
    seed: int

    def trace(self) -> Trace:
        """Load the run's :class:`Trace`."""
        return Trace.from_parquet(self.path)


@dataclass
class Campaign:
    """A campaign directory read back by :func:`load_campaign`."""

    directory: Path
    manifest: dict[str, Any]
    runs: list[CampaignRun] = field(default_factory=list)

    @property
    def bench(self) -> RackPinionBench:
        """The bench the campaign was recorded on."""
        return RackPinionBench.from_dict(self.manifest["bench"])

    @property
    def gains(self) -> CascadeGains:
        """The cascade gains of the recording."""
        return CascadeGains(**self.manifest["gains"])

    @property
    def seed(self) -> int:
        """Seed of the drive."""
        return int(self.manifest["seed"])

    def true_te_model(self) -> TransmissionErrorModel:
        """Regenerate the true transmission-error model (for scoring)."""
        return TransmissionErrorModel.from_dict(self.manifest["te_model"])

    def true_te(self, run: CampaignRun, trace: Trace | None = None) -> np.ndarray:
        """The true TE along a recorded run [m], quasi-static.

        TE(x_T, F, d) of :meth:`true_te_model` with d the commanded direction and F the
        force the mesh transmits at constant velocity, F_load + F_CT + β_T |v_T|
        (v_T from the recorded x_T). Accurate to the dynamics of the run (inertia during
        ramps and reversals, damping: ≲ 0.01 µm at 10 mm/s at constant speed).

        Parameters
        ----------
        run : CampaignRun
            The run.
        trace : Trace, optional
            Its trace if already loaded.
        """
        tr = trace if trace is not None else run.trace()
        bench = self.bench
        v = np.gradient(tr["x_T"], tr["t"])
        F = tr["F_load"] + bench.table_friction(v)
        d = np.where(tr["direction"] >= 0, 1, -1)
        return self.true_te_model().te(tr["x_T"], F, d)

    def simulator(self) -> RackAxisSimulator:
        """A simulator of the same drive, gains and engine settings."""
        return RackAxisSimulator(
            self.bench,
            self.true_te_model(),
            gains=self.gains,
            seed=self.seed,
            config=AxisSimConfig(**self.manifest["sim_config"]),
        )

    def select(self, kind: str | None = None, direction: int | None = None, velocity: float | None = None,
               load: float | None = None) -> list[CampaignRun]:  # fmt: skip
        """Runs matching all given fields (velocity and load compared to 1e-9)."""
        out = []
        for r in self.runs:
            if kind is not None and r.kind != kind:
                continue
            if direction is not None and r.direction != direction:
                continue
            if velocity is not None and abs(r.velocity - velocity) > 1e-9:
                continue
            if load is not None and abs(r.load - load) > 1e-9:
                continue
            out.append(r)
        return out


def load_campaign(directory: str | Path) -> Campaign:
    """Read ``manifest.json`` of a campaign directory.

    Raises
    ------
    DataError
        Missing or malformed manifest, or a listed trace file that does not exist.
    """
    d = Path(directory)
    mpath = d / "manifest.json"
    if not mpath.is_file():
        raise DataError("no manifest.json: not a campaign directory", path=str(d))
    try:
        manifest = json.loads(mpath.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise DataError(f"malformed JSON ({exc.msg}, line {exc.lineno})", path=str(mpath)) from None
    if manifest.get("format") != FORMAT:
        raise DataError(f"unknown format {manifest.get('format')!r}, expected {FORMAT!r}", path=str(mpath))
    runs = []
    for r in manifest.get("runs", []):
        p = d / r["file"]
        if not p.is_file():
            raise DataError("listed in the manifest but missing", path=str(p))
        runs.append(
            CampaignRun(
                p, r["kind"], float(r["load"]), float(r["velocity"]), int(r["direction"]), int(r["seed"])
            )
        )
    return Campaign(d, manifest, runs)


def measured_te(trace: Trace, bench: RackPinionBench) -> np.ndarray:
    """TE = x_T − θ_M d_p/(2 i_PG) along a recorded run [m], eq (1)."""
    return bench.te_from_measurement(trace["x_T"], trace["theta_m"])


def plot_te_over_position(
    campaign: Campaign, path: str | Path, velocity: float | None = None, step: float = 200e-6
) -> Path:
    """Fig. 2 of the paper from a campaign: TE over position, both directions, all loads.

    Parameters
    ----------
    campaign : Campaign
        The recording.
    path : str or Path
        PNG to write.
    velocity : float, optional
        Velocity of the load runs to show [m/s]; default the lowest recorded.
    step : float
        Plot resolution over position [m].

    Returns
    -------
    Path
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    bench = campaign.bench
    loads = campaign.select(kind="load")
    if velocity is None and loads:
        velocity = min(r.velocity for r in loads)
    fig, ax = plt.subplots(2, 1, figsize=(11, 8), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    cmap = plt.get_cmap("viridis")
    F_max = max([r.load for r in loads] + [1.0])
    geo = {}
    for r in campaign.select(kind="geometric"):
        tr = r.trace()
        x, te = tr["x_T"], measured_te(tr, bench)
        grid = np.arange(x.min(), x.max(), step)
        order = np.argsort(x)
        geo[r.direction] = (grid, np.interp(grid, x[order], te[order]))
        ax[0].plot(grid, geo[r.direction][1] * 1e6, color="k", lw=0.8)
    for r in campaign.select(kind="load", velocity=velocity):
        tr = r.trace()
        x, te = tr["x_T"], measured_te(tr, bench)
        grid = np.arange(x.min(), x.max(), step)
        order = np.argsort(x)
        ax[0].plot(grid, np.interp(grid, x[order], te[order]) * 1e6, color=cmap(r.load / F_max), lw=0.5)
    if 1 in geo and -1 in geo:
        g = geo[1][0]
        lo = np.interp(g, *geo[1])
        hi = np.interp(g, *geo[-1])
        ax[0].fill_between(g, lo * 1e6, hi * 1e6, color="tab:orange", alpha=0.25, label="backlash (no load)")
        ax[1].plot(g, (hi - lo) * 1e6, color="tab:orange")
    ax[0].set_ylabel("TE = x_T − x_M [µm]")
    v_txt = f"{velocity * 1e3:g} mm/s" if velocity else ""
    ax[0].set_title(
        f"Transmission error, both directions, loads 0…{F_max:g} N (colour) {v_txt}; black: 10 mm/s, no load"
    )
    ax[0].legend(loc="upper right")
    ax[1].set_ylabel("gap [µm]")
    ax[1].set_xlabel("table position x_T [m]")
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
