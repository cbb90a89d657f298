"""The ``iso230`` configuration file: ``[columns]``, ``[sampling]``, ``[iso230]``, ``[dwell]``,
``[transmission]``.

``[columns]`` and ``[sampling]`` are the project's tables (:mod:`drivelash.io.config`);
``[iso230]``, ``[dwell]`` and ``[transmission]`` hold the fields of
:class:`~drivelash.iso230.inputs.Iso230Params`, :class:`~drivelash.iso230.dwell.DwellParams`
and :class:`~drivelash.iso230.compare.Transmission` (SI units), checked by those
dataclasses. Example::

    [columns."Target [mm]"]
    column = "P_target"
    unit = "mm"
    [columns.Run]
    column = "run"
    [columns.Dir]
    column = "direction"
    [columns."Error [um]"]
    column = "x_dev"
    unit = "um"

    [transmission]
    lead = 0.01          # ball screw, 10 mm per revolution

Errors are one line naming the file, the table and the key.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drivelash.errors import ConfigError, ParameterError
from drivelash.io.config import DriveConfig, did_you_mean, parse_config, read_toml
from drivelash.iso230.compare import Transmission
from drivelash.iso230.dwell import DwellParams
from drivelash.iso230.inputs import Iso230Params

__all__ = ["Iso230Config", "load_iso230_config"]

_TABLES: dict[str, type] = {"iso230": Iso230Params, "dwell": DwellParams, "transmission": Transmission}
_DRIVE_TABLES = ("columns", "sampling")


@dataclass(frozen=True)
class Iso230Config:
    """A parsed ``iso230`` configuration.

    Attributes
    ----------
    mapping : DriveConfig
        ``[columns]`` and ``[sampling]`` (what :func:`drivelash.io.load_trace` takes).
    iso230 : Iso230Params
    dwell : DwellParams
    transmission : Transmission or None
        None when the file has no ``[transmission]``.
    source : str
    """

    mapping: DriveConfig | None
    iso230: Iso230Params
    dwell: DwellParams
    transmission: Transmission | None
    source: str


def _table(source: str, name: str, cls: type, data: Any) -> Any:
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: [{name}] must be a table")
    valid = [f.name for f in dataclasses.fields(cls)]
    for key in data:
        if key not in valid:
            close = did_you_mean(key, valid, cutoff=0.5)
            hint = f"; did you mean '{close}'?" if close else f"; valid: {', '.join(valid)}"
            raise ConfigError(f"{source}: table [{name}], key '{key}': unknown key{hint}")
    kw = dict(data)
    if cls is Iso230Params and "targets" in kw:
        t = kw["targets"]
        if not isinstance(t, list) or any(isinstance(v, bool) or not isinstance(v, int | float) for v in t):
            raise ConfigError(
                f"{source}: table [{name}], key 'targets': must be a list of numbers [m or rad]"
            )
        kw["targets"] = tuple(float(v) for v in t)
    for f in dataclasses.fields(cls):
        if f.name in kw and f.type in ("float", "float | None") and kw[f.name] is not None:
            v = kw[f.name]
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise ConfigError(f"{source}: table [{name}], key '{f.name}': must be a number, got {v!r}")
            kw[f.name] = float(v)
    try:
        return cls(**kw)
    except ParameterError as exc:
        raise ConfigError(f"{source}: table [{name}], key '{exc.field}': {exc.problem}") from None


def load_iso230_config(path: str | Path | None) -> Iso230Config:
    """Read an ``iso230`` configuration (None: every default, columns named as in the file).

    Raises
    ------
    ConfigError
        Missing file, TOML syntax, unknown table or key (with the closest valid one),
        a value the dataclass refuses — one line.
    """
    if path is None:
        return Iso230Config(None, Iso230Params(), DwellParams(), None, "<defaults>")
    p = Path(path)
    src = str(p)
    data = read_toml(p)
    known = [*_DRIVE_TABLES, *_TABLES]
    for key in data:
        if key not in known:
            close = did_you_mean(key, known, cutoff=0.5)
            hint = f"; did you mean '{close}'?" if close else f"; valid: {', '.join(known)}"
            raise ConfigError(f"{src}: unknown table [{key}]{hint}")
    drive = {k: data[k] for k in _DRIVE_TABLES if k in data}
    mapping = parse_config(drive, src) if drive else None
    built = {name: _table(src, name, cls, data[name]) for name, cls in _TABLES.items() if name in data}
    return Iso230Config(
        mapping=mapping,
        iso230=built.get("iso230", Iso230Params()),
        dwell=built.get("dwell", DwellParams()),
        transmission=built.get("transmission"),
        source=src,
    )
