"""Pure physical models: @njit kernels and thin NumPy wrappers.

Public names (imported on first use):

- two-mass drive train with backlash (spec 01 §1): :func:`rhs`, :func:`rk4_step`,
  :func:`linear_state_space`, :func:`plant_params_array`;
- deadzone and smooth backlash torque (spec 01 eqs. (10)–(12)), scalar kernels:
  :func:`deadzone_torque_scalar`, :func:`smooth_torque_scalar`;
- friction (Coulomb, Stribeck, viscous): :func:`friction_scalar`;
- rack-and-pinion geometry and transmission error (spec 02 §2):
  :class:`RackGeometry`, :class:`RackDrive`, :class:`RackPinionBench`,
  :class:`TEGeneratorParams`, :class:`LocalDefect`, :class:`TransmissionErrorModel`.
"""

from __future__ import annotations

from drivelash._lazy import lazy_names

_LAZY: dict[str, str] = {
    "deadzone_torque_scalar": "drivelash.physics.backlash",
    "smooth_torque_scalar": "drivelash.physics.backlash",
    "friction_scalar": "drivelash.physics.friction",
    "linear_state_space": "drivelash.physics.drivetrain",
    "plant_params_array": "drivelash.physics.drivetrain",
    "rhs": "drivelash.physics.drivetrain",
    "rk4_step": "drivelash.physics.drivetrain",
    "LocalDefect": "drivelash.physics.rack_pinion",
    "RackDrive": "drivelash.physics.rack_pinion",
    "RackGeometry": "drivelash.physics.rack_pinion",
    "RackPinionBench": "drivelash.physics.rack_pinion",
    "TEGeneratorParams": "drivelash.physics.rack_pinion",
    "TransmissionErrorModel": "drivelash.physics.rack_pinion",
}

__all__ = sorted(_LAZY, key=str.lower)

__getattr__, __dir__ = lazy_names("drivelash.physics", _LAZY, globals())
