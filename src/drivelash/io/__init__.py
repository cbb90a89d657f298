"""Traces, file formats, column/unit mapping, validation and configuration."""

from drivelash.io.config import DriveConfig, load_config
from drivelash.io.formats import read_raw, write_trace
from drivelash.io.load import load_trace
from drivelash.io.stream import TraceStream, iter_trace_chunks
from drivelash.io.trace import Trace

__all__ = [
    "DriveConfig",
    "Trace",
    "TraceStream",
    "iter_trace_chunks",
    "load_config",
    "load_trace",
    "read_raw",
    "write_trace",
]
