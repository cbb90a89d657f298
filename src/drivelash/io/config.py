"""One configuration schema: TOML tables generated from the parameter dataclasses.

Every table that holds parameters is a pydantic model **generated** from the frozen
dataclass the code runs on (:func:`section`): the same keys, types and defaults, the unit
from the dataclass's numpydoc (``Field.description`` and ``json_schema_extra["unit"]``),
and the value checks of the dataclass's own ``__post_init__`` — one source of truth. A
table means the same in every file:

=================  =====================================================================
``[drivetrain]``   :class:`~drivelash.params.DrivetrainParams` — the drive train as the
                   estimator/model is told it [SI]
``[backlash]``     :class:`~drivelash.params.BacklashParams` — ``delta``, ``delta1`` [rad],
                   ``alpha`` [1/rad]
``[estimator]``    :class:`~drivelash.params.EstimatorConfig` — every gain of the deadzone
                   estimator; a key left out comes from the tuning rule
``[columns.<src>]`` source column → Trace column, unit and scale (:class:`ColumnMap`)
``[sampling]``     time unit, sample rate, jitter tolerance (:class:`SamplingSection`)
``[identification]`` options of ``drivelash identify`` (:class:`IdentificationSection`)
=================  =====================================================================

Files are pydantic models too, subclasses of :class:`ConfigFile` listing their tables:
:class:`DriveConfig` (``estimate``, ``identify``, ``observe``) and the scenario file
(:class:`drivelash.sim.scenarios.ScenarioFile`: ``base`` plus ``[plant]``, ``[drivetrain]``,
``[backlash]``, ``[gains]``, ``[sensors]``, ``[reference]``, ``[deadzone]``,
``[estimator]``). Errors are :class:`~drivelash.errors.ConfigError`, one line naming the
file, the table and the key; an unknown key comes with the closest valid key, or with the
table it belongs to.

Adding a table (for another owner's file)
-----------------------------------------
Generate the table from your frozen dataclass and list it in your file model; nothing
in this module changes::

    from drivelash.io.config import ConfigFile, EstimatorSection, load_file, section
    from drivelash.physics.rack_pinion import RackPinionBench

    GeometrySection = section(RackPinionBench, overrides=True)   # [geometry]

    class AxisFile(ConfigFile):
        '''An axis file: [geometry] and the estimator gains.'''
        geometry: GeometrySection | None = None
        estimator: EstimatorSection | None = None     # the same [estimator] as everywhere

    cfg = load_file("axis.toml", AxisFile)             # unknown keys, types: one-line errors
    bench = cfg.params("geometry", base=RackPinionBench())
    # -> RackPinionBench with the file's keys replaced, checked by its __post_init__;
    #    a bad value is "axis.toml: table [geometry], key 'm_T': must be > 0, got -1".

``section(cls)`` keeps the dataclass's required keys required; ``optional=True`` lets the
keys without a default be left out (the command completes them, e.g. a ``[drivetrain]``
fragment with only J_m, beta_m); ``overrides=True`` makes every key optional — a table
of changes to a ``base`` object. A complete table (no ``overrides``) is checked by the
dataclass when the file is loaded; the others when :meth:`ConfigFile.params` builds the
object. Non-parameter tables (like ``[columns]``) are ordinary pydantic models deriving
from :class:`Table`.
"""

from __future__ import annotations

import dataclasses
import difflib
import functools
import inspect
import math
import re
import tomllib
import types
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal, TypeVar, Union

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    Strict,
    ValidationError,
    create_model,
    field_validator,
    model_validator,
)

from drivelash.errors import ConfigError, ParameterError
from drivelash.params import (
    DELTA_MAX_DEFAULT,
    BacklashParams,
    DrivetrainParams,
    EstimatorConfig,
    check_delta1_bound,
)

#: Units accepted in ``[columns.*] unit`` and the quantity each one measures.
UNIT_KIND: dict[str, str] = {
    "s": "time",
    "ms": "time",
    "us": "time",
    "ns": "time",
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
    "in": "length",  # inch, 25.4 mm (US laser software and CNC traces)
    "m/s": "velocity",
    "mm/s": "velocity",
    "N·m": "torque",
    "N*m": "torque",
    "Nm": "torque",
    "N": "force",
    "A": "current",
    "mA": "current",  # a CNC's current trace in milliamps (×1e-3, then torque_constant)
    "V": "voltage",
    "1": "dimensionless",
}


