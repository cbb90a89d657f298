"""Parameter validation: errors name the class and the field."""

from __future__ import annotations

import pytest

from drivelash.errors import ParameterError
from drivelash.params import BacklashParams, CascadeGains, DrivetrainParams, SensorParams


def _dt(**kw):
    base = dict(J_m=8.31e-4, J_l=8.31e-4, N=1.0, K_S=32.94, D_S=0.0548)
    base.update(kw)
    return DrivetrainParams(**base)


@pytest.mark.parametrize(
    ("kw", "field"),
    [
        ({"J_m": -1.0}, "J_m"),
        ({"J_l": 0.0}, "J_l"),
        ({"K_S": float("nan")}, "K_S"),
        ({"T_Cl": -0.1}, "T_Cl"),
        ({"T_Sm": 0.01, "T_Cm": 0.02}, "T_Sm"),
    ],
)
def test_drivetrain_rejects_bad_field(kw, field):
    with pytest.raises(ParameterError) as ei:
        _dt(**kw)
    assert ei.value.field == field
    assert f"DrivetrainParams.{field}" in str(ei.value)
    assert "\n" not in str(ei.value)


def test_backlash_offset_outside_gap():
    with pytest.raises(ParameterError, match=r"BacklashParams\.delta1"):
        BacklashParams(delta=0.1, delta1=0.2)
    with pytest.raises(ParameterError, match=r"BacklashParams\.alpha"):
        BacklashParams(delta=0.1, delta1=0.05, alpha=0.0)


def test_gains_and_sensor_validation():
    with pytest.raises(ParameterError, match=r"CascadeGains\.k_ff"):
        CascadeGains(K_v=100, K_p=0.1, T_n=0.01, torque_limit=13, k_ff=2)
    with pytest.raises(ParameterError, match=r"SensorParams\.counts_m"):
        SensorParams(counts_m=10.5)
    with pytest.raises(ParameterError, match=r"SensorParams\.velocity_source"):
        SensorParams(velocity_source="guessed")


def test_frozen():
    p = _dt()
    with pytest.raises(AttributeError):
        p.J_m = 1.0  # type: ignore[misc]
