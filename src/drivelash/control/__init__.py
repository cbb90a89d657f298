"""Discrete cascade position control and reference trajectories (spec 01 §1)."""

from drivelash.control.cascade import CascadeController, gains_from_bandwidth
from drivelash.control.path_error import predict_path_error
from drivelash.control.references import (
    Reference,
    constant_velocity_passes,
    position_sine,
    sampled,
    velocity_sine,
)

__all__ = [
    "CascadeController",
    "Reference",
    "constant_velocity_passes",
    "gains_from_bandwidth",
    "position_sine",
    "predict_path_error",
    "sampled",
    "velocity_sine",
]