def is_prismatic(kinds: Mapping[str, str | None]) -> bool:
    """Whether mapped columns make a trace prismatic: ``theta_m`` in a length unit or ``omega_m``
    in a velocity unit (``kinds``: Trace column → unit kind, :data:`UNIT_KIND`). The one rule for a
    recording (:func:`drivelash.io.load.load_trace`, the streaming reader) and for a drive file's
    ``[columns]`` read without a recording (:func:`columns_axis`)."""
    return kinds.get("theta_m") == "length" or kinds.get("omega_m") == "velocity"


def columns_axis(columns: Mapping[str, ColumnMap] | None) -> str:
    """The axis kind a ``[columns]`` mapping gives its recordings: "prismatic" or "rotary"."""
    kinds = {c.column: UNIT_KIND.get(c.unit) for c in (columns or {}).values()}
    return "prismatic" if is_prismatic(kinds) else "rotary"


class Table(BaseModel):
    """Base of every table: unknown keys are errors, values frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=False)


# ----------------------------------------------------------------------------- numpydoc
_UNIT = re.compile(r"\[([^\[\]]+)\](?:\s+or\s+\[([^\[\]]+)\])?")
_SECTIONS = ("Parameters", "Attributes")


def param_docs(cls: type) -> dict[str, tuple[str, str | None]]:
    """Description and unit of each field, from the ``Parameters``/``Attributes`` numpydoc.

    Parameters
    ----------
    cls : type
        A documented class; entries may name several fields (``T_Cm, T_Cl : float``).

    Returns
    -------
    dict
        field name → (description, unit); the unit is the first ``[...]`` of the
        description (``"-"`` for dimensionless), None when there is none.
    """
    lines = (inspect.getdoc(cls) or "").splitlines()
    out: dict[str, tuple[str, str | None]] = {}
    names: list[str] = []
    desc: list[str] = []
    inside = False

    def flush() -> None:
        text = " ".join(d.strip() for d in desc).strip()
        m = _UNIT.search(text)
        for n in names:
            unit = (m.group(1) + (f" or {m.group(2)}" if m.group(2) else "")) if m else None
            out[n] = (text, unit)

    for i, line in enumerate(lines):
        nxt = lines[i + 1].strip() if i + 1 < len(lines) else ""
        is_header = bool(line.strip()) and not line.startswith(" ") and nxt and set(nxt) == {"-"}
        if is_header:
            flush()
            names, desc = [], []
            inside = line.strip() in _SECTIONS
            continue
        if not inside or (line.strip() and set(line.strip()) == {"-"}):
            continue
        if line and not line.startswith(" "):
            flush()
            desc = []
            head = line.split(" : ")[0]
            names = [n.strip() for n in head.split(",") if n.strip().isidentifier()]
        elif line.strip():
            desc.append(line)
    flush()
    return out


# ----------------------------------------------------------------------------- generated tables
class Section(Table):
    """A table generated from a parameter dataclass by :func:`section`."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=False)
    #: The dataclass the table was generated from.
    __params__: ClassVar[type]
    #: Every key optional: the table changes a base object (:meth:`ConfigFile.params`).
    __overrides__: ClassVar[bool] = False
    #: The ``optional`` argument the table was generated with.
    __optional__: ClassVar[bool | tuple[str, ...]] = ()

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickle by the recipe (dataclass, options), not by the generated class's name: a
        process that unpickles a table regenerates its class (process pools, Dask)."""
        return (
            _rebuild_section,
            (self.__params__, self.__optional__, self.__overrides__, self.__getstate__()),
        )

    def given(self) -> dict[str, Any]:
        """The keys written in the file, with their values."""
        return self.model_dump(exclude_unset=True)

    def missing(self) -> list[str]:
        """Fields the dataclass requires that are neither in the file nor defaulted."""
        return [
            f.name
            for f in dataclasses.fields(self.__params__)
            if f.init
            and f.default is dataclasses.MISSING
            and f.default_factory is dataclasses.MISSING
            and getattr(self, f.name) is None
        ]

    def to_params(self, where: str, base: Any = None, **values: Any) -> Any:
        """Build (and so validate) the dataclass.

        Parameters
        ----------
        where : str
            ``"<file>: table [<name>]"``, the start of every error message.
        base : dataclass instance, optional
            Object whose fields the table's keys replace (``dataclasses.replace``);
            without it, the table's values (and the dataclass defaults) are used.
        **values
            Values that take precedence over the file (None entries are ignored).

        Raises
        ------
        ConfigError
            A required key missing, or a value the dataclass refuses: one line with
            file, table and key.
        """
        cls = self.__params__
        if base is not None:
            kw = {f.name: getattr(base, f.name) for f in dataclasses.fields(base) if f.init}
            kw.update(self.given())
        else:
            kw = {k: v for k, v in self.model_dump().items() if v is not None}
        kw.update({k: v for k, v in values.items() if v is not None})
        for f in dataclasses.fields(cls):
            required = f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
            if f.init and required and kw.get(f.name) is None:
                raise ConfigError(f"{where}, key '{f.name}': missing")
        try:
            return cls(**kw)
        except ParameterError as exc:
            raise ConfigError(f"{where}, key '{exc.field}': {exc.problem}") from None
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"{where}: {exc}") from None


_SCALARS = (float, int, bool, str)


def _strict(ann: Any) -> Any:
    """``ann`` with strict scalars: a float takes int or float, never a bool or a string;
    int, bool and str take only themselves (TOML has native types)."""
    if ann in _SCALARS:
        return Annotated[ann, Strict()]
    origin = typing.get_origin(ann)
    args = typing.get_args(ann)
    if origin is Literal or not args:
        return ann
    if origin in (Union, types.UnionType):
        return Union[tuple(_strict(a) for a in args)]  # noqa: UP007 - built from a tuple
    if origin is Annotated:
        return ann
    try:
        return origin[tuple(_strict(a) for a in args)]
    except TypeError:
        return ann


def dataclass_fields(
    cls: type, *, optional: bool | tuple[str, ...] = (), overrides: bool = False, only: tuple[str, ...] = ()
) -> dict[str, Any]:
    """pydantic field definitions of a dataclass's init fields (see :func:`section`).

    ``only`` restricts to those fields (e.g. the scalar top-level keys of a file).
    """
    hints = typing.get_type_hints(cls)
    docs = param_docs(cls)
    out: dict[str, Any] = {}
    for f in dataclasses.fields(cls):
        if not f.init or (only and f.name not in only):
            continue
        ann = _strict(hints[f.name])
        has_default = f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING
        text, unit = docs.get(f.name, ("", None))
        extra = {"unit": unit} if unit else None
        if (
            overrides
            or f.name in (optional if isinstance(optional, tuple) else ())
            or (optional is True and not has_default)
        ):
            out[f.name] = (ann | None, Field(default=None, description=text, json_schema_extra=extra))
        elif f.default is not dataclasses.MISSING:
            out[f.name] = (ann, Field(default=f.default, description=text, json_schema_extra=extra))
        elif f.default_factory is not dataclasses.MISSING:
            factory = f.default_factory
            out[f.name] = (ann, Field(default_factory=factory, description=text, json_schema_extra=extra))
        else:
            out[f.name] = (ann, Field(description=text, json_schema_extra=extra))
    return out


def section(cls: type, *, optional: bool | tuple[str, ...] = (), overrides: bool = False) -> type[Section]:
    """The TOML table of a frozen parameter dataclass, as a pydantic model.

    Parameters
    ----------
    cls : type
        The dataclass (numpydoc ``Parameters``/``Attributes`` give descriptions and units).
    optional : bool or tuple of str
        ``True``: keys without a default may be left out (None until the command
        completes them); a tuple: these keys may be left out.
    overrides : bool
        Every key optional (None): the table changes a base object.

    Returns
    -------
    type
        A :class:`Section` subclass; ``model_fields[k].description`` holds the
        documentation and ``json_schema_extra["unit"]`` the unit of key ``k``.
    """
    opt = (optional or ()) if isinstance(optional, bool) else tuple(optional)  # False == ()
    return _section(cls, opt, bool(overrides))


@functools.cache
def _section(cls: type, optional: bool | tuple[str, ...], overrides: bool) -> type[Section]:
    """:func:`section` with normalised, positional arguments: one class per table recipe."""
    kind = "Overrides" if overrides else "Section"
    model = create_model(  # type: ignore[call-overload]
        f"{cls.__name__}{kind}",
        __base__=Section,
        __doc__=f"[table] generated from :class:`{cls.__module__}.{cls.__qualname__}`.",
        **dataclass_fields(cls, optional=optional, overrides=overrides),
    )
    model.__params__ = cls
    model.__overrides__ = overrides
    model.__optional__ = optional
    return model


def _rebuild_section(cls: type, optional: bool | tuple[str, ...], overrides: bool, state: Any) -> Section:
    """Unpickle a generated table (see :meth:`Section.__reduce__`)."""
    model = section(cls, optional=optional, overrides=overrides)
    obj = model.__new__(model)
    obj.__setstate__(state)
    return obj


def unit_of(model: type[BaseModel], key: str) -> str | None:
    """Unit of ``key`` in a generated table (from the dataclass numpydoc), or None."""
    extra = model.model_fields[key].json_schema_extra
    return extra.get("unit") if isinstance(extra, dict) else None  # type: ignore[return-value]


# ----------------------------------------------------------------------------- the drive tables
#: ``[drivetrain]``: J_m, J_l, N, K_S, D_S may be left out at parse time (a rigid axis
#: identified by ``drivelash identify`` has only J_m, beta_m, T_Cm).
DrivetrainSection = section(DrivetrainParams, optional=True)
#: ``[backlash]``: ``delta`` (the true δ) may be left out — an estimator estimates it.
BacklashSection = section(BacklashParams, optional=("delta",))
#: ``[estimator]``: every :class:`~drivelash.params.EstimatorConfig` field; a key left
#: out comes from the tuning rule (:meth:`~drivelash.params.EstimatorConfig.tuned`).
EstimatorSection = section(EstimatorConfig, overrides=True)


#: The units of a current column (:data:`UNIT_KIND` "current"): ``torque_constant`` turns them into
#: a torque/force (``unit = "mA"``: ×1e-3 to A first).
CURRENT_UNITS = tuple(u for u, kind in UNIT_KIND.items() if kind == "current")

#: ``[columns]`` conversion keys and the units that apply each (key, units, what it converts).
_FACTOR_UNITS: tuple[tuple[str, tuple[str, ...], str], ...] = (
    ("gain", ("V",), "a voltage times gain is the torque/force"),
    ("torque_constant", CURRENT_UNITS, "a current times torque_constant is the torque/force"),
    ("counts_per_rev", ("counts",), "encoder counts per revolution"),
)


class ColumnMap(Table):
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
        with a current unit, ``unit = "A"`` or ``unit = "mA"`` (milliamps: ×1e-3 first;
        the constant stays per ampere).
    gain : float or str, optional
        Scale of a ``V`` signal into torque/force [N·m/V or N/V], required with
        ``unit = "V"``; a string names a scalar stored in the same file (e.g.
        ``"gtau"`` in the EMPS ``.mat`` files). ``gain``, ``torque_constant`` and
        ``counts_per_rev`` are refused with any other unit than theirs (they would
        change nothing).
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
            close = did_you_mean(v, UNIT_KIND)
            hint = f" (did you mean '{close}'?)" if close else ""
            raise ValueError(f"unknown unit '{v}'{hint}; known: {', '.join(UNIT_KIND)}")
        return v

    @field_validator("counts_per_rev", "torque_constant")
    @classmethod
    def _positive(cls, v: float | None) -> float | None:
        if v is not None and not (math.isfinite(v) and v > 0):
            raise ValueError(f"must be a finite number > 0, got {v!r}")
        return v

    @model_validator(mode="after")
    def _factor_used(self) -> ColumnMap:
        # a conversion factor only the unit that needs it applies: given with another unit it
        # would change nothing (session 31 tester C, C6: EMPS force declared "N" with
        # gain = "gtau" gave M = 2.7 kg instead of 95.1, no word)
        for key, units, what in _FACTOR_UNITS:
            if getattr(self, key) is not None and self.unit not in units:
                named = " or ".join(repr(u) for u in units)
                raise ValueError(
                    f"{key} applies only with unit = {named} ({what}), got unit = {self.unit!r}:"
                    f" declare unit = {named} for the raw column, or drop {key} (use scale for a"
                    " plain factor)"
                )
        return self


class SamplingSection(Table):
    """``[sampling]``: how time is given and how strictly it is checked.

    Attributes
    ----------
    time_unit : {"s", "ms", "us", "ns"}
        Unit of the time column when no ``[columns]`` entry maps ``t``.
    sample_rate : float, optional
        Constant sample rate [Hz] when the file has no time column.
    tolerance : float
        Allowed relative deviation of any sample interval from the median [-].
    resample : bool
        Resample non-uniform data onto a uniform grid (linear interpolation)
        instead of refusing it. Never done unless asked for.
    """

    time_unit: Literal["s", "ms", "us", "ns"] = "s"
    sample_rate: float | None = Field(default=None, gt=0)
    tolerance: float = Field(default=0.01, gt=0)
    resample: bool = False


def is_window(v: Any) -> bool:
    """Whether ``v`` is a two-mass integral window: a finite length > 0 [s] or ``"auto"``."""
    if v == "auto":
        return True
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0


class IdentificationSection(Table):
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
        Window of the two-mass integral equations [s] (default 1 ms, at least 2 samples), or
        ``"auto"``: a sixth of the period of the shaft resonance a 1 ms fit shows, within
        1–4 ms — for gaps much smaller than the shaft's deflection (README; the report's fit
        table names the window chosen and why).
    equations : {"both", "motor"}
        Two-mass model: fit both equations, or the motor equation only (a robot link whose
        inertia depends on the pose and which carries gravity).
    encoder_delay : bool
        Two-mass model: also fit a time offset between the motor and the load encoder [s].
    torque_offset : float, optional
        Two-mass model: known offset of the recorded motor torque [N·m], fixed instead of
        fitted (give 0 for an absolute torque on an axis loaded by gravity).
    max_samples : int
        Two-mass model: samples fitted at most (default 480 000 = 60 s at 8 kHz). A longer
        recording is fitted on its contiguous stretch of that length with the most motor
        reversals (``drivelash identify`` says which).
    """

    cutoff_hz: float = Field(default=100.0, gt=0)
    filter_order: int = Field(default=4, ge=1, le=10)
    decimate: int = Field(default=10, ge=1, le=100)
    n_border: int = Field(default=50, ge=0)
    side: Literal["motor", "load"] = "motor"
    model: Literal["rigid", "two-mass"] = "rigid"
    window: float | str | None = None
    equations: Literal["both", "motor"] = "both"
    encoder_delay: bool = False
    torque_offset: float | None = None
    max_samples: int = Field(default=480_000, ge=1000)

    @field_validator("window", mode="before")
    @classmethod
    def _window(cls, v: Any) -> float | str | None:
        if v is None or is_window(v):
            return v if v is None or v == "auto" else float(v)
        raise ValueError(f"must be a window length > 0 [s] or 'auto', got {v!r}")


