"""A measurement campaign directory read back (spec 02 §1, §6), simulated or imported.

Reading::

    camp = load_campaign(DIR)                # manifest validated (drivelash.io.campaign)
    camp.runs                                # list[CampaignRun]; run.trace() loads the Trace
    camp.bench, camp.gains                   # RackPinionBench, CascadeGains (None if unknown)
    camp.select(kind="load", direction=1, velocity=0.05)
    camp.is_simulated                        # a virtual-bench campaign (te campaign)
    camp.true_te_model(); camp.true_te(run); camp.simulator(); camp.seed   # simulated only

Campaigns are recorded on the virtual bench by :func:`drivelash.sim.rack_campaign.run_campaign`
and brought in from real recordings by :func:`drivelash.te.protocol.importer.import_campaign`;
both write the published schema of :mod:`drivelash.io.campaign`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import DataError
from drivelash.io.campaign import MANIFEST, REQUIRED_COLUMNS, CampaignManifest, read_manifest, run_path
from drivelash.io.jsondoc import Document, validate_document
from drivelash.io.load import load_trace
from drivelash.io.trace import Trace
from drivelash.params import CascadeGains
from drivelash.physics.rack_pinion import RackPinionBench, TransmissionErrorModel
from drivelash.sim.rack_axis import RackAxisSimulator
from drivelash.sim.rack_campaign import SimulatorBlock

__all__ = ["Campaign", "CampaignRun", "check_same_axis", "load_campaign", "measured_te"]


@dataclass(frozen=True)
class CampaignRun:
    """One recorded run (see :class:`drivelash.io.campaign.RunEntry`).

    Attributes
    ----------
    path : Path
        Its Parquet trace (inside the campaign directory).
    kind : str
        ``geometric``, ``load`` or ``sine``.
    load : float
        Process load [N].
    velocity : float
        Travel speed [m/s].
    direction : int
        +1, −1 (0 for sine).
    index : int
        Position in the manifest's ``runs`` list.
    """

    path: Path
    kind: str
    load: float
    velocity: float
    direction: int
    index: int = 0

    @property
    def name(self) -> str:
        """The file name without suffix."""
        return self.path.stem

    def trace(self) -> Trace:
        """Load the run's :class:`Trace`, validated (finite values, uniform time, required columns).

        Raises
        ------
        DataError
            Truncated, empty or unreadable file, a missing column, a NaN — one line naming
            the file, the column and the row.
        """
        return load_trace(self.path, required=REQUIRED_COLUMNS)


@dataclass
class Campaign:
    """A campaign directory read back by :func:`load_campaign`.

    Attributes
    ----------
    directory : Path
        The campaign directory.
    manifest : CampaignManifest
        ``manifest.json``, validated (axis, simulator, runs).
    runs : list of CampaignRun
        Every run of the manifest, its file resolved inside ``directory``.
    """

    directory: Path
    manifest: CampaignManifest
    runs: list[CampaignRun] = field(default_factory=list)

    @property
    def manifest_path(self) -> Path:
        """``manifest.json``."""
        return self.directory / MANIFEST

    @property
    def bench(self) -> RackPinionBench:
        """The axis the campaign was recorded on (geometry and drive)."""
        return self.manifest.axis.bench

    @property
    def gains(self) -> CascadeGains | None:
        """The cascade gains of the recording (None when the axis file gave none)."""
        return self.manifest.axis.gains

    @property
    def is_simulated(self) -> bool:
        """True for a virtual-bench campaign (it has a ``simulator`` block)."""
        return self.manifest.simulator is not None

    @cached_property
    def simulator_block(self) -> SimulatorBlock:
        """The validated ``simulator`` block (simulated campaigns only)."""
        if self.manifest.simulator is None:
            raise DataError(
                "an imported campaign has no simulator (no seed, no true TE): this needs a campaign"
                " recorded on the virtual bench (te campaign)",
                path=str(self.manifest_path),
            )
        doc = {"simulator": self.manifest.simulator}
        return validate_document(doc, _SimulatorKey, self.manifest_path).simulator

    @property
    def seed(self) -> int:
        """Seed of the simulated drive."""
        return int(self.simulator_block.seed)

    @property
    def velocities(self) -> tuple[float, ...]:
        """Distinct velocities of the load runs [m/s]."""
        return self.manifest.velocities

    @property
    def loads(self) -> tuple[float, ...]:
        """Distinct loads of the load runs [N]."""
        return self.manifest.loads

    def true_te_model(self) -> TransmissionErrorModel:
        """Regenerate the true transmission-error model (simulated campaigns only)."""
        return self.simulator_block.te_model(self.bench)

    def true_te(self, run: CampaignRun, trace: Trace | None = None) -> np.ndarray:
        """The true TE along a recorded run [m], quasi-static (simulated campaigns only).

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
        """A simulator of the same drive, gains and engine settings (simulated campaigns only)."""
        blk = self.simulator_block
        return RackAxisSimulator(
            self.bench, self.true_te_model(), gains=self.gains, seed=self.seed, config=blk.sim_config
        )

    def select(self, kind: str | None = None, direction: int | None = None, velocity: float | None = None,
               load: float | None = None) -> list[CampaignRun]:  # fmt: skip
        """Runs matching all given fields (velocity and load compared to 1e-9).

        Parameters
        ----------
        kind : str, optional
            ``"geometric"``, ``"load"`` or ``"sine"``.
        direction : int, optional
            +1 or −1 (0 for sine runs).
        velocity : float, optional
            Travel speed [m/s].
        load : float, optional
            Process load [N].
        """
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


