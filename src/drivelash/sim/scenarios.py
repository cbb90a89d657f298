"""Named, documented, seeded simulation scenarios (spec 01 §4).

* ``paper-sim`` — the paper's simulation study (§V): deadzone plant, velocity
  reference ω_r = 4π sin 4πt, velocity noise σ = 0.0316 rad/s, δ* = 0.2 rad stepping
  +5 % at t = 3 s, δ1 = δ*/2 = 0.1 rad (fixed: the step moves the upper contact).
* ``bench-<k><X>`` — replica of the test bench (§VI), k = 0…5, X = A, B, C:
  rig parameters, deadzone A = 1.027, B = 0.186, C = 0.105 rad, θ_r = sin(πt),
  60 s, 11-bit encoders on both sides, measured velocities with σ = 0.0316 rad/s.
  The plant is always nominal; test k changes the *estimator-side* parameters:
  0 none, 1 K_S, 2 D_S, 3 T_Cl, 4 beta_l (+100 % each), 5 all four.

Every number chosen here that the paper does not give is listed, with its reason,
in ``docs/assumptions.md``, section "Simulator and bench replica (spec 01)".

Usage::

    sc = get_scenario("bench-0A")
    trace = sc.simulate()            # Trace: t, theta_m, omega_m, theta_l, omega_l,
                                     # torque_m, delta_true, delta1_true, theta_ref, omega_ref
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Strict, create_model

from drivelash.control.cascade import gains_from_bandwidth
from drivelash.control.references import Reference, position_sine, velocity_sine
from drivelash.errors import ConfigError, DrivelashError, ParameterError
from drivelash.io.config import ConfigFile, EstimatorSection, dataclass_fields, load_file, section
from drivelash.io.trace import Trace
from drivelash.params import BacklashParams, CascadeGains, DrivetrainParams, EstimatorConfig, SensorParams
from drivelash.physics.drivetrain import DEFAULT_OMEGA_REG
from drivelash.sim.engine import DEFAULT_SUBSTEPS, delta_constant, delta_ramp, delta_step, simulate


class UnknownScenarioError(DrivelashError, KeyError):
    """A scenario name that is not registered."""

    def __str__(self) -> str:  # KeyError would add quotes
        return str(self.args[0])


# --------------------------------------------------------------------------------------
# rig data (spec 01 §4) and chosen numbers (docs/assumptions.md)
# --------------------------------------------------------------------------------------
#: Rig parameters of spec 01 §4; static friction 0.044 N·m on both sides with a
#: Stribeck velocity of 0.05 rad/s (chosen, not given).
RIG_DRIVETRAIN = DrivetrainParams(
    J_m=8.31e-4,
    J_l=8.31e-4,
    N=1.0,
    K_S=32.94,
    D_S=0.0548,
    T_Cm=0.0223,
    T_Cl=0.0232,
    beta_m=0.0016,
    beta_l=0.0016,
    T_Sm=0.044,
    T_Sl=0.044,
    omega_s=0.05,
)
#: Rig without static friction: the plant of the simulation study, whose friction is (6)–(7).
SIM_DRIVETRAIN = replace(RIG_DRIVETRAIN, T_Sm=0.0, T_Sl=0.0)
#: Deadzones of tests A, B, C [rad].
BENCH_DEADZONES = {"A": 1.027, "B": 0.186, "C": 0.105}
#: Velocity-loop crossover with the load engaged [rad/s] (100 rad/s engaged, 200 rad/s in
#: the gap; below the shaft antiresonance sqrt(K_S/J_l) = 199 rad/s … resonance 282 rad/s
#: with the load engaged), PI zero 4× lower, position loop 25 1/s.
OMEGA_CV = 100.0
RIG_GAINS: CascadeGains = gains_from_bandwidth(RIG_DRIVETRAIN, OMEGA_CV, torque_limit=13.0, T_s=125e-6)
#: Smoothness α of the estimator-side model (11) [1/rad]: transition width 1/α = 1 mrad,
#: below the 3.07 mrad encoder step.
ESTIMATOR_ALPHA = 1000.0
#: Sensor noise of the paper's simulation (velocity, both sides) [rad/s].
SIGMA_OMEGA = 0.0316
#: Absolute encoders of the rig, counts per revolution (11 bit).
ENCODER_COUNTS = 2048
#: Estimator-side errors of tests 1…5: fields doubled (+100 %).
BENCH_TESTS: dict[int, tuple[str, ...]] = {
    0: (),
    1: ("K_S",),
    2: ("D_S",),
    3: ("T_Cl",),
    4: ("beta_l",),
    5: ("K_S", "D_S", "T_Cl", "beta_l"),
}


@dataclass(frozen=True)
class ReferenceSpec:
    """Recipe of a reference trajectory.

    Parameters
    ----------
    kind : {"position_sine", "velocity_sine"}
        θ_r = A sin(2π f t) or ω_r = A sin(2π f t) (θ_r its integral).
    amplitude : float
        A [rad] or [rad/s].
    frequency : float
        f [Hz].
    """

    kind: Literal["position_sine", "velocity_sine"]
    amplitude: float
    frequency: float

    def __post_init__(self) -> None:
        if self.kind not in ("position_sine", "velocity_sine"):
            raise ParameterError(
                "ReferenceSpec", "kind", f"must be position_sine or velocity_sine, got {self.kind!r}"
            )
        if not (math.isfinite(self.amplitude) and math.isfinite(self.frequency) and self.frequency > 0):
            raise ParameterError(
                "ReferenceSpec", "frequency", f"must be finite and > 0, got {self.frequency!r}"
            )

    def build(self, duration: float, T_s: float) -> Reference:
        """Sample the reference on k·T_s over ``duration`` [s]."""
        if self.kind == "position_sine":
            return position_sine(duration, T_s, self.amplitude, self.frequency)
        return velocity_sine(duration, T_s, self.amplitude, self.frequency)


@dataclass(frozen=True)
class DeadzoneProfile:
    """Time profile of the true deadzone δ(t) (δ1 stays constant).

    Parameters
    ----------
    kind : {"constant", "step", "ramp"}
        δ constant; stepping to ``delta_end`` at ``t0``; ramping to ``delta_end`` over [t0, t1].
    delta_end : float
        Final δ [rad] (step/ramp).
    t0, t1 : float
        Step time / ramp start and end [s].
    """

    kind: Literal["constant", "step", "ramp"] = "constant"
    delta_end: float = 0.0
    t0: float = 0.0
    t1: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in ("constant", "step", "ramp"):
            raise ParameterError(
                "DeadzoneProfile", "kind", f"must be constant, step or ramp, got {self.kind!r}"
            )
        if self.kind != "constant" and not self.delta_end >= 0:
            raise ParameterError("DeadzoneProfile", "delta_end", f"must be >= 0, got {self.delta_end!r}")
        if self.kind == "ramp" and not self.t1 > self.t0:
            raise ParameterError("DeadzoneProfile", "t1", f"must be > t0 = {self.t0}, got {self.t1!r}")

    def sample(self, t: np.ndarray, delta0: float) -> np.ndarray:
        """δ(t) [rad] starting from ``delta0``."""
        if self.kind == "constant":
            return delta_constant(t, delta0)
        if self.kind == "step":
            return delta_step(t, delta0, self.t0, self.delta_end)
        return delta_ramp(t, delta0, self.t0, self.t1, self.delta_end)


@dataclass(frozen=True)
class Scenario:
    """A named, seeded simulation recipe.

    Attributes
    ----------
    name, description : str
        Identifier and one-line description.
    plant_drivetrain, plant_backlash : DrivetrainParams, BacklashParams
        The true plant (``plant_backlash.delta`` is δ at t = 0).
    estimator_drivetrain, estimator_backlash : DrivetrainParams, BacklashParams
        What an estimator is told: possibly wrong drive-train parameters (tests 1…5;
        static friction set to 0 since the estimator's friction model is (6)–(7)),
        the known offset δ1 and the smoothness α of model (11). ``estimator_backlash.delta``
        is the true initial δ, for scoring only — an estimator must not start from it.
    gains : CascadeGains
        Cascade controller (also fixes T_s).
    sensors : SensorParams
        Sensor model of the recorded (and fed-back) signals.
    reference : ReferenceSpec
        Motion.
    deadzone_profile : DeadzoneProfile
        δ(t).
    duration : float
        Default length [s].
    seed : int
        Default noise seed.
    model : {"deadzone", "smooth"}
        Plant shaft model.
    omega_reg : float
        Friction regularisation velocity [rad/s].
    n_sub : int
        RK4 substeps per control period.
    feedback : {"measured", "true"}
        Signals the controller uses.
    estimator : tuple of (str, value)
        :class:`~drivelash.params.EstimatorConfig` fields that override the tuning rule
        when this scenario is estimated (``[estimator]`` of a scenario file).

    Raises
    ------
    ParameterError
        A field outside its valid range (one line naming the class and the field).
    """

    name: str
    description: str
    plant_drivetrain: DrivetrainParams
    plant_backlash: BacklashParams
    estimator_drivetrain: DrivetrainParams
    estimator_backlash: BacklashParams
    gains: CascadeGains
    sensors: SensorParams
    reference: ReferenceSpec
    deadzone_profile: DeadzoneProfile = DeadzoneProfile()
    duration: float = 60.0
    seed: int = 0
    model: Literal["deadzone", "smooth"] = "deadzone"
    omega_reg: float = DEFAULT_OMEGA_REG
    n_sub: int = DEFAULT_SUBSTEPS
    feedback: Literal["measured", "true"] = "measured"
    estimator: tuple[tuple[str, Any], ...] = ()

    def __post_init__(self) -> None:
        name = type(self).__name__
        if not (
            isinstance(self.duration, int | float) and math.isfinite(self.duration) and self.duration > 0
        ):
            raise ParameterError(name, "duration", f"must be finite and > 0, got {self.duration!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ParameterError(name, "seed", f"must be an integer >= 0, got {self.seed!r}")
        if isinstance(self.n_sub, bool) or not isinstance(self.n_sub, int) or self.n_sub < 1:
            raise ParameterError(name, "n_sub", f"must be an integer >= 1, got {self.n_sub!r}")
        if not (math.isfinite(self.omega_reg) and self.omega_reg > 0):
            raise ParameterError(name, "omega_reg", f"must be finite and > 0, got {self.omega_reg!r}")
        if self.model not in ("deadzone", "smooth"):
            raise ParameterError(name, "model", f"must be 'deadzone' or 'smooth', got {self.model!r}")
        if self.feedback not in ("measured", "true"):
            raise ParameterError(name, "feedback", f"must be 'measured' or 'true', got {self.feedback!r}")

    @property
    def estimator_overrides(self) -> dict[str, Any]:
        """Estimator gains set for this scenario (``[estimator]`` of a scenario file)."""
        return dict(self.estimator)

    @property
    def T_s(self) -> float:
        """Control and sample period [s]."""
        return self.gains.T_s

    def delta_true(self, t: np.ndarray) -> np.ndarray:
        """True δ(t) [rad] on ``t``.

        Parameters
        ----------
        t : numpy.ndarray
            Sample instants [s].
        """
        return self.deadzone_profile.sample(t, self.plant_backlash.delta)

    def simulate(
        self,
        duration: float | None = None,
        seed: int | None = None,
        progress: Callable[[int, int], None] | None = None,
        return_states: bool = False,
    ) -> Trace:
        """Run the scenario.

        Parameters
        ----------
        duration : float, optional
            Length [s]; default :attr:`duration`.
        seed : int, optional
            Noise seed; default :attr:`seed`.
        progress : callable, optional
            ``progress(done, total)`` in samples, called every 10 s of simulated time.
        return_states : bool
            Also return the noiseless plant states and applied torque
            (``omega_m_true``, ``theta_m_true``, ``omega_l_true``, ``theta_l_true``, ``u``).

        Returns
        -------
        Trace
            Columns t, theta_m, omega_m, theta_l, omega_l, torque_m (measured),
            delta_true, delta1_true, theta_ref, omega_ref; ``meta`` has the scenario.

        Raises
        ------
        ParameterError
            ``duration`` not a finite number > 0 [s].
        """
        duration = self.duration if duration is None else float(duration)
        seed = self.seed if seed is None else int(seed)
        if not (math.isfinite(duration) and duration > 0):
            raise ParameterError("simulate", "duration", f"must be > 0, got {duration!r}")
        ref = self.reference.build(duration, self.T_s)
        res = simulate(
            self.plant_drivetrain,
            self.plant_backlash,
            self.gains,
            ref,
            sensors=self.sensors,
            delta=self.delta_true(ref.t),
            model=self.model,
            seed=seed,
            omega_reg=self.omega_reg,
            n_sub=self.n_sub,
            feedback=self.feedback,
            chunk=max(1, int(round(10.0 / self.T_s))),
            progress=progress,
        )
        res.meta = self.to_meta() | {"seed": seed, "duration": duration}
        return res.to_trace(return_states=return_states)

    def to_meta(self) -> dict[str, Any]:
        """JSON-serialisable description (goes into ``Trace.meta``)."""
        d: dict[str, Any] = {"scenario": self.name, "description": self.description}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if dataclasses.is_dataclass(v):
                d[f.name] = dataclasses.asdict(v)
            elif f.name == "estimator":
                d[f.name] = dict(v)
            elif f.name not in ("name", "description"):
                d[f.name] = v
        return d


def _estimator_side(d: DrivetrainParams, names: tuple[str, ...]) -> DrivetrainParams:
    """Estimator parameters: ``names`` doubled; no static friction (the estimator's model is (6)–(7))."""
    return replace(d, T_Sm=0.0, T_Sl=0.0, **{n: 2.0 * getattr(d, n) for n in names})


def _bench(k: int, x: str) -> Scenario:
    delta = BENCH_DEADZONES[x]
    delta1 = delta / 2.0
    plant_bl = BacklashParams(delta=delta, delta1=delta1, alpha=ESTIMATOR_ALPHA)
    wrong = BENCH_TESTS[k]
    what = "identified parameters" if not wrong else "estimator +100 % on " + ", ".join(wrong)
    return Scenario(
        name=f"bench-{k}{x}",
        description=f"test bench replica, deadzone {x} = {delta} rad, theta_r = sin(pi t), {what}",
        plant_drivetrain=RIG_DRIVETRAIN,
        plant_backlash=plant_bl,
        estimator_drivetrain=_estimator_side(RIG_DRIVETRAIN, wrong),
        estimator_backlash=plant_bl,
        gains=RIG_GAINS,
        sensors=SensorParams(
            counts_m=ENCODER_COUNTS,
            counts_l=ENCODER_COUNTS,
            sigma_omega_m=SIGMA_OMEGA,
            sigma_omega_l=SIGMA_OMEGA,
        ),
        reference=ReferenceSpec("position_sine", amplitude=1.0, frequency=0.5),
        duration=60.0,
        seed=1000 + 10 * k + "ABC".index(x),
    )


def _paper_sim() -> Scenario:
    delta = 0.2
    bl = BacklashParams(delta=delta, delta1=delta / 2.0, alpha=ESTIMATOR_ALPHA)
    return Scenario(
        name="paper-sim",
        description="paper's simulation study: omega_r = 4 pi sin(4 pi t), delta* = 0.2 rad +5 % at 3 s",
        plant_drivetrain=SIM_DRIVETRAIN,
        plant_backlash=bl,
        estimator_drivetrain=SIM_DRIVETRAIN,
        estimator_backlash=bl,
        gains=gains_from_bandwidth(SIM_DRIVETRAIN, OMEGA_CV, torque_limit=13.0, T_s=125e-6),
        sensors=SensorParams(sigma_omega_m=SIGMA_OMEGA, sigma_omega_l=SIGMA_OMEGA),
        reference=ReferenceSpec("velocity_sine", amplitude=4.0 * math.pi, frequency=2.0),
        deadzone_profile=DeadzoneProfile("step", delta_end=1.05 * delta, t0=3.0),
        duration=6.0,
        seed=42,
    )


def _registry() -> dict[str, Scenario]:
    reg = {"paper-sim": _paper_sim()}
    for k in BENCH_TESTS:
        for x in BENCH_DEADZONES:
            sc = _bench(k, x)
            reg[sc.name] = sc
    return reg


_REGISTRY: dict[str, Scenario] = _registry()


def list_scenarios() -> list[Scenario]:
    """All registered scenarios, ``paper-sim`` first, then ``bench-0A`` … ``bench-5C``."""
    return list(_REGISTRY.values())


def get_scenario(name: str) -> Scenario:
    """The scenario called ``name``.

    Parameters
    ----------
    name : str
        A registered name (``paper-sim``, ``bench-0A`` … ``bench-5C``; :func:`list_scenarios`).

    Raises
    ------
    UnknownScenarioError
        (a :class:`~drivelash.errors.DrivelashError`) listing the valid names.
    """
    try:
        return _REGISTRY[name]
    except KeyError:
        names = ", ".join(_REGISTRY)
        raise UnknownScenarioError(f"unknown scenario {name!r}; valid: {names}") from None


# --------------------------------------------------------------------------------------
# TOML configuration: one schema (drivelash.io.config), tables generated from the dataclasses
# --------------------------------------------------------------------------------------
#: Top-level keys of a scenario file: these fields of :class:`Scenario`.
SCENARIO_KEYS = ("name", "description", "duration", "seed", "model", "omega_reg", "n_sub", "feedback")
#: ``[plant]`` (the true drive train) and ``[drivetrain]`` (as the estimator is told it).
DrivetrainOverrides = section(DrivetrainParams, overrides=True)
BacklashOverrides = section(BacklashParams, overrides=True)
GainsOverrides = section(CascadeGains, overrides=True)
SensorsOverrides = section(SensorParams, overrides=True)
ReferenceOverrides = section(ReferenceSpec, overrides=True)
DeadzoneOverrides = section(DeadzoneProfile, overrides=True)


class _ScenarioTables(ConfigFile):
    """Tables of a scenario file; each changes the ``base`` scenario's object."""

    base: Annotated[str, Strict()] = "bench-0A"
    plant: DrivetrainOverrides | None = None  # type: ignore[valid-type]
    drivetrain: DrivetrainOverrides | None = None  # type: ignore[valid-type]
    backlash: BacklashOverrides | None = None  # type: ignore[valid-type]
    gains: GainsOverrides | None = None  # type: ignore[valid-type]
    sensors: SensorsOverrides | None = None  # type: ignore[valid-type]
    reference: ReferenceOverrides | None = None  # type: ignore[valid-type]
    deadzone: DeadzoneOverrides | None = None  # type: ignore[valid-type]
    estimator: EstimatorSection | None = None  # type: ignore[valid-type]


#: A scenario file (:func:`scenario_from_toml`): ``base`` + the top-level keys of
#: :data:`SCENARIO_KEYS` (generated from :class:`Scenario`) + the tables above.
ScenarioFile = create_model(  # type: ignore[call-overload]
    "ScenarioFile",
    __base__=_ScenarioTables,
    __module__=__name__,
    **dataclass_fields(Scenario, only=SCENARIO_KEYS, overrides=True),
)


def scenario_from_toml(path: str | Path) -> Scenario:
    """A scenario from a TOML file: a registered ``base`` scenario plus overrides.

    Top-level keys: ``base`` (default ``"bench-0A"``), ``name``, ``description``,
    ``duration`` [s], ``seed``, ``model``, ``omega_reg`` [rad/s], ``n_sub``, ``feedback``.
    Tables (the same as in every drivelash file, see :mod:`drivelash.io.config`):
    ``[plant]`` (the true :class:`~drivelash.params.DrivetrainParams`), ``[drivetrain]``
    (the drive train as the estimator is told it), ``[backlash]``, ``[gains]``,
    ``[sensors]``, ``[reference]`` (kind, amplitude, frequency), ``[deadzone]``
    (kind, delta_end, t0, t1) and ``[estimator]`` (estimator gains for this scenario,
    :class:`~drivelash.params.EstimatorConfig`). Example::

        base = "bench-0B"
        duration = 20.0
        [backlash]
        delta = 0.25
        delta1 = 0.125
        [deadzone]
        kind = "ramp"
        delta_end = 0.3
        t0 = 5.0
        t1 = 15.0

    Parameters
    ----------
    path : str or Path
        The scenario file.

    Raises
    ------
    ConfigError
        Unreadable file, unknown key (with the closest valid one), wrong type, a value a
        parameter class refuses: one line naming the file, table and key.
    """
    path = Path(path)
    cfg = load_file(path, ScenarioFile)
    src = cfg.source
    try:
        base = get_scenario(cfg.base)
    except UnknownScenarioError as exc:
        raise ConfigError(f"{src}: top-level key 'base': {exc}") from None
    plant = cfg.params("plant", base=base.plant_drivetrain)
    est = cfg.params("drivetrain", base=base.estimator_drivetrain)
    backlash = cfg.params("backlash", base=base.plant_backlash)
    est_bl = replace(base.estimator_backlash, delta=backlash.delta, delta1=backlash.delta1)
    gains = cfg.params("gains", base=base.gains)
    sensors = cfg.params("sensors", base=base.sensors)
    reference = cfg.params("reference", base=base.reference)
    profile = cfg.params("deadzone", base=base.deadzone_profile)
    estimator = dict(base.estimator) | (cfg.estimator.given() if cfg.estimator is not None else {})
    top = {k: v for k, v in cfg.model_dump(exclude_unset=True).items() if k in SCENARIO_KEYS}
    try:
        sc = replace(
            base,
            name=top.pop("name", path.stem),
            description=top.pop("description", f"{base.name} with overrides from {path.name}"),
            plant_drivetrain=plant,
            plant_backlash=backlash,
            estimator_drivetrain=est,
            estimator_backlash=est_bl,
            gains=gains,
            sensors=sensors,
            reference=reference,
            deadzone_profile=profile,
            estimator=tuple(sorted(estimator.items())),
            **top,
        )
    except ParameterError as exc:
        raise ConfigError(f"{src}: top-level key '{exc.field}': {exc.problem}") from None
    if estimator:  # the estimator this scenario gets (estimation.reproduce.estimator_for) must build
        kw = {k: v for k, v in estimator.items() if k != "method"}
        try:
            EstimatorConfig.tuned(est, sc.T_s, f_exc=sc.reference.frequency, **kw)
        except ParameterError as exc:
            raise ConfigError(f"{src}: table [estimator], key '{exc.field}': {exc.problem}") from None
    return sc


def load_scenario(name_or_path: str) -> Scenario:
    """A registered scenario by name, or one from a ``.toml`` file.

    Parameters
    ----------
    name_or_path : str
        A name for :func:`get_scenario`, or a path ending in ``.toml`` for
        :func:`scenario_from_toml`.
    """
    if name_or_path.lower().endswith(".toml"):
        return scenario_from_toml(name_or_path)
    return get_scenario(name_or_path)