# ----------------------------------------------------------------------------- files
class ConfigFile(Table):
    """Base of a configuration file: its fields are the file's tables and top-level keys.

    Read one with :func:`load_file`; :attr:`source` is the file it came from.
    """

    _source: str = PrivateAttr(default="<config>")

    @property
    def source(self) -> str:
        """The file (or name) the configuration was read from."""
        return self._source

    def require(self, table: str) -> Any:
        """Return table ``table``, or raise a one-line :class:`ConfigError` if absent."""
        if table not in type(self).model_fields:
            raise ConfigError(f"{self.source}: no such table [{table}]")
        value = getattr(self, table)
        if value is None:
            raise ConfigError(f"{self.source}: table [{table}] is required for this command")
        return value

    def params(self, table: str, base: Any = None, **values: Any) -> Any:
        """Table ``table`` as its parameter dataclass (see :meth:`Section.to_params`).

        With ``base``, an absent table gives ``base`` (with ``values`` applied); without
        it, an absent table is an error.
        """
        sec = getattr(self, table, None) if table in type(self).model_fields else None
        if sec is None:
            if base is None:
                self.require(table)
            sec = section(type(base), overrides=True)()
        return sec.to_params(f"{self.source}: table [{table}]", base=base, **values)

    def check(self) -> None:
        """Validate each complete parameter table by its dataclass (called on load)."""
        for name in type(self).model_fields:
            sec = getattr(self, name)
            if isinstance(sec, Section) and not sec.__overrides__ and not sec.missing():
                sec.to_params(f"{self.source}: table [{name}]")