class _SimulatorKey(Document):
    """Wraps the block so that error messages name the key ``simulator.…``."""

    simulator: SimulatorBlock


def load_campaign(directory: str | Path) -> Campaign:
    """Read a campaign directory: ``manifest.json`` validated, every run file resolved inside it.

    Run traces are read (and validated) on demand by :meth:`CampaignRun.trace`.

    Parameters
    ----------
    directory : str or Path
        The campaign directory (``te campaign -o`` or ``te import``).

    Raises
    ------
    DataError
        Missing or malformed manifest, a key missing or invalid, a run file outside the
        directory or missing — one line naming the file and the key.
    """
    d = Path(directory)
    manifest = read_manifest(d)
    runs = [
        CampaignRun(run_path(d, r, i), r.kind, float(r.load), float(r.velocity), int(r.direction), i)
        for i, r in enumerate(manifest.runs)
    ]
    camp = Campaign(d, manifest, runs)
    if camp.is_simulated:
        camp.simulator_block  # noqa: B018 - validated now, so a bad block fails early
    return camp


def check_same_axis(
    campaign: Any, geometry: Any, path: str | Path, whose: str, what: str = "the passes'"
) -> None:
    """Refuse ``campaign`` when its axis (pitch diameter, teeth, gearbox ratio) is not ``geometry``'s.

    Parameters
    ----------
    campaign : Campaign
        The passes to check.
    geometry : GearGeometry
        The reference (a model's ``pipeline.geometry``, or another campaign's
        ``GearGeometry.from_bench``).
    path : str or Path
        File named in the error (the campaign's manifest).
    whose, what : str
        The reference and the campaign in the message, e.g. ``"the model's"``, ``"the passes'"``.

    Raises
    ------
    DataError
        ``d_p of the passes' axis is 0.0764, the model's is 0.0849: passes of another axis``.
    """
    from drivelash.te.learn.preprocess import GearGeometry

    try:
        g = GearGeometry.from_bench(campaign.bench)
    except Exception:  # noqa: BLE001 - a campaign without a bench block: nothing to compare
        return
    for name in ("d_p", "n_t", "i_pg"):
        a, b = float(getattr(g, name)), float(getattr(geometry, name))
        if not np.isclose(a, b, rtol=1e-6, atol=0.0):
            raise DataError(
                f"{name} of {what} axis is {a:g}, {whose} is {b:g}: passes of another axis",
                path=str(path),
            )


def measured_te(trace: Trace, bench: RackPinionBench) -> np.ndarray:
    """TE = x_T − θ_M d_p/(2 i_PG) along a recorded run [m], eq (1)."""
    return bench.te_from_measurement(trace["x_T"], trace["theta_m"])
