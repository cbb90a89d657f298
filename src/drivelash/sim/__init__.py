"""Closed-loop drive-train simulation: engine, sensor model and named scenarios.

Public names (imported on first use):

- two-mass drive with backlash under cascade control (spec 01): :func:`simulate`,
  :class:`SimResult`, :func:`initial_state`, deadzone profiles :func:`delta_constant`,
  :func:`delta_step`, :func:`delta_ramp`;
- named scenarios (``drivelash scenarios``): :class:`Scenario`, :func:`get_scenario`,
  :func:`list_scenarios`, :func:`load_scenario`, :func:`scenario_from_toml`;
- rack-and-pinion axis (spec 02): :class:`RackAxisSimulator`, :class:`AxisSimConfig`;
- simulated wear fleet: :func:`simulate_fleet`, :class:`FleetPlan`.
"""

from __future__ import annotations

from drivelash._lazy import lazy_names

_LAZY: dict[str, str] = {
    "SimResult": "drivelash.sim.engine",
    "delta_constant": "drivelash.sim.engine",
    "delta_ramp": "drivelash.sim.engine",
    "delta_step": "drivelash.sim.engine",
    "initial_state": "drivelash.sim.engine",
    "simulate": "drivelash.sim.engine",
    "Scenario": "drivelash.sim.scenarios",
    "get_scenario": "drivelash.sim.scenarios",
    "list_scenarios": "drivelash.sim.scenarios",
    "load_scenario": "drivelash.sim.scenarios",
    "scenario_from_toml": "drivelash.sim.scenarios",
    "AxisSimConfig": "drivelash.sim.rack_axis",
    "RackAxisSimulator": "drivelash.sim.rack_axis",
    "FleetPlan": "drivelash.sim.fleet",
    "simulate_fleet": "drivelash.sim.fleet",
}

__all__ = sorted(_LAZY, key=str.lower)

__getattr__, __dir__ = lazy_names("drivelash.sim", _LAZY, globals())