class DriveConfig(ConfigFile):
    """A drive configuration (``estimate``, ``identify``, ``observe``); every table optional.

    Use :func:`load_config` to read one. Values in SI units.

    Parameters
    ----------
    drivetrain : DrivetrainSection, optional
        ``[drivetrain]``: the fields of :class:`~drivelash.params.DrivetrainParams`
        (J_m, J_l [kg·m²], N [-], K_S [N·m/rad], D_S [N·m·s/rad], friction [N·m], …).
    backlash : BacklashSection, optional
        ``[backlash]``: ``delta1`` [rad] (and ``delta`` [rad], ``alpha`` [1/rad]).
    estimator : EstimatorSection, optional
        ``[estimator]``: fields of :class:`~drivelash.params.EstimatorConfig` overriding the
        tuning rule.
    columns : dict of str to ColumnMap, optional
        ``[columns]``: source column → Trace column and the source's unit.
    sampling : SamplingSection, optional
        ``[sampling]``: time base and resampling of the recordings.
    identification : IdentificationSection, optional
        ``[identification]``: options of :func:`drivelash.identify_drive`.
    """

    drivetrain: DrivetrainSection | None = None  # type: ignore[valid-type]
    backlash: BacklashSection | None = None  # type: ignore[valid-type]
    estimator: EstimatorSection | None = None  # type: ignore[valid-type]
    columns: dict[str, ColumnMap] | None = None
    sampling: SamplingSection | None = None
    identification: IdentificationSection | None = None

    def check(self) -> None:
        """Validate each complete table, then ``[backlash] delta1`` against the estimator's δ_max
        (``[estimator] delta_max`` or its default): δ1 ≤ δ ≤ δ_max.

        Raises
        ------
        ConfigError
            A table the parameter classes refuse, or δ1 > δ_max (naming the file, table and key).
        """
        super().check()
        delta1 = getattr(self.backlash, "delta1", None)
        if delta1 is None:
            return
        delta_max = getattr(self.estimator, "delta_max", None)
        # a [columns] mapping with the motor position in a length unit makes the trace prismatic
        # (io.load): δ1 is then in m, and a slip is read as µm or mm (session 34 tester G, G10)
        axis = columns_axis(self.columns)
        try:
            check_delta1_bound("", delta1, DELTA_MAX_DEFAULT if delta_max is None else delta_max, axis)
        except ParameterError as exc:
            raise ConfigError(f"{self.source}: table [backlash], key 'delta1': {exc.problem}") from None

    def to_drivetrain_params(self) -> DrivetrainParams:
        """The ``[drivetrain]`` table as :class:`~drivelash.params.DrivetrainParams`."""
        return self.params("drivetrain")

    def to_backlash_params(self, delta: float | None = None) -> BacklashParams:
        """The ``[backlash]`` table as :class:`~drivelash.params.BacklashParams`.

        Parameters
        ----------
        delta : float, optional
            Deadzone δ [rad]; overrides the table's ``delta`` (an estimator passes its
            estimate). One of the two must be given.
        """
        return self.params("backlash", delta=delta)

    def sampling_or_default(self) -> SamplingSection:
        """``[sampling]`` or its defaults."""
        return self.sampling or SamplingSection()

    def identification_or_default(self) -> IdentificationSection:
        """``[identification]`` or its defaults."""
        return self.identification or IdentificationSection()


