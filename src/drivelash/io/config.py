"""TOML configuration: pydantic v2 models mirroring :mod:`drivelash.params`.

A configuration file has these tables, all optional at parse time (a command
that needs one calls :meth:`DriveConfig.require`)::

    [drivetrain]      # DrivetrainParams: J_m, J_l, N, K_S, D_S, T_Cm, … (SI units)
    [backlash]        # BacklashParams: delta1, alpha, optional delta
    [estimator]       # k1, k2, gamma, delta_max, eps_delta, delta0 (all optional)
    [columns.<src>]   # source column <src> → Trace column, unit and scale
    [sampling]        # time unit, constant sample rate, jitter tolerance, resampling
    [identification]  # filter cut-off, decimation, … for ``drivelash identify``

Errors are :class:`~drivelash.errors.ConfigError` with one line naming the file,
the table and the key; an unknown key comes with the closest valid key.
"""

from __future__ import annotations

import difflib
import math
import tomllib
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from drivelash.errors import ConfigError, DrivelashError
from drivelash.params import BacklashParams, DrivetrainParams

#: Units accepted in ``[columns.*] unit`` and the quantity each one measures.
UNIT_KIND: dict[str, str] = {
    "s": "time",
    "ms": "time",
    "us": "time",
    "rad": "angle",
    "deg": "angle",
    "rev": "angle",
    "counts": "angle",
    "arcsec": "angle",
    "mrad": "angle",
    "urad": "angle",
    "rad/s": "angular_velocity",
    "deg/s": "angular_velocity",
    "rpm": "angular_velocity",
    "rev/s": "angular_velocity",
    "m": "length",
    "mm": "length",
    "um": "length",
    "µm": "length",
    "m/s": "velocity",
    "mm/s": "velocity",
    "N·m": "torque",
    "N*m": "torque",
    "Nm": "torque",
    "N": "force",
    "A": "current",
    "V": "voltage",
    "1": "dimensionless",
}


