"""The setting of a validation on the virtual bench: protocol settings, drive, table, compensator.

:class:`ValidationConfig` holds every number of the protocol; :func:`model_context` is
what a model stores of its campaign (axis, valid range, compensator settings, simulator);
:class:`ModelDrive` (:func:`drive_for_model`) is the virtual drive a model describes,
rebuilt from the model alone; :func:`table_for` samples a model into the runtime table;
:func:`compensator_for` fills the drive train's nominal friction and inertia into the
compensator settings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import DataError, ParameterError
from drivelash.physics.rack_pinion import RackPinionBench
from drivelash.te.runtime.compensator import CompensatorParams
from drivelash.te.runtime.persist import CampaignInfo, ModelContext, ValidRange
from drivelash.te.runtime.table import TEPredictor, TETable, build_table, measured_range

__all__ = [
    "ModelDrive",
    "ValidationConfig",
    "compensator_for",
    "drive_for_model",
    "model_context",
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
        Sinusoidal trajectory x_c − A cos(2π f t) [m], [Hz], [-] (no load, as in the paper),
        centred in the pass range; A is cut to half that range when larger.
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
    defect_center : float or None
        Centre of the local rack defect of the monitoring demo [m]; None: the centre of
        the section at 60 % of the pass range (1.305 m on the paper's bench: the passes start
        at its valid range, 55 mm).
    defect_width, defect_amplitude : float
        Gaussian σ [m] and peak [m] of the defect.
    x_range : tuple of float or None
        Positions the passes may use [m]; None: the model's valid range (where it was
        measured, :func:`~drivelash.te.runtime.table.measured_range`), so a validation never
        runs beyond the training data. A range beyond it is run, the compensator holds its
        table's edge value there, and the summary states the share of cycles outside.
    monitor_velocity, monitor_load : float
        Pass of the monitoring demo [m/s], [N].
    compensator : CompensatorParams
        Settings of the compensator the validation runs
        (:class:`~drivelash.te.runtime.compensator.CompensatorParams`).
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
    defect_center: float | None = None
    defect_width: float = 0.003
    defect_amplitude: float = 15e-6
    monitor_velocity: float = 0.1
    monitor_load: float = 1000.0
    compensator: CompensatorParams = field(default_factory=CompensatorParams)
    x_range: tuple[float, float] | None = None

    @classmethod
    def quick(cls) -> ValidationConfig:
        """Few loads, one direction, at most a 0.6 m stroke: for tests and the demo."""
        return cls(loads=(0.0, 2000.0, 4000.0), directions=(1,), stroke=0.6, sine_amplitude=0.1,
                   sine_periods=1.0)  # fmt: skip

    def resolved(self, travel: float, x_range: tuple[float, float] | None) -> ValidationConfig:
        """A copy with ``x_range`` (given or the model's) and ``defect_center`` filled in.

        Parameters
        ----------
        travel : float
            Travel of the axis [m].
        x_range : tuple of float or None
            The model's valid position range [m] (used when ``self.x_range`` is None).
        """
        from dataclasses import replace

        xr = self.x_range or x_range or (0.0, travel)
        cfg = replace(self, x_range=(float(xr[0]), float(xr[1])))
        if cfg.defect_center is None:
            lo, hi = _pass_bounds(travel, cfg)
            k = math.floor((0.6 * (hi - lo)) / cfg.section_length)
            cfg = replace(cfg, defect_center=lo + (k + 0.5) * cfg.section_length)
        return cfg


def _pass_bounds(travel: float, cfg: ValidationConfig) -> tuple[float, float]:
    """[margin, travel − margin] ∩ ``cfg.x_range``, shortened to ``cfg.stroke`` [m]."""
    lo, hi = cfg.margin, travel - cfg.margin
    if cfg.x_range is not None:
        lo, hi = max(lo, cfg.x_range[0]), min(hi, cfg.x_range[1])
    if cfg.stroke is not None:
        hi = min(hi, lo + cfg.stroke)
    if not hi - lo >= cfg.section_length:
        raise ParameterError(
            "ValidationConfig", "x_range", f"passes over [{lo:.4g}, {hi:.4g}] m are shorter than one section"
        )
    return lo, hi


#: Effective pinion radius of the paper's bench [m]: the reference of the flank-detection
#: thresholds of :class:`CompensatorParams` (see :func:`compensator_for`).
_PAPER_R_EFF = float(RackPinionBench().r_eff)


def compensator_for(
    bench: Any, table: TETable | None, base: CompensatorParams | None = None
) -> CompensatorParams:
    """Compensator settings with the drive-train estimates of ``bench`` filled in.

    Friction T_C, β and the inertia J_flank = J_M (motor + gearbox + pinion) for flank
    detection; J_model = J_s (the whole axis) for the model torque. The compensator
    uses *nominal* data-sheet values of the drive, as a commissioning engineer would.

    The flank-detection thresholds ``hysteresis`` and ``release`` of ``base`` are motor
    torques for the paper's bench, i.e. forces at the mesh (≈ 75 N and ≈ 230 N,
    docs/assumptions.md) times its effective radius r_eff = d_p/(2 i_PG); they are
    converted to this axis' r_eff (×1 on the paper's bench). Without the conversion an
    axis with a larger r_eff sees its unloaded table's mesh torque at a reversal above
    the release threshold, the flank change comes 15 ms late, mid-gap, and the 5 ms
    backlash step makes the reversal error worse instead of better.

    Parameters
    ----------
    bench : RackPinionBench
        The axis (``r_eff`` [m], ``J_M``, ``J_s`` [kg·m²], ``T_Cm`` [N·m], ``beta_m``
        [N·m·s/rad]).
    table : TETable or None
        The runtime table (not used by the settings; kept for the callers' symmetry).
    base : CompensatorParams, optional
        Timing, gains and the paper-bench thresholds to start from (default
        :class:`CompensatorParams`).
    """
    b = base or CompensatorParams()
    k = float(bench.r_eff) / _PAPER_R_EFF
    return CompensatorParams(
        t_sc=b.t_sc,
        t_ss=b.t_ss,
        t_ss_sign=b.t_ss_sign,
        bl_gain=b.bl_gain,
        J_flank=float(bench.J_M),
        T_C=float(bench.T_Cm),
        beta=float(bench.beta_m),
        omega_reg=1e-4 / float(bench.r_eff),
        hysteresis=b.hysteresis * k,
        J_model=float(bench.J_s),
        v_max=b.v_max,
        release=b.release * k,
        t_lock=b.t_lock,
    )


def model_context(
    campaign: Any,
    max_load: float,
    holdout_loads: tuple[float, ...] = (),
    valid_x: tuple[float, float] | None = None,
    base: CompensatorParams | None = None,
) -> ModelContext:
    """What a model keeps of its campaign, so that nothing is ever read back from it.

    Parameters
    ----------
    campaign : Campaign
        The training campaign (:func:`~drivelash.te.protocol.campaign.load_campaign`).
    max_load : float
        Largest training load [N].
    holdout_loads : tuple of float
        Loads left out of training [N].
    valid_x : tuple of float, optional
        Valid position range [m]; default the plausibility report's
        (:func:`~drivelash.te.protocol.plausibility.check_campaign`): the span the geometric
        runs of both directions cover, where the load passes were recorded too.
        :func:`~drivelash.te.runtime.persist.save_model` stores it narrowed to where the
        fitted no-load curves hold data (:func:`~drivelash.te.runtime.persist.measured_context`).
    base : CompensatorParams, optional
        Compensator settings whose drive-train fields are filled from the axis.
    """
    m = campaign.manifest
    if valid_x is None:
        from drivelash.te.protocol.plausibility import check_campaign

        report = check_campaign(campaign, max_load)
        report.raise_errors()
        valid_x = report.valid_range
    lo, hi = valid_x
    train = sorted(
        f for f in m.loads if f <= max_load + 1e-9 and all(abs(f - h) > 1e-6 for h in holdout_loads)
    )
    return ModelContext(
        axis=m.axis,
        valid_range=ValidRange(
            x_min=lo, x_max=hi, torque_max=training_torque_max(campaign, max_load), loads=train
        ),
        compensator=compensator_for(campaign.bench, None, base),
        campaign=CampaignInfo(
            source=m.source,
            directory=str(campaign.directory),
            velocities=list(m.velocities),
            loads=list(m.loads),
            max_load=max_load,
            holdout_loads=list(holdout_loads),
        ),
        simulator=m.simulator,
    )


class ModelDrive:
    """The virtual drive a model was trained on, rebuilt from the model alone.

    A model fitted on a virtual-bench campaign stores the campaign's ``simulator``
    block (seed, TE generator, engine settings, plan) and the axis; from them this
    rebuilds the simulator, and — only when a protocol needs the training data (the
    update half of the monitoring demo) — regenerates the campaign itself, which is
    byte-identical to the original (same seed ⇒ identical campaign).

    Parameters
    ----------
    model : TEModel
        A loaded model with its context.
    campaign : Campaign, optional
        The training campaign when it is at hand (saves regenerating it).
    """

    def __init__(self, model: Any, campaign: Any = None) -> None:
        ctx = getattr(model, "context", None)
        if ctx is None:
            raise DataError("the model has no context (axis, valid range): refit it with drivelash te fit")
        if ctx.simulator is None:
            raise DataError(
                "te validate is the virtual-bench protocol, and this model was fitted on an imported"
                " campaign: score your own passes with drivelash te score"
            )
        from drivelash.sim.rack_campaign import SimulatorBlock

        self.context = ctx
        self.block = SimulatorBlock.model_validate(ctx.simulator)
        self.bench = ctx.axis.bench
        self.gains = ctx.axis.gains
        if campaign is not None and (
            campaign.manifest.simulator != ctx.simulator or campaign.manifest.axis != ctx.axis
        ):
            raise DataError(
                "not the campaign this model was trained on (different drive); leave --campaign out",
                path=str(campaign.manifest_path),
            )
        self._campaign = campaign
        self._tmp: Any = None

    @property
    def seed(self) -> int:
        """Seed of the simulated drive."""
        return int(self.block.seed)

    @property
    def velocities(self) -> tuple[float, ...]:
        """Velocities of the training campaign's load runs [m/s]."""
        return tuple(self.context.campaign.velocities)

    @property
    def torque_max(self) -> float:
        """Largest training motor torque [N·m]."""
        return float(self.context.valid_range.torque_max)

    def simulator(self) -> Any:
        """A simulator of the drive, gains and engine settings."""
        from drivelash.sim.rack_axis import RackAxisSimulator

        return RackAxisSimulator(
            self.bench, self.block.te_model(self.bench), gains=self.gains, seed=self.seed,
            config=self.block.sim_config,
        )  # fmt: skip

    def campaign(self) -> Any:
        """The training campaign: the one given, else regenerated from the simulator block."""
        if self._campaign is None:
            import tempfile

            from drivelash.sim.rack_campaign import run_campaign
            from drivelash.te.protocol.campaign import load_campaign

            self._tmp = tempfile.TemporaryDirectory(prefix="drivelash-campaign-")
            run_campaign(
                self._tmp.name, seed=self.seed, config=self.block.campaign, bench=self.bench,
                te_params=self.block.te_generator, gains=self.gains, sim_config=self.block.sim_config,
                runs=self.block.runs,
            )  # fmt: skip
            self._campaign = load_campaign(self._tmp.name)
        return self._campaign


def drive_for_model(model: Any, campaign_dir: Path | None = None) -> ModelDrive:
    """The virtual drive of ``model`` (its training campaign at ``campaign_dir`` if given).

    Parameters
    ----------
    model : TEModel
        A loaded model; its ``context`` names the simulated axis.
    campaign_dir : Path, optional
        Its training campaign (:func:`~drivelash.te.protocol.campaign.load_campaign`).
    """
    camp = None
    if campaign_dir is not None:
        from drivelash.te.protocol.campaign import load_campaign

        camp = load_campaign(campaign_dir)
    return ModelDrive(model, camp)


def training_torque_max(campaign: Any, max_load: float) -> float:
    """Largest motor torque magnitude [N·m] of the campaign's load runs with load ≤ ``max_load``.

    The 99.9th percentile over the constant-velocity part of each run (robust to the
    start transient).

    Parameters
    ----------
    campaign : Campaign
        The training campaign.
    max_load : float
        Largest training load [N].

    Raises
    ------
    DataError
        No load run with load ≤ ``max_load`` (and a constant-velocity part).
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


def table_for(
    model: TEPredictor,
    bench: Any,
    cfg: ValidationConfig,
    meta: dict | None = None,
    torque_max: float | None = None,
    x_range: tuple[float, float] | None = None,
) -> TETable:
    """The runtime table of ``model`` (see :func:`build_table`).

    Parameters
    ----------
    model : TEPredictor
        The fitted model.
    bench : RackPinionBench
        The axis (its ``travel`` [m] when the model has no measured range).
    cfg : ValidationConfig
        ``table_dx`` [m], ``table_torque_step`` [N·m] and ``table_torque_max`` [N·m].
    meta : dict, optional
        Provenance stored in the table.
    torque_max : float, optional
        Largest torque magnitude of the table [N·m] when ``cfg.table_torque_max`` is None
        (the callers pass the training runs' torque); a set ``cfg.table_torque_max`` wins.
        One of the two must be given.
    x_range : tuple of float, optional
        The positions of the table [m]; default where the model was measured
        (:func:`~drivelash.te.runtime.table.measured_range`: its valid range ∩ the span of its
        no-load curves), else the whole travel.

    Raises
    ------
    ParameterError
        Neither ``cfg.table_torque_max`` nor ``torque_max`` is given; or as
        :func:`build_table`.
    """
    tmax = cfg.table_torque_max if cfg.table_torque_max is not None else torque_max
    if tmax is None:
        raise ParameterError("ValidationConfig", "table_torque_max", "needs a value or the training range")
    n_t = int(math.ceil(tmax / cfg.table_torque_step - 1e-9)) + 1
    m = dict(meta or {})
    m["torque_max_Nm"] = tmax
    if x_range is None:
        lo, hi = measured_range(model)
        x_range = (lo, hi) if math.isfinite(lo) and math.isfinite(hi) else (0.0, float(bench.travel))
    return build_table(model, x_range[0], x_range[1], cfg.table_dx, tmax, n_t, meta=m)