# ----------------------------------------------------------------------------- errors
def _unwrap(ann: Any) -> Any:
    """The model, dict or list type inside Optional/Annotated/Union, or None for a leaf."""
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return ann
    origin = typing.get_origin(ann)
    if origin in (dict, list, tuple):
        return ann
    for a in typing.get_args(ann) if origin in (Union, types.UnionType, Annotated) else ():
        u = _unwrap(a)
        if u is not None:
            return u
    return None


def _walk(model: type[BaseModel], loc: tuple[Any, ...]) -> tuple[tuple[Any, ...], Any]:
    """Keys of ``loc`` that address tables/keys (pydantic's type tags dropped), and the
    model or container at the last of them."""
    cur: Any = model
    kept: list[Any] = []
    for part in loc:
        if isinstance(cur, type) and issubclass(cur, BaseModel):
            if part in cur.model_fields:
                kept.append(part)
                cur = _unwrap(cur.model_fields[part].annotation)
            continue
        origin = typing.get_origin(cur)
        if origin in (dict, list, tuple):
            kept.append(part)
            args = typing.get_args(cur)
            cur = _unwrap(args[-1]) if args else None
            continue
    return tuple(kept), cur


def did_you_mean(word: str, choices: Any, cutoff: float = 0.6) -> str | None:
    """The choice a mistyped ``word`` most likely meant, or None.

    A choice equal to ``word`` but for case wins (``J_L`` → ``J_l``, not ``J_m``: difflib's ratio
    is case-sensitive and ``J_m`` shares as many characters; session 34, tester G, G13), when
    exactly one does; else the closest by :func:`difflib.get_close_matches` above ``cutoff``.

    Parameters
    ----------
    word : str
        What was written.
    choices : iterable of str
        The valid names.
    cutoff : float
        Least similarity (0–1) of a difflib suggestion.
    """
    choices = [str(c) for c in choices]
    same = [c for c in choices if c.casefold() == word.casefold()]
    if len(same) == 1:
        return same[0]
    close = difflib.get_close_matches(word, choices, n=1, cutoff=cutoff)
    return close[0] if close else None


