"""drivelash — mechanics of machine-tool drive trains.

Backlash estimation (online and offline), transmission-error learning and
compensation for rack-and-pinion drives, and wear tracking.
"""

from drivelash.errors import DrivelashError, ParameterError

__version__ = "0.1.0"
__all__ = ["DrivelashError", "ParameterError", "__version__"]
