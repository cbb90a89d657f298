"""A measurement campaign directory read back (spec 02 §1, §6).

Reading::

    camp = load_campaign(DIR)
    camp.runs                  # list[CampaignRun]; run.trace() loads the Trace
    camp.bench, camp.gains     # RackPinionBench, CascadeGains
    camp.true_te_model()       # TransmissionErrorModel for scoring
    camp.true_te(run)          # the true TE along a run (quasi-static, at the transmitted force)
    camp.simulator()           # RackAxisSimulator of the same drive
    camp.select(kind="load", direction=1, velocity=0.05)

Campaigns are recorded on the virtual bench by :func:`drivelash.sim.rack_campaign.run_campaign`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import DataError
from drivelash.io.trace import Trace
from drivelash.params import CascadeGains
from drivelash.physics.rack_pinion import RackPinionBench, TransmissionErrorModel
from drivelash.sim.rack_axis import AxisSimConfig, RackAxisSimulator
from drivelash.sim.rack_campaign import FORMAT

__all__ = ["Campaign", "CampaignRun", "load_campaign", "measured_te"]


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