def _tables_with_key(model: type[BaseModel], key: str) -> list[str]:
    """Tables of ``model`` (a file) that have a key ``key``."""
    found = []
    for name, f in model.model_fields.items():
        sub = _unwrap(f.annotation)
        if isinstance(sub, type) and issubclass(sub, BaseModel) and key in sub.model_fields:
            found.append(name)
    return found


def _format_error(path: str, err: dict[str, Any], model: type[BaseModel]) -> str:
    kind = err.get("type", "")
    loc, _ = _walk(model, tuple(err.get("loc", ())))
    if kind == "extra_forbidden":
        loc = loc + (tuple(err.get("loc", ()))[-1],)
    key = str(loc[-1]) if loc else "?"
    table = ".".join(str(p) for p in loc[:-1])
    where = f"table [{table}], key '{key}'" if table else f"top-level key '{key}'"
    if kind == "extra_forbidden":
        _, holder = _walk(model, loc[:-1])
        is_model = isinstance(holder, type) and issubclass(holder, BaseModel)
        valid = list(holder.model_fields) if is_model else []
        close = did_you_mean(key, valid, cutoff=0.5)
        elsewhere = [t for t in _tables_with_key(model, key) if t != table] if table else []
        if elsewhere and not close:
            hint = "; it is a key of " + " and ".join(f"[{t}]" for t in elsewhere)
        elif close:
            hint = f"; did you mean '{close}'?"
        else:
            hint = f"; valid: {', '.join(valid)}" if valid else ""
        if not table and isinstance(err.get("input"), dict):
            return f"{path}: unknown table [{key}]{hint}"
        return f"{path}: {where}: unknown key{hint}"
    if kind == "missing":
        return f"{path}: {where}: missing"
    if kind in ("model_type", "model_attributes_type", "dict_type"):
        what = f"table [{'.'.join(str(p) for p in loc)}]" if loc else "the document"
        return f"{path}: {what} must be a table (got {type(err.get('input')).__name__})"
    msg = str(err.get("msg", "invalid value")).replace("\n", " ")
    if msg.startswith("Value error, "):
        msg = msg[len("Value error, ") :]
    got = err.get("input")
    if not isinstance(got, dict | list) and kind not in ("value_error",):
        msg = f"{msg} (got {got!r})"
    return f"{path}: {where}: {msg}"


