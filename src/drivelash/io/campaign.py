"""The campaign directory: published, versioned manifest schema (``drivelash.te-campaign``, v2).

A campaign directory holds one Parquet trace per run and ``manifest.json``::

    {
      "format": "drivelash.te-campaign", "version": 2, "generator": "drivelash 0.x",
      "source": "imported" | "simulated",
      "axis": {"geometry": {m_n, n_t, helix_angle, alpha_n, face_width, i_PG, travel,
                            contact_ratio},                       # RackGeometry [SI]
               "drive": {m_T, J_motor, J_gearbox, J_pinion, T_Cm, beta_m, F_CT, beta_T,
                         zeta_mesh},                              # RackDrive [SI]
               "gains": {K_v, K_p, T_n, torque_limit, k_ff, T_s} | null},   # CascadeGains
      "columns": ["t", "x_T", "theta_m", "torque_m", ...],       # stored in every run
      "runs": [{"file": "load_v50mmps_F1500N_pos.parquet", "kind": "load",
                "direction": 1, "velocity": 0.05, "load": 1500.0,
                "samples": 24000, "duration": 24.0, "recording": "pass_07.csv"}, ...],
      "import": {...} | null,          # te import: axis file, recordings, plausibility report
      "simulator": {...} | null        # te campaign: seed, TE generator, engine, campaign plan
    }

Units are SI throughout (m, rad, N, N·m, s, kg). ``kind`` is ``geometric`` (no-load
passes over the travel, both directions: the geometric error TE_geo and the backlash),
``load`` (constant-velocity passes under a process load acting against the motion) or
``sine`` (a trajectory with reversals; ``direction`` 0). ``velocity`` is the travel speed
of the constant-velocity part [m/s], ``load`` the process-load magnitude [N]. A run file
is a Parquet trace with at least the columns :data:`REQUIRED_COLUMNS` in SI units and
optionally :data:`OPTIONAL_COLUMNS`; every file name is relative to the directory and
must stay inside it. An imported campaign has no seed and no true TE.

:func:`read_manifest` validates a manifest (one-line errors naming file and key);
:func:`manifest_v1_to_v2` reads the unversioned manifests of earlier releases.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal

from pydantic import Field, field_validator, model_validator

from drivelash.errors import DataError
from drivelash.io.jsondoc import Document, inside, read_raw_document, validate_document
from drivelash.params import CascadeGains
from drivelash.physics.rack_pinion import RackDrive, RackGeometry, RackPinionBench

__all__ = [
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "MANIFEST",
    "OPTIONAL_COLUMNS",
    "REQUIRED_COLUMNS",
    "RUN_KINDS",
    "AxisBlock",
    "CampaignManifest",
    "RunEntry",
    "read_manifest",
    "run_path",
]

FORMAT_NAME = "drivelash.te-campaign"
FORMAT_VERSION = 2
MANIFEST = "manifest.json"
#: Columns every run file holds [SI]: time, table position (linear scale), motor angle, motor torque.
REQUIRED_COLUMNS = ("t", "x_T", "theta_m", "torque_m")
#: Columns a run file may hold: set position [m], motor velocity [rad/s], process load [N],
#: commanded direction (±1).
OPTIONAL_COLUMNS = ("x_d", "omega_m", "F_load", "direction")
RUN_KINDS = ("geometric", "load", "sine")
#: The v1 manifests (no published schema) of the first release.
FORMAT_V1 = "drivelash.te_campaign/1"
#: Largest plausible magnitudes of run entries (guards against unit slips and garbage).
MAX_VELOCITY = 10.0  # m/s
MAX_LOAD = 1e7  # N


class AxisBlock(Document):
    """``axis``: the rack-and-pinion axis the campaign was recorded on.

    Attributes
    ----------
    geometry : RackGeometry
        Module, teeth, helix angle, gearbox ratio, travel, contact ratio [SI].
    drive : RackDrive
        Table mass, inertias and friction of the drive train [SI].
    gains : CascadeGains or None
        The position/velocity loop gains of the drive (eq. (3) of the monitoring); None
        when unknown.
    """

    geometry: RackGeometry
    drive: RackDrive = Field(default_factory=RackDrive)
    gains: CascadeGains | None = None

    @property
    def bench(self) -> RackPinionBench:
        """Geometry and drive as one :class:`~drivelash.physics.rack_pinion.RackPinionBench`."""
        return RackPinionBench.from_parts(self.geometry, self.drive)

    @classmethod
    def of(cls, bench: RackPinionBench, gains: CascadeGains | None = None) -> AxisBlock:
        """The block of a bench (and its gains)."""
        return cls(geometry=bench.geometry, drive=bench.drive, gains=gains)


class RunEntry(Document):
    """One run of the campaign.

    Attributes
    ----------
    file : str
        Parquet trace, relative to the campaign directory.
    kind : {"geometric", "load", "sine"}
        What the run records.
    direction : {1, -1, 0}
        Direction of travel (0 for a sine with reversals).
    velocity : float
        Travel speed of the constant-velocity part [m/s] (sine: peak speed).
    load : float
        Process-load magnitude [N] (0 for geometric runs).
    samples : int, optional
        Rows of the trace.
    duration : float, optional
        Length of the run [s].
    recording : str, optional
        The user's original recording (imported campaigns), for reference only.
    """

    file: str
    kind: Literal["geometric", "load", "sine"]
    direction: Literal[1, -1, 0]
    velocity: float = Field(gt=0, le=MAX_VELOCITY)
    load: float = Field(ge=0, le=MAX_LOAD)
    samples: int | None = Field(default=None, ge=3)
    duration: float | None = Field(default=None, gt=0)
    recording: str | None = None

    @field_validator("velocity", "load", "duration")
    @classmethod
    def _finite(cls, v: float | None) -> float | None:
        if v is not None and not math.isfinite(v):
            raise ValueError("must be finite")
        return v

    @model_validator(mode="after")
    def _consistent(self) -> RunEntry:
        if (self.kind == "sine") != (self.direction == 0):
            raise ValueError(f"direction {self.direction} does not fit kind '{self.kind}' (0 only for sine)")
        if self.kind == "geometric" and self.load != 0:
            raise ValueError(f"a geometric run has no load, got {self.load:g} N")
        if not self.file.lower().endswith((".parquet", ".pq")):
            raise ValueError(f"run file {self.file!r} must be a Parquet trace")
        return self


class CampaignManifest(Document):
    """``manifest.json`` of a campaign directory (see the module documentation)."""

    format: Literal["drivelash.te-campaign"]
    version: Literal[2]
    generator: str | None = None
    source: Literal["imported", "simulated"]
    axis: AxisBlock
    columns: list[str]
    runs: list[RunEntry] = Field(min_length=1)
    store_rate: float | None = Field(default=None, gt=0)
    import_: dict[str, Any] | None = Field(default=None, alias="import")
    simulator: dict[str, Any] | None = None

    @model_validator(mode="after")
    def _check(self) -> CampaignManifest:
        missing = [c for c in REQUIRED_COLUMNS if c not in self.columns]
        if missing:
            raise ValueError(f"columns: missing required column '{missing[0]}'")
        unknown = [c for c in self.columns if c not in (*REQUIRED_COLUMNS, *OPTIONAL_COLUMNS)]
        if unknown:
            raise ValueError(f"columns: unknown column '{unknown[0]}'")
        seen: set[str] = set()
        for i, r in enumerate(self.runs):
            if r.file in seen:
                raise ValueError(f"runs[{i}].file: {r.file!r} listed twice")
            seen.add(r.file)
        if self.source == "simulated" and self.simulator is None:
            raise ValueError("a simulated campaign needs its 'simulator' block")
        if self.source == "imported" and self.simulator is not None:
            raise ValueError("an imported campaign has no 'simulator' block")
        return self

    def dump(self) -> dict[str, Any]:
        """JSON-ready dict (the ``import`` key under its published name)."""
        return self.model_dump(mode="json", by_alias=True, exclude_none=True)

    @property
    def loads(self) -> tuple[float, ...]:
        """Distinct loads of the ``load`` runs [N], ascending."""
        return tuple(sorted({r.load for r in self.runs if r.kind == "load"}))

    @property
    def velocities(self) -> tuple[float, ...]:
        """Distinct velocities of the ``load`` runs [m/s], ascending."""
        return tuple(sorted({r.velocity for r in self.runs if r.kind == "load"}))


RUN_KEYS_V1 = ("file", "kind", "direction", "velocity", "load", "samples", "duration")


def manifest_v1_to_v2(data: dict[str, Any], path: str | Path) -> dict[str, Any]:
    """The v2 form of a first-release (``drivelash.te_campaign/1``) simulator manifest."""
    try:
        bench = RackPinionBench.from_dict(dict(data["bench"]))
        runs = [
            {
                k: r[k]
                for k in ("file", "kind", "direction", "velocity", "load", "samples", "duration")
                if k in r
            }
            for r in data["runs"]
        ]
        sim = {k: data[k] for k in ("seed", "te_generator", "sim_config", "campaign") if k in data}
        sim["defects"] = list(data.get("te_model", {}).get("defects", []))
        return {
            "format": FORMAT_NAME,
            "version": FORMAT_VERSION,
            "source": "simulated",
            "axis": {
                "geometry": bench.geometry,
                "drive": bench.drive,
                "gains": data.get("gains"),
            },
            "columns": list(data.get("columns", REQUIRED_COLUMNS)),
            "runs": runs,
            "store_rate": data.get("store_rate"),
            "simulator": sim,
        }
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise DataError(
            f"malformed version-1 manifest ({type(exc).__name__}: {exc})", path=str(path)
        ) from None


def read_manifest(directory: str | Path) -> CampaignManifest:
    """Read and validate ``directory/manifest.json``.

    Raises
    ------
    DataError
        Not a campaign directory, malformed JSON, unknown format or version, a key
        missing, of the wrong type or out of range — one line naming the file and key.
    """
    d = Path(directory)
    if not d.is_dir():
        raise DataError(f"not a campaign directory (not found; a campaign holds {MANIFEST})", path=str(d))
    mpath = d / MANIFEST
    if not mpath.is_file():
        raise DataError("no manifest.json: not a campaign directory", path=str(d))
    raw = read_raw_document(mpath)
    fmt, version = raw.get("format"), raw.get("version")
    if fmt == FORMAT_V1:
        return validate_document(manifest_v1_to_v2(raw, mpath), CampaignManifest, mpath)
    if fmt != FORMAT_NAME:
        raise DataError(
            f"key 'format': {fmt!r} is not a drivelash campaign ({FORMAT_NAME!r})", path=str(mpath)
        )
    if version != FORMAT_VERSION:
        msg = f"key 'version': unsupported campaign format version {version!r} (this release reads 2)"
        raise DataError(msg, path=str(mpath))
    return validate_document(raw, CampaignManifest, mpath)


def run_path(directory: str | Path, entry: RunEntry, index: int) -> Path:
    """The trace file of run ``index``, resolved inside the campaign directory and present."""
    mpath = Path(directory) / MANIFEST
    p = inside(directory, entry.file, document=mpath, key=f"runs[{index}].file")
    if not p.is_file():
        raise DataError(f"key 'runs[{index}].file': {entry.file!r} is listed but missing", path=str(mpath))
    return p
