"""Session 34, tester G, G13: a configuration key mistyped in case only (``J_L``) was answered
"did you mean 'J_m'?" (difflib's ratio is case-sensitive and J_m shares as many characters); a
case-insensitive exact match now wins, for units too. Negative control: another typo still gets
difflib's nearest key.
"""

from __future__ import annotations

import pytest

from drivelash.errors import ConfigError
from drivelash.io.config import parse_config

DRIVE = {"J_m": 20.0, "J_l": 100.0, "N": 1.0, "K_S": 2e7, "D_S": 2000.0}


@pytest.mark.parametrize(
    ("typo", "meant"), [("J_L", "J_l"), ("j_m", "J_m"), ("k_s", "K_S"), ("BETA_L", "beta_l")]
)
def test_a_key_mistyped_in_case_suggests_that_key(typo, meant):
    table = {k: v for k, v in DRIVE.items() if k != meant} | {typo: 1.0}
    with pytest.raises(ConfigError, match=rf"key '{typo}': unknown key; did you mean '{meant}'\?$"):
        parse_config({"drivetrain": table}, "d.toml")


def test_negative_control_another_typo_keeps_the_nearest_key():
    with pytest.raises(ConfigError, match=r"key 'J_ml': unknown key; did you mean 'J_m'\?$"):
        parse_config({"drivetrain": DRIVE | {"J_ml": 1.0}}, "d.toml")


def test_a_unit_mistyped_in_case_suggests_that_unit():
    """The same rule for a unit: 'mM' was answered "did you mean 'm'?"."""
    with pytest.raises(ConfigError, match=r"unknown unit 'mM' \(did you mean 'mm'\?\)"):
        parse_config({"columns": {"x": {"column": "theta_m", "unit": "mM"}}}, "d.toml")