# ----------------------------------------------------------------------------- loading
F = TypeVar("F", bound=ConfigFile)


def parse_file(data: Any, model: type[F], source: str = "<config>") -> F:
    """Validate an already-parsed TOML document against a file model.

    Parameters
    ----------
    data : dict
        The TOML document as returned by :func:`tomllib.loads`.
    model : type
        A :class:`ConfigFile` subclass (e.g. :class:`DriveConfig`).
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
        cfg = model.model_validate(data)
    except ValidationError as exc:
        errors = exc.errors()
        # an unknown key first: a misspelt key also shows up as the missing one
        errors.sort(key=lambda e: e.get("type") != "extra_forbidden")
        raise ConfigError(_format_error(source, errors[0], model)) from None
    except (TypeError, ValueError, RecursionError) as exc:  # pragma: no cover - defensive
        raise ConfigError(f"{source}: invalid configuration ({type(exc).__name__})") from None
    cfg._source = source
    cfg.check()
    return cfg


def loads_toml(text: str, source: str) -> dict[str, Any]:
    """Parse TOML text; a syntax error is one :class:`ConfigError` line naming ``source``."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc).splitlines()[0] if str(exc) else "syntax error"
        raise ConfigError(f"{source}: TOML syntax error: {msg}") from None
    except (ValueError, TypeError, RecursionError) as exc:
        raise ConfigError(f"{source}: TOML syntax error ({type(exc).__name__})") from None


