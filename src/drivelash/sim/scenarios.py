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
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np

from drivelash.control.cascade import gains_from_bandwidth
from drivelash.control.references import Reference, position_sine, velocity_sine
from drivelash.errors import ConfigError, DrivelashError, ParameterError
from drivelash.io.trace import Trace
from drivelash.params import BacklashParams, CascadeGains, DrivetrainParams, SensorParams
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

    @property
    def T_s(self) -> float:
        """Control and sample period [s]."""
        return self.gains.T_s

    def delta_true(self, t: np.ndarray) -> np.ndarray:
        """True δ(t) [rad] on ``t``."""
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
# TOML configuration
# --------------------------------------------------------------------------------------
_TOP_KEYS = {"base", "name", "description", "duration", "seed", "model", "omega_reg", "n_sub", "feedback"}
_TABLES = {
    "plant": DrivetrainParams,
    "estimator": DrivetrainParams,
    "backlash": BacklashParams,
    "gains": CascadeGains,
    "sensors": SensorParams,
    "reference": ReferenceSpec,
    "deadzone": DeadzoneProfile,
}


def scenario_from_toml(path: str | Path) -> Scenario:
    """A scenario from a TOML file: a registered ``base`` scenario plus overrides.

    Keys: ``base`` (default ``"bench-0A"``), ``name``, ``description``, ``duration`` [s],
    ``seed``, ``model``, ``omega_reg`` [rad/s], ``n_sub``, ``feedback``; tables
    ``[plant]`` and ``[estimator]`` (DrivetrainParams fields), ``[backlash]``,
    ``[gains]``, ``[sensors]``, ``[reference]`` (kind, amplitude, frequency) and
    ``[deadzone]`` (kind, delta_end, t0, t1). Example::

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

    Raises
    ------
    ConfigError
        Unreadable file, unknown key, wrong type; one line naming the key.
    ParameterError
        A value out of range (from the parameter classes).
    """
    path = Path(path)
    try:
        with path.open("rb") as fh:
            cfg = tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such file") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: invalid TOML: {exc}") from None
    for key, value in cfg.items():
        if key in _TABLES:
            if not isinstance(value, dict):
                raise ConfigError(f"{path}: [{key}] must be a table")
            allowed = {f.name for f in dataclasses.fields(_TABLES[key])}
            for sub in value:
                if sub not in allowed:
                    raise ConfigError(
                        f"{path}: unknown key '{key}.{sub}'; allowed: {', '.join(sorted(allowed))}"
                    )
        elif key not in _TOP_KEYS:
            allowed = sorted(_TOP_KEYS | set(_TABLES))
            raise ConfigError(f"{path}: unknown key '{key}'; allowed: {', '.join(allowed)}")
    base = get_scenario(str(cfg.get("base", "bench-0A")))
    try:
        plant = replace(base.plant_drivetrain, **cfg.get("plant", {}))
        est = replace(base.estimator_drivetrain, **cfg.get("estimator", {}))
        backlash = replace(base.plant_backlash, **cfg.get("backlash", {}))
        est_bl = replace(base.estimator_backlash, delta=backlash.delta, delta1=backlash.delta1)
        gains = replace(base.gains, **cfg.get("gains", {}))
        sensors = replace(base.sensors, **cfg.get("sensors", {}))
        reference = replace(base.reference, **cfg.get("reference", {}))
        profile = replace(base.deadzone_profile, **cfg.get("deadzone", {}))
        top = {k: cfg[k] for k in _TOP_KEYS - {"base"} if k in cfg}
        for k, typ in (
            ("duration", (int, float)),
            ("seed", int),
            ("n_sub", int),
            ("omega_reg", (int, float)),
        ):
            if k in top and (isinstance(top[k], bool) or not isinstance(top[k], typ)):
                raise ConfigError(f"{path}: '{k}' has the wrong type ({type(top[k]).__name__})")
        for k in ("name", "description", "model", "feedback"):
            if k in top and not isinstance(top[k], str):
                raise ConfigError(f"{path}: '{k}' must be a string")
        if top.get("model", base.model) not in ("deadzone", "smooth"):
            raise ConfigError(f"{path}: 'model' must be 'deadzone' or 'smooth'")
        if top.get("feedback", base.feedback) not in ("measured", "true"):
            raise ConfigError(f"{path}: 'feedback' must be 'measured' or 'true'")
        if "duration" in top and not top["duration"] > 0:
            raise ConfigError(f"{path}: 'duration' must be > 0")
        if "n_sub" in top and not top["n_sub"] >= 1:
            raise ConfigError(f"{path}: 'n_sub' must be >= 1")
        if "omega_reg" in top and not top["omega_reg"] > 0:
            raise ConfigError(f"{path}: 'omega_reg' must be > 0")
        return replace(
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
            **{k: (float(v) if k in ("duration", "omega_reg") else v) for k, v in top.items()},
        )
    except TypeError as exc:  # wrong value type inside a parameter class
        raise ConfigError(f"{path}: {exc}") from None


def load_scenario(name_or_path: str) -> Scenario:
    """A registered scenario by name, or one from a ``.toml`` file."""
    if name_or_path.lower().endswith(".toml"):
        return scenario_from_toml(name_or_path)
    return get_scenario(name_or_path)
