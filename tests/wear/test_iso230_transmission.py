"""An ISO 230-2 check stored for an axis without a transmission (exploration: value_rad NULL,
silently; the fleet report then showed '–' where README promises the check beside the trend)."""

from __future__ import annotations

import pytest
from tests.iso230.test_history import K_MM, LEAD, laser_files  # the same laser table and screw

from drivelash.commands.iso230 import run_iso230
from drivelash.wear.store import Store


class _Axis:
    def __init__(self, name: str) -> None:
        self.name, self.drive_path, self.drive_hash = name, "drive.toml", "h" * 64
        self.threshold_rad, self.transmission, self.horizon_days, self.not_excited_alarm = 0.02, None, 30.0, 5


def _setup(tmp_path, transmission: bool):
    db = tmp_path / "wear.sqlite"
    with Store(db) as st:
        st.upsert_axes([_Axis("M01/Y")])
    csv, toml = laser_files(tmp_path, f"\n[transmission]\nlead = {LEAD}\n" if transmission else "")
    return db, csv, toml


def _stored(db):
    with Store(db, create=False) as st:
        (m,) = st.measurements("M01/Y")
    return m


def test_check_without_any_transmission_warns_which_key_to_add(tmp_path):
    db, csv, toml = _setup(tmp_path, transmission=False)
    s = run_iso230(csv, toml, db=str(db), axis="M01/Y", time="2026-03-10T09:00", quiet=True)
    w = [x for x in s["warnings"] if "cannot be shown as a deadzone" in x]
    assert len(w) == 1 and "axis M01/Y has no transmission" in w[0]
    assert "'transmission = <mm of load travel per rad>' to its [[axis]] in fleet.toml" in w[0]
    assert _stored(db)["value_rad"] is None


def test_check_uses_the_iso230_configs_transmission(tmp_path):
    db, csv, toml = _setup(tmp_path, transmission=True)
    s = run_iso230(csv, toml, db=str(db), axis="M01/Y", time="2026-03-10T09:00", quiet=True)
    m = _stored(db)
    assert m["unit"] == "m" and m["value_rad"] == pytest.approx(m["value"] * 1e3 / K_MM, rel=1e-12)
    assert m["value"] == pytest.approx(12e-6, abs=3 * m["std"])
    # negative control: no warning when the check can be converted
    assert not [x for x in s["warnings"] if "cannot be shown as a deadzone" in x]
