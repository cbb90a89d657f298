"""Physical parameters and gains as frozen, validated dataclasses.

Symbols follow Papageorgiou et al. (2019), spec 01 §1, and the rack-and-pinion
paper, spec 02 §2. Every field carries its unit in the docstring. Objects are
immutable: an estimator never changes a plant's parameters — adapted values live
in estimator state. Use :func:`dataclasses.replace` to derive a variant.

Validation happens at construction and raises :class:`~drivelash.errors.ParameterError`
naming the class and the field.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Literal

import numpy as np

from drivelash.errors import ParameterError


def require_finite(obj: object) -> None:
    """Raise :class:`ParameterError` naming the first non-finite numeric field of ``obj``."""
    for f in fields(obj):  # type: ignore[arg-type]
        v = getattr(obj, f.name)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            continue
        if not math.isfinite(v):
            raise ParameterError(type(obj).__name__, f.name, f"must be finite, got {v!r}")


def require_positive(obj: object, *names: str) -> None:
    """Raise :class:`ParameterError` naming the first of ``names`` that is not > 0."""
    for n in names:
        v = getattr(obj, n)
        if not v > 0:
            raise ParameterError(type(obj).__name__, n, f"must be > 0, got {v!r}")


def require_non_negative(obj: object, *names: str) -> None:
    """Raise :class:`ParameterError` naming the first of ``names`` that is not >= 0."""
    for n in names:
        v = getattr(obj, n)
        if not v >= 0:
            raise ParameterError(type(obj).__name__, n, f"must be >= 0, got {v!r}")


@dataclass(frozen=True)
class DrivetrainParams:
    """Two-mass drive train, eqs (1)–(7) of spec 01.

    Parameters
    ----------
    J_m : float
        Motor-side inertia [kg·m²].
    J_l : float
        Load-side inertia [kg·m²].
    N : float
        Gear ratio θ_m / θ_l [-] (1 for a direct coupling).
    K_S : float
        Shaft stiffness [N·m/rad].
    D_S : float
        Shaft damping [N·m·s/rad].
    T_Cm, T_Cl : float
        Coulomb friction torque, motor / load side [N·m].
    beta_m, beta_l : float
        Viscous friction coefficient, motor / load side [N·m·s/rad].
    T_Sm, T_Sl : float
        Static (breakaway) friction torque, motor / load side [N·m]; 0 means none.
        When non-zero it must be ≥ the Coulomb torque of that side.
    omega_s : float
        Stribeck velocity of the static-friction decay [rad/s].
    """

    J_m: float
    J_l: float
    N: float
    K_S: float
    D_S: float
    T_Cm: float = 0.0
    T_Cl: float = 0.0
    beta_m: float = 0.0
    beta_l: float = 0.0
    T_Sm: float = 0.0
    T_Sl: float = 0.0
    omega_s: float = 0.01

    def __post_init__(self) -> None:
        require_finite(self)
        require_positive(self, "J_m", "J_l", "N", "K_S", "omega_s")
        require_non_negative(self, "D_S", "T_Cm", "T_Cl", "beta_m", "beta_l", "T_Sm", "T_Sl")
        for s, c in (("T_Sm", "T_Cm"), ("T_Sl", "T_Cl")):
            if getattr(self, s) and getattr(self, s) < getattr(self, c):
                raise ParameterError(type(self).__name__, s, f"static friction must be 0 or >= {c}")

    def as_array(self) -> np.ndarray:
        """Parameters as a float64 array in field order (for numba kernels)."""
        return np.array([getattr(self, f.name) for f in fields(self)], dtype=np.float64)

    def to_dict(self) -> dict[str, float]:
        """Plain dict of the fields (e.g. for TOML/JSON output)."""
        return asdict(self)


@dataclass(frozen=True)
class BacklashParams:
    """Deadzone of the coupling, eq (10)–(12) of spec 01.

    Parameters
    ----------
    delta : float
        Total deadzone (gap) angle δ [rad], load-side coordinates.
    delta1 : float
        Initial offset δ1 [rad], 0 ≤ δ1 ≤ δ: the shafts are disengaged for
        −δ1 ≤ Δθ ≤ δ − δ1.
    alpha : float
        Smoothness of the varying-stiffness model (11) [1/rad]; the smooth model
        tends to the deadzone model as α → ∞.
    """

    delta: float
    delta1: float
    alpha: float = 1000.0

    def __post_init__(self) -> None:
        require_finite(self)
        require_non_negative(self, "delta")
        require_positive(self, "alpha")
        if not 0.0 <= self.delta1 <= self.delta:
            raise ParameterError(
                type(self).__name__,
                "delta1",
                f"must lie in [0, delta] = [0, {self.delta}], got {self.delta1!r}",
            )


@dataclass(frozen=True)
class CascadeGains:
    """Discrete P position / PI velocity cascade on the motor (spec 01 §1, spec 02 §2).

    Parameters
    ----------
    K_v : float
        Position-loop proportional gain [1/s] (velocity command per position error).
    K_p : float
        Velocity-loop proportional gain [N·m·s/rad].
    T_n : float
        Velocity-loop integral (reset) time [s].
    torque_limit : float
        Symmetric limit of the commanded motor torque [N·m].
    k_ff : float
        Velocity feed-forward gain [-], 0 (off) … 1 (full).
    T_s : float
        Control period [s] (zero-order hold of the torque command).
    """

    K_v: float
    K_p: float
    T_n: float
    torque_limit: float
    k_ff: float = 1.0
    T_s: float = 125e-6

    def __post_init__(self) -> None:
        require_finite(self)
        require_positive(self, "K_v", "K_p", "T_n", "torque_limit", "T_s")
        if not 0.0 <= self.k_ff <= 1.0:
            raise ParameterError(type(self).__name__, "k_ff", f"must lie in [0, 1], got {self.k_ff!r}")


@dataclass(frozen=True)
class SensorParams:
    """Sensor model: encoder quantisation and Gaussian noise.

    Parameters
    ----------
    counts_m, counts_l : int
        Encoder counts per revolution on the motor / load side; 0 means ideal
        (no quantisation).
    sigma_theta_m, sigma_theta_l : float
        Standard deviation of white position noise [rad].
    sigma_omega_m, sigma_omega_l : float
        Standard deviation of white velocity noise [rad/s].
    sigma_torque : float
        Standard deviation of white noise on the measured motor torque [N·m].
    velocity_source : {"measured", "differentiated"}
        ``"measured"``: velocity = true velocity + noise (as a drive reports it);
        ``"differentiated"``: backward difference of the quantised position.
    """

    counts_m: int = 0
    counts_l: int = 0
    sigma_theta_m: float = 0.0
    sigma_theta_l: float = 0.0
    sigma_omega_m: float = 0.0
    sigma_omega_l: float = 0.0
    sigma_torque: float = 0.0
    velocity_source: Literal["measured", "differentiated"] = "measured"

    def __post_init__(self) -> None:
        require_finite(self)
        require_non_negative(
            self,
            "counts_m",
            "counts_l",
            "sigma_theta_m",
            "sigma_theta_l",
            "sigma_omega_m",
            "sigma_omega_l",
            "sigma_torque",
        )
        for n in ("counts_m", "counts_l"):
            if int(getattr(self, n)) != getattr(self, n):
                raise ParameterError(type(self).__name__, n, "must be a whole number of counts")
        if self.velocity_source not in ("measured", "differentiated"):
            raise ParameterError(
                type(self).__name__,
                "velocity_source",
                f"must be 'measured' or 'differentiated', got {self.velocity_source!r}",
            )