def read_toml(path: str | Path, kind: str = "configuration") -> dict[str, Any]:
    """The TOML document of a file: the one reader of every configuration file.

    The text is decoded as UTF-8 with an optional byte-order mark (``utf-8-sig``: Windows
    editors save one, and a BOM is accepted on CSV recordings too).

    Parameters
    ----------
    path : str or Path
        The ``.toml`` file.
    kind : str
        What the file is, for messages (``"configuration"``, ``"fleet"``).

    Raises
    ------
    ConfigError
        Missing/unreadable file, a directory, not UTF-8, TOML syntax — one line.
    """
    p = Path(path)
    try:
        raw = p.read_bytes()
    except FileNotFoundError:
        raise ConfigError(f"{p}: no such {kind} file") from None
    except IsADirectoryError:
        raise ConfigError(f"{p}: is a directory, not a {kind} file") from None
    except OSError as exc:
        raise ConfigError(f"{p}: cannot read ({exc.strerror or exc})") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ConfigError(
            f"{p}: not a UTF-8 text file (byte 0x{raw[exc.start]:02X} at offset {exc.start};"
            f" is this a TOML {kind} file?)"
        ) from None
    return loads_toml(text, str(p))


def loads_file(text: str, model: type[F], source: str = "<config>") -> F:
    """Parse configuration TOML text against a file model (see :func:`load_file`)."""
    return parse_file(loads_toml(text.removeprefix("\ufeff"), source), model, source)


def load_file(path: str | Path, model: type[F]) -> F:
    """Read and validate a TOML file against a file model.

    Parameters
    ----------
    path : str or Path
        The ``.toml`` file (UTF-8, a byte-order mark allowed; :func:`read_toml`).
    model : type
        A :class:`ConfigFile` subclass.

    Raises
    ------
    ConfigError
        File missing/unreadable, not UTF-8, TOML syntax error, unknown key (with the
        closest valid key), missing key, wrong type or a value the parameter dataclass
        refuses — always one line.
    """
    return parse_file(read_toml(path), model, str(Path(path)))


def parse_config(data: dict[str, Any], source: str = "<config>") -> DriveConfig:
    """A drive configuration from a parsed TOML document (see :func:`parse_file`)."""
    return parse_file(data, DriveConfig, source)


def load_config(path: str | Path) -> DriveConfig:
    """Read and validate a drive configuration file.

    Parameters
    ----------
    path : str or Path
        The drive's ``.toml`` file (``[drivetrain]``, ``[backlash]``, optional ``[estimator]``,
        ``[columns]``, ``[sampling]``, ``[identification]``; values in SI units).

    Returns
    -------
    DriveConfig
        The validated configuration.

    Raises
    ------
    ConfigError
        As :func:`load_file`: the file is missing or unreadable, not TOML, or has an unknown
        or missing key or a value the parameter dataclasses refuse.
    """
    return load_file(path, DriveConfig)


def loads_config(text: str, source: str = "<config>") -> DriveConfig:
    """Parse drive-configuration TOML text (see :func:`load_file`)."""
    return loads_file(text, DriveConfig, source)


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
