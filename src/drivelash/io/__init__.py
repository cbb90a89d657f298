"""Traces, file formats, column/unit mapping, validation and configuration."""

from drivelash.io.trace import Trace

__all__ = ["Trace"]
