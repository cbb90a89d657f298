"""The setting of a validation on the virtual bench: protocol settings, drive, table, compensator.

:class:`ValidationConfig` holds every number of the protocol; :func:`drive_for_model`
finds the drive a model was trained on; :func:`table_for` samples the model into the
runtime table over the travel; :func:`compensator_for` fills the drive train's
nominal friction and inertia into the compensator settings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import DataError, ParameterError
from drivelash.te.runtime.compensator import CompensatorParams
from drivelash.te.runtime.table import TEPredictor, TETable, build_table

__all__ = [
    "ValidationConfig",
    "compensator_for",
    "drive_for_model",
    "table_for",
    "training_torque_max",
]


@dataclass(frozen=True)
class ValidationConfig:
    """What ``te validate`` runs; every number with its reason in docs/assumptions.md.

    Parameters
    ----------
    velocities : tuple of float or None
        Travel speeds of the passes [m/s]; None = the campaign's three velocities.
    loads : tuple of float
        Process loads [N] (0 … 5000 N in 500 N steps).
    train_max_load : float
        Largest training load [N]; loads above it are "beyond the training range".
    directions : tuple of int
        Directions of the passes (paper Fig. 9: +1; the negative is "similar").
    margin : float
        Distance kept from the travel ends [m].
    stroke : float or None
        Pass length [m] (None: travel − 2 margin).
    section_length : float
        Length of the scored sections [m] (paper: 100 mm).
    sine_amplitude, sine_frequency, sine_periods : float
        Sinusoidal trajectory x_c − A cos(2π f t) [m], [Hz], [-] (no load, as in the paper).
    sine_load : float
        Load [N] of the additional loaded sine (robustness check, not in the acceptance).
    reversal_window : tuple of float
        Window around each reversal in which the reversal error is taken [s] (before, after).
    table_dx : float
        Position step of the compensation table [m].
    table_torque_max : float or None
        Largest torque magnitude of the table [N·m]; None = the largest motor torque of
        the training runs, so that beyond the trained load range the model is held at
        its edge instead of extrapolated.
    table_torque_step : float
        Torque step of the table [N·m].
    defect_center, defect_width, defect_amplitude : float
        Local rack defect of the monitoring demo: centre [m], Gaussian σ [m], peak [m].
    monitor_velocity, monitor_load : float
        Pass of the monitoring demo [m/s], [N].
    """

    velocities: tuple[float, ...] | None = None
    loads: tuple[float, ...] = tuple(float(f) for f in range(0, 5001, 500))
    train_max_load: float = 3000.0
    directions: tuple[int, ...] = (1, -1)
    margin: float = 0.05
    stroke: float | None = None
    section_length: float = 0.1
    sine_amplitude: float = 0.25
    sine_frequency: float = 0.1
    sine_periods: float = 2.0
    sine_load: float = 2000.0
    reversal_window: tuple[float, float] = (0.1, 0.3)
    table_dx: float = 0.2e-3
    table_torque_max: float | None = None
    table_torque_step: float = 0.5
    defect_center: float = 1.30
    defect_width: float = 0.003
    defect_amplitude: float = 15e-6
    monitor_velocity: float = 0.1
    monitor_load: float = 1000.0
    compensator: CompensatorParams = field(default_factory=CompensatorParams)

    @classmethod
    def quick(cls) -> ValidationConfig:
        """Few loads, one direction, a 0.6 m stroke: for tests and the demo."""
        return cls(loads=(0.0, 2000.0, 4000.0), directions=(1,), stroke=0.6, sine_amplitude=0.1,
                   sine_periods=1.0, defect_center=0.30)  # fmt: skip


def compensator_for(
    bench: Any, table: TETable | None, base: CompensatorParams | None = None
) -> CompensatorParams:
    """Compensator settings with the drive-train estimates of ``bench`` filled in.

    Friction T_C, β and the inertia J_flank = J_M (motor + gearbox + pinion) for flank
    detection; J_model = J_s (the whole axis) for the model torque. The compensator
    uses *nominal* data-sheet values of the drive, as a commissioning engineer would.
    """
    b = base or CompensatorParams()
    return CompensatorParams(
        t_sc=b.t_sc,
        t_ss=b.t_ss,
        t_ss_sign=b.t_ss_sign,
        bl_gain=b.bl_gain,
        J_flank=float(bench.J_M),
        T_C=float(bench.T_Cm),
        beta=float(bench.beta_m),
        omega_reg=1e-4 / float(bench.r_eff),
        hysteresis=b.hysteresis,
        J_model=float(bench.J_s),
        v_max=b.v_max,
        release=b.release,
        t_lock=b.t_lock,
    )


def drive_for_model(model: Any, campaign_dir: Path | None) -> Any:
    """The campaign (drive) to validate on: ``campaign_dir`` or the one recorded in the model."""
    from drivelash.te.protocol.campaign import load_campaign

    if campaign_dir is None:
        info = getattr(model, "info", {}) or {}
        cand = info.get("campaign") or info.get("campaign_dir")
        if not cand:
            raise DataError("the model does not record its campaign; pass --campaign DIR")
        campaign_dir = Path(cand)
    return load_campaign(campaign_dir)


def training_torque_max(campaign: Any, max_load: float) -> float:
    """Largest motor torque magnitude [N·m] of the campaign's load runs with load ≤ ``max_load``.

    The 99.9th percentile over the constant-velocity part of each run (robust to the
    start transient).
    """
    out = 0.0
    for r in campaign.select(kind="load"):
        if r.load > max_load + 1e-9:
            continue
        tr = r.trace()
        v = np.gradient(tr["x_T"], tr["t"])
        m = np.abs(np.abs(v) - r.velocity) < 0.05 * r.velocity
        if np.count_nonzero(m) > 10:
            out = max(out, float(np.percentile(np.abs(tr["torque_m"][m]), 99.9)))
    if out <= 0.0:
        raise DataError(f"no load run with load <= {max_load:g} N in the campaign")
    return out


def table_for(model: TEPredictor, bench: Any, cfg: ValidationConfig, meta: dict | None = None,
              torque_max: float | None = None) -> TETable:  # fmt: skip
    """The runtime table of ``model`` over the whole travel (see :func:`build_table`).

    ``torque_max`` [N·m] overrides ``cfg.table_torque_max``; one of them must be given.
    """
    tmax = cfg.table_torque_max if cfg.table_torque_max is not None else torque_max
    if tmax is None:
        raise ParameterError("ValidationConfig", "table_torque_max", "needs a value or the training range")
    n_t = int(math.ceil(tmax / cfg.table_torque_step - 1e-9)) + 1
    m = dict(meta or {})
    m["torque_max_Nm"] = tmax
    return build_table(model, 0.0, float(bench.travel), cfg.table_dx, tmax, n_t, meta=m)
