"""drivelash — mechanics of machine-tool drive trains.

Backlash estimation (online and offline), transmission-error learning and
compensation for rack-and-pinion drives, and wear tracking.

The public API, for notebooks and scripts (python-control style: one curated namespace)::

    import drivelash as dl
    trace = dl.load_trace("run.parquet", dl.load_config("drive.toml"))
    est = dl.estimate_backlash(trace, "drive.toml")         # online: the numbers of `estimate`
    est.delta, est.converged, est.summary
    ident = dl.identify_drive(trace, "drive.toml")          # offline, with 95 % intervals
    ident["delta"].value, ident["delta"].low, ident["delta"].high

Names are imported on first use, so ``import drivelash`` (and the command line) stays fast.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from drivelash._lazy import lazy_names
from drivelash.errors import ConfigError, DataError, DrivelashError, ParameterError

__version__ = "0.1.0"

#: public name → module that defines it (imported lazily, PEP 562)
_LAZY: dict[str, str] = {
    # online estimation (the computation of `drivelash estimate`)
    "estimate_backlash": "drivelash.estimation.backlash_api",
    "BacklashEstimate": "drivelash.estimation.backlash_api",
    # offline identification
    "identify_drive": "drivelash.estimation.identify_api",
    "DriveIdentification": "drivelash.estimation.identify_result",
    "ParameterEstimate": "drivelash.estimation.identify_result",
    # recordings and configuration
    "Trace": "drivelash.io.trace",
    "load_trace": "drivelash.io.load",
    "load_config": "drivelash.io.config",
    "DriveConfig": "drivelash.io.config",
    # parameters
    "DrivetrainParams": "drivelash.params",
    "BacklashParams": "drivelash.params",
}

__all__ = [
    "BacklashEstimate",
    "BacklashParams",
    "ConfigError",
    "DataError",
    "DriveConfig",
    "DriveIdentification",
    "DrivelashError",
    "DrivetrainParams",
    "ParameterError",
    "ParameterEstimate",
    "Trace",
    "__version__",
    "estimate_backlash",
    "identify_drive",
    "load_config",
    "load_trace",
]


__getattr__, __dir__ = lazy_names("drivelash", _LAZY, globals())


if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs
    from drivelash.estimation.backlash_api import BacklashEstimate, estimate_backlash
    from drivelash.estimation.identify_api import identify_drive
    from drivelash.estimation.identify_result import DriveIdentification, ParameterEstimate
    from drivelash.io.config import DriveConfig, load_config
    from drivelash.io.load import load_trace
    from drivelash.io.trace import Trace
    from drivelash.params import BacklashParams, DrivetrainParams