class _Strict(BaseModel):
    """Base: unknown keys are errors, values validated on assignment, frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=False)


class DrivetrainSection(_Strict):
    """``[drivetrain]``: the fields of :class:`~drivelash.params.DrivetrainParams` [SI].

    J_m, J_l, N, K_S and D_S have no defaults in ``DrivetrainParams``; here they may
    be left out at parse time (a rigid axis identified by ``drivelash identify``
    has only J_m, beta_m, T_Cm), and :meth:`DriveConfig.to_drivetrain_params`
    names the first missing one.
    """

    J_m: float | None = None
    J_l: float | None = None
    N: float | None = None
    K_S: float | None = None
    D_S: float | None = None
    T_Cm: float = 0.0
    T_Cl: float = 0.0
    beta_m: float = 0.0
    beta_l: float = 0.0
    T_Sm: float = 0.0
    T_Sl: float = 0.0
    omega_s: float = 0.01


class BacklashSection(_Strict):
    """``[backlash]``: δ1 [rad], α [1/rad] and optionally the true δ [rad]."""

    delta1: float
    alpha: float = 1000.0
    delta: float | None = None


class EstimatorSection(_Strict):
    """``[estimator]``: gains of the deadzone estimator and its STSMO (all optional).

    ``k1`` [(rad/s²)/(rad/s)^½], ``k2`` [rad/s³] super-twisting gains; ``gamma``
    adaptation gain; ``delta_max`` [rad] projection radius; ``eps_delta`` [rad]
    projection margin; ``delta0`` [rad] initial estimate. The estimator fills in
    defaults for what is left out.
    """

    k1: float | None = None
    k2: float | None = None
    gamma: float | None = None
    delta_max: float | None = None
    eps_delta: float | None = None
    delta0: float | None = None


class ColumnMap(_Strict):
    """One ``[columns.<source>]`` entry: where a source column goes and its unit.

    Attributes
    ----------
    column : str
        Trace column it becomes (``t``, ``theta_m``, ``omega_m``, ``theta_l``,
        ``omega_l``, ``torque_m`` or any further name).
    unit : str
        Unit in the file (see :data:`UNIT_KIND`); converted to SI on load.
    counts_per_rev : float, optional
        Encoder counts per revolution, required with ``unit = "counts"``.
    torque_constant : float, optional
        Motor torque constant [N·m/A] (or [N/A] on a prismatic axis), required
        with ``unit = "A"``.
    gain : float or str, optional
        Scale of a ``V`` signal into torque/force [N·m/V or N/V], required with
        ``unit = "V"``; a string names a scalar stored in the same file (e.g.
        ``"gtau"`` in the EMPS ``.mat`` files).
    scale, offset : float
        Extra affine correction applied after the unit conversion:
        ``value = scale·converted + offset``.
    wrap : float, optional
        Modulus of a wrapping position counter, in file units (e.g. 65536 counts);
        defaults to one revolution for angle units.
    """

    column: str
    unit: str = "1"
    counts_per_rev: float | None = None
    torque_constant: float | None = None
    gain: float | str | None = None
    scale: float = 1.0
    offset: float = 0.0
    wrap: float | None = None

    @field_validator("unit")
    @classmethod
    def _known_unit(cls, v: str) -> str:
        if v not in UNIT_KIND:
            close = difflib.get_close_matches(v, list(UNIT_KIND), n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            raise ValueError(f"unknown unit '{v}'{hint}; known: {', '.join(UNIT_KIND)}")
        return v

    @field_validator("counts_per_rev", "torque_constant")
    @classmethod
    def _positive(cls, v: float | None) -> float | None:
        if v is not None and not (math.isfinite(v) and v > 0):
            raise ValueError(f"must be a finite number > 0, got {v!r}")
        return v


class SamplingSection(_Strict):
    """``[sampling]``: how time is given and how strictly it is checked.

    Attributes
    ----------
    time_unit : {"s", "ms", "us"}
        Unit of the time column when no ``[columns]`` entry maps ``t``.
    sample_rate : float, optional
        Constant sample rate [Hz] when the file has no time column.
    tolerance : float
        Allowed relative deviation of any sample interval from the median [-].
    resample : bool
        Resample non-uniform data onto a uniform grid (linear interpolation)
        instead of refusing it. Never done unless asked for.
    """

    time_unit: Literal["s", "ms", "us"] = "s"
    sample_rate: float | None = Field(default=None, gt=0)
    tolerance: float = Field(default=0.01, gt=0)
    resample: bool = False


class IdentificationSection(_Strict):
    """``[identification]``: options of :func:`drivelash.estimation.identify.identify_rigid`.

    Attributes
    ----------
    cutoff_hz : float
        Cut-off of the zero-phase Butterworth low-pass on position [Hz].
    filter_order : int
        Order of that Butterworth filter (doubled by forward-backward filtering).
    decimate : int
        Decimation factor of the observation matrix and force (≥ 1).
    n_border : int
        Samples dropped at each end against filter/difference edge effects.
    side : {"motor", "load"}
        ``"load"`` identifies J_l, β_l, T_Cl from the load encoder and the
        estimated shaft torque.
    model : {"rigid", "two-mass"}
        Model of ``drivelash identify`` when ``--model`` is not given: the rigid
        IDIM-LS above, or the two-mass model with backlash
        (:mod:`drivelash.estimation.identify_two_mass`).
    window : float, optional
        Window of the two-mass integral equations [s] (default 1 ms, at least 2 samples).
    equations : {"both", "motor"}
        Two-mass model: fit both equations, or the motor equation only (a robot link whose
        inertia depends on the pose and which carries gravity).
    encoder_delay : bool
        Two-mass model: also fit a time offset between the motor and the load encoder [s].
    torque_offset : float, optional
        Two-mass model: known offset of the recorded motor torque [N·m], fixed instead of
        fitted (give 0 for an absolute torque on an axis loaded by gravity).
    """

    cutoff_hz: float = Field(default=100.0, gt=0)
    filter_order: int = Field(default=4, ge=1, le=10)
    decimate: int = Field(default=10, ge=1, le=100)
    n_border: int = Field(default=50, ge=0)
    side: Literal["motor", "load"] = "motor"
    model: Literal["rigid", "two-mass"] = "rigid"
    window: float | None = Field(default=None, gt=0)
    equations: Literal["both", "motor"] = "both"
    encoder_delay: bool = False
    torque_offset: float | None = None


class DriveConfig(_Strict):
    """A whole configuration file. Every table is optional at parse time.

    Use :func:`load_config` to read one; ``source`` is the file it came from.
    """

    drivetrain: DrivetrainSection | None = None
    backlash: BacklashSection | None = None
    estimator: EstimatorSection | None = None
    columns: dict[str, ColumnMap] | None = None
    sampling: SamplingSection | None = None
    identification: IdentificationSection | None = None
    source: str | None = Field(default=None, exclude=True)

    def require(self, section: str) -> Any:
        """Return table ``section``, or raise a one-line :class:`ConfigError` if absent."""
        if section not in type(self).model_fields or section == "source":
            raise ConfigError(f"{self.source or '<config>'}: no such table [{section}]")
        value = getattr(self, section)
        if value is None:
            raise ConfigError(f"{self.source or '<config>'}: table [{section}] is required for this command")
        return value

    def to_drivetrain_params(self) -> DrivetrainParams:
        """The ``[drivetrain]`` table as :class:`~drivelash.params.DrivetrainParams`."""
        sec: DrivetrainSection = self.require("drivetrain")
        for key in ("J_m", "J_l", "N", "K_S", "D_S"):
            if getattr(sec, key) is None:
                raise ConfigError(f"{self.source or '<config>'}: table [drivetrain], key '{key}': missing")
        try:
            return DrivetrainParams(**sec.model_dump())
        except DrivelashError as exc:
            raise ConfigError(f"{self.source or '<config>'}: [drivetrain] {exc}") from None

    def to_backlash_params(self, delta: float | None = None) -> BacklashParams:
        """The ``[backlash]`` table as :class:`~drivelash.params.BacklashParams`.

        Parameters
        ----------
        delta : float, optional
            Deadzone δ [rad]; overrides the table's ``delta`` (an estimator
            passes its estimate). One of the two must be given.
        """
        sec: BacklashSection = self.require("backlash")
        d = delta if delta is not None else sec.delta
        if d is None:
            raise ConfigError(
                f"{self.source or '<config>'}: table [backlash], key 'delta': missing (and none given)"
            )
        try:
            return BacklashParams(delta=d, delta1=sec.delta1, alpha=sec.alpha)
        except DrivelashError as exc:
            raise ConfigError(f"{self.source or '<config>'}: [backlash] {exc}") from None

    def sampling_or_default(self) -> SamplingSection:
        """``[sampling]`` or its defaults."""
        return self.sampling or SamplingSection()

    def identification_or_default(self) -> IdentificationSection:
        """``[identification]`` or its defaults."""
        return self.identification or IdentificationSection()


_SECTION_MODELS: dict[str, type[BaseModel]] = {
    "drivetrain": DrivetrainSection,
    "backlash": BacklashSection,
    "estimator": EstimatorSection,
    "sampling": SamplingSection,
    "identification": IdentificationSection,
    "columns.*": ColumnMap,
}


def _valid_keys(loc: tuple[Any, ...]) -> list[str]:
    """Valid keys at the table addressed by ``loc`` (without the offending key)."""
    if len(loc) <= 1:
        return [k for k in DriveConfig.model_fields if k != "source"]
    top = str(loc[0])
    if top == "columns":
        return list(ColumnMap.model_fields) if len(loc) >= 3 else []
    model = _SECTION_MODELS.get(top)
    return list(model.model_fields) if model else []


def _format_error(path: str, err: dict[str, Any]) -> str:
    loc = tuple(err.get("loc", ()))
    # pydantic adds union-member tags like 'float' / 'str' to the location; drop them.
    loc = tuple(p for p in loc if p not in ("float", "str", "int", "bool", "function-after[_known_unit()]"))
    key = str(loc[-1]) if loc else "?"
    table = ".".join(str(p) for p in loc[:-1])
    where = f"table [{table}], key '{key}'" if table else f"top-level key '{key}'"
    kind = err.get("type", "")
    if kind == "extra_forbidden":
        valid = _valid_keys(loc)
        close = difflib.get_close_matches(key, valid, n=1, cutoff=0.5)
        hint = f"; did you mean '{close[0]}'?" if close else (f"; valid: {', '.join(valid)}" if valid else "")
        if not table:
            where = f"unknown table [{key}]"
            return f"{path}: {where}{hint}"
        return f"{path}: {where}: unknown key{hint}"
    if kind == "missing":
        return f"{path}: {where}: missing"
    msg = str(err.get("msg", "invalid value")).replace("\n", " ")
    if msg.startswith("Value error, "):
        msg = msg[len("Value error, ") :]
    got = err.get("input")
    if not isinstance(got, dict | list) and kind not in ("value_error",):
        msg = f"{msg} (got {got!r})"
    return f"{path}: {where}: {msg}"


def parse_config(data: dict[str, Any], source: str = "<config>") -> DriveConfig:
    """Validate an already-parsed TOML document.

    Parameters
    ----------
    data : dict
        The TOML document as returned by :func:`tomllib.loads`.
    source : str
        Name used in error messages (usually the file path).

    Raises
    ------
    ConfigError
        One line naming ``source``, the table and the key.
    """
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: a configuration must be a TOML table")
    try:
        cfg = DriveConfig.model_validate(data)
    except ValidationError as exc:
        errors = exc.errors()
        # an unknown key first: a misspelt key also shows up as the missing one
        errors.sort(key=lambda e: e.get("type") != "extra_forbidden")
        raise ConfigError(_format_error(source, errors[0])) from None
    except (TypeError, ValueError, RecursionError) as exc:  # pragma: no cover - defensive
        raise ConfigError(f"{source}: invalid configuration ({type(exc).__name__})") from None
    return cfg.model_copy(update={"source": source})


def load_config(path: str | Path) -> DriveConfig:
    """Read and validate a TOML configuration file.

    Parameters
    ----------
    path : str or Path
        The ``.toml`` file.

    Returns
    -------
    DriveConfig

    Raises
    ------
    ConfigError
        File missing/unreadable, TOML syntax error, unknown key (with the closest
        valid key), missing key or wrong type — always one line.
    """
    p = Path(path)
    try:
        raw = p.read_bytes()
    except FileNotFoundError:
        raise ConfigError(f"{p}: no such configuration file") from None
    except OSError as exc:
        raise ConfigError(f"{p}: cannot read ({exc.strerror or exc})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise ConfigError(f"{p}: not a UTF-8 text file (is this a TOML configuration?)") from None
    return loads_config(text, source=str(p))


def loads_config(text: str, source: str = "<config>") -> DriveConfig:
    """Parse configuration TOML text (see :func:`load_config`)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc).splitlines()[0] if str(exc) else "syntax error"
        raise ConfigError(f"{source}: TOML syntax error: {msg}") from None
    except (ValueError, TypeError, RecursionError) as exc:
        raise ConfigError(f"{source}: TOML syntax error ({type(exc).__name__})") from None
    return parse_config(data, source)


def drivetrain_fragment(values: dict[str, float], comments: list[str] | None = None) -> str:
    """A ``[drivetrain]`` TOML fragment (``tomli_w``), with leading ``#`` comments.

    Parameters
    ----------
    values : dict
        Keys of :class:`DrivetrainSection` → values [SI].
    comments : list of str, optional
        Lines written as TOML comments above the table.
    """
    import tomli_w

    unknown = [k for k in values if k not in DrivetrainSection.model_fields]
    if unknown:
        raise ConfigError(f"<fragment>: table [drivetrain], key '{unknown[0]}': unknown key")
    head = "".join(f"# {c}\n" for c in (comments or []))
    return head + tomli_w.dumps({"drivetrain": {k: float(v) for k, v in values.items()}})
