"""The axis description: one TOML file for a rack-and-pinion axis, real or virtual.

``drivelash te import AXIS.toml -o CAMPAIGN`` reads the user's recordings with it;
``drivelash te campaign --config AXIS.toml -o CAMPAIGN`` records the same axis (and, if
the file lists runs, the same runs) on the virtual bench. Tables (every key SI, generated
from the parameter dataclasses — :mod:`drivelash.io.config`)::

    [geometry]            # RackGeometry: m_n [m], n_t, helix_angle [rad], alpha_n [rad],
                          #   face_width [m], i_PG, travel [m], contact_ratio (optional override)
    [drive]               # RackDrive: m_T [kg], J_motor, J_gearbox, J_pinion [kg·m²],
                          #   T_Cm [N·m], beta_m [N·m·s/rad], F_CT [N], beta_T [N·s/m], zeta_mesh
    [gains]               # CascadeGains: K_v [1/s], K_p [N·m·s/rad], T_n [s], torque_limit [N·m],
                          #   k_ff, T_s [s]; optional — left out, the virtual bench uses the
                          #   paper's tuning scaled to the axis inertia and an import records none
    [columns.<source>]    # the recordings' columns → t, x_T, theta_m, torque_m (x_d, F_load, …):
                          #   unit, counts_per_rev, torque_constant, and scale/offset — the
                          #   encoder sign is ``scale = -1``, the scale zero ``offset`` [m, SI]
    [sampling]            # time unit, sample rate, jitter tolerance
    [[runs]]              # kind = "geometric" | "load" | "sine", direction = 1 | -1 (0: sine),
                          #   velocity [m/s] (optional for import: measured), load [N], file
    [campaign]            # virtual bench only: CampaignConfig (velocities, loads, stroke, …)
    [te_generator]        # virtual bench only: TEGeneratorParams (runout, mesh, backlash, …)

Every table is optional at parse time; a command names what it needs. Unknown keys,
wrong types and values the dataclasses refuse are one-line errors naming file, table
and key. Run files are relative to the axis file.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal

from pydantic import Field, field_validator, model_validator

from drivelash.errors import ConfigError
from drivelash.io.config import ColumnMap, ConfigFile, SamplingSection, Table, load_file, section
from drivelash.params import CascadeGains
from drivelash.physics.rack_pinion import RackDrive, RackGeometry, RackPinionBench, TEGeneratorParams
from drivelash.sim.rack_campaign import CampaignConfig, default_gains

__all__ = ["AxisFile", "RunTable", "load_axis"]

DriveSection = section(RackDrive, overrides=True)
GainsSection = section(CascadeGains, overrides=True)
CampaignSection = section(CampaignConfig, overrides=True)
GeneratorSection = section(TEGeneratorParams, overrides=True)


class RunTable(Table):
    """One ``[[runs]]`` entry.

    Attributes
    ----------
    kind : {"geometric", "load", "sine"}
        No-load pass (geometric error and backlash), pass under a process load, or a
        trajectory with reversals.
    direction : {1, -1, 0}
        Direction of travel (0 for sine).
    velocity : float, optional
        Travel speed of the constant-velocity part [m/s]; measured from the recording
        when left out (import).
    load : float
        Process-load magnitude against the motion [N].
    file : str, optional
        The recording, relative to the axis file (required by ``te import``).
    """

    kind: Literal["geometric", "load", "sine"]
    direction: Literal[1, -1, 0]
    velocity: float | None = Field(default=None, gt=0, le=10.0)
    load: float = Field(default=0.0, ge=0, le=1e7)
    file: str | None = None

    @model_validator(mode="after")
    def _consistent(self) -> RunTable:
        if (self.kind == "sine") != (self.direction == 0):
            raise ValueError(f"direction {self.direction} does not fit kind '{self.kind}' (0 only for sine)")
        if self.kind == "geometric" and self.load != 0:
            raise ValueError(f"a geometric run has no load, got {self.load:g} N")
        return self


#: Unit slips in [geometry] (SI: m, rad): a value beyond the limit is the other unit read as SI.
#: Module: the largest racks have m_n ≈ 30–50 mm; 0.05 m. Face width: 1 m. Travel: no
#: rack-and-pinion machine axis is longer than 100 m (and the virtual bench's memory grows with
#: it: 0.42 GB at 2.2 m, 1.7 GB at 120 m, ≈ 13 GB at 1200 m). Angles: a helix angle ≥ 60° and a
#: pressure angle ≥ 45° are not gears (RackGeometry refuses the first) — in degrees they are.
GEOMETRY_LIMITS: dict[str, tuple[float, str]] = {
    "m_n": (0.05, "m"),
    "face_width": (1.0, "m"),
    "travel": (100.0, "m"),
    "helix_angle": (math.pi / 3, "rad"),
    "alpha_n": (math.pi / 4, "rad"),
}


def _unit_slip(key: str, value: float) -> str | None:
    """Why ``value`` of ``[geometry] key`` looks like a unit slip (None: plausible)."""
    limit, unit = GEOMETRY_LIMITS[key]
    if not value > limit:
        return None
    if unit == "rad":
        deg = math.degrees(value)
        hint = f" — {value:g}° is {math.radians(value):.6g} rad" if value < 90 else ""
        return (
            f"{value:g} is read in rad ({value:g} rad = {deg:.4g}°), the key is in rad{hint}"
            f" (limit {math.degrees(limit):.0f}°)"
        )
    what = {"m_n": "the module", "face_width": "the face width", "travel": "the travel"}[key]
    extra = "; no rack-and-pinion machine axis is longer" if key == "travel" else ""
    return (
        f"{value:g} is read in m ({value:g} m), {what} is in m — {value:g} mm is {value * 1e-3:g}"
        f" (limit {limit:g} m{extra})"
    )


class GeometrySection(section(RackGeometry, overrides=True)):  # type: ignore[misc]
    """``[geometry]`` (:class:`RackGeometry`) with the unit slips named (:data:`GEOMETRY_LIMITS`)."""

    @field_validator(*GEOMETRY_LIMITS, mode="after")
    @classmethod
    def _units(cls, v: Any, info: Any) -> Any:
        if isinstance(v, (int, float)) and math.isfinite(v):
            why = _unit_slip(info.field_name, float(v))
            if why:
                raise ValueError(why)
        return v


class AxisFile(ConfigFile):
    """An axis description (see the module documentation)."""

    geometry: GeometrySection | None = None  # type: ignore[valid-type]
    drive: DriveSection | None = None  # type: ignore[valid-type]
    gains: GainsSection | None = None  # type: ignore[valid-type]
    columns: dict[str, ColumnMap] | None = None
    sampling: SamplingSection | None = None
    runs: list[RunTable] | None = None
    campaign: CampaignSection | None = None  # type: ignore[valid-type]
    te_generator: GeneratorSection | None = None  # type: ignore[valid-type]

    @property
    def directory(self) -> Path:
        """The directory of the axis file (run files are relative to it)."""
        return Path(self.source).parent

    def bench(self, require_geometry: bool = False) -> RackPinionBench:
        """``[geometry]`` and ``[drive]`` on the paper's bench as base (its geometry required if asked)."""
        if require_geometry:
            self.require("geometry")
        geo = self.params("geometry", base=RackGeometry())
        drive = self.params("drive", base=RackDrive())
        return RackPinionBench.from_parts(geo, drive)

    def cascade_gains(self, bench: RackPinionBench, default: bool = True) -> CascadeGains | None:
        """``[gains]`` over the virtual bench's gains for ``bench``; without the table: those (or None)."""
        if self.gains is None:
            return default_gains(bench) if default else None
        return self.params("gains", base=default_gains(bench))

    def campaign_config(self) -> CampaignConfig:
        """``[campaign]`` over the full protocol."""
        return self.params("campaign", base=CampaignConfig())

    def generator(self) -> TEGeneratorParams:
        """``[te_generator]`` over the default generator."""
        return self.params("te_generator", base=TEGeneratorParams())

    def run_list(self, need_files: bool) -> list[RunTable]:
        """``[[runs]]`` (required, and every run with a ``file`` when ``need_files``)."""
        runs = self.require("runs")
        if not runs:
            raise ConfigError(f"{self.source}: table [[runs]] is empty")
        if need_files:
            for i, r in enumerate(runs):
                if not r.file:
                    raise ConfigError(f"{self.source}: table [[runs]] #{i + 1}, key 'file': missing")
        return list(runs)


def load_axis(path: str | Path) -> AxisFile:
    """Read and validate an axis file (:class:`AxisFile`); one-line :class:`ConfigError` on any problem."""
    return load_file(path, AxisFile)
