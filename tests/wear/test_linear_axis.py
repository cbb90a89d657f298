"""Wear tracking of a linear (prismatic) axis: δ in m, lost motion 5–60 µm (session 35 tester G).

G5: a 20 → 60 µm jump (4 + 3 estimates, ±0.45 µm each, converged) gave no change point, a noise
of "0.020 mrad" (the 20 µrad floor read as 20 µm) and a linear fit crossing 100 µm in 4.3 days —
the trend's absolute constants were rad (a jump had to exceed 2 mm). G2: estimates ±10 µm (σ) on a
20 µm gap, not converged, were admitted (the 5 mrad gate read as 5 mm). G9: status, forecast,
alarms and report wrote mm numbers labelled mrad, and a threshold could not be given in µm; the
unit-slip hint for ``threshold = 30`` suggested 30 mm. Each test has the rotary axis as its
negative control: its rules and texts are unchanged.
"""

from __future__ import annotations

import dataclasses
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np
import pytest
import sqlalchemy as sa

from drivelash.errors import ConfigError
from drivelash.wear.fleet import load_fleet
from drivelash.wear.store import EstimateRow, Store

T0 = datetime(2026, 11, 20, 8, 0)
#: the tester's L1/Z (fz.json): δ̂ [m] of 7 daily 6 s recordings, true 20 µm then 60 µm
L1Z = [19.794e-6, 19.786e-6, 19.826e-6, 19.81e-6, 59.94e-6, 59.94e-6, 59.95e-6]
L1Z_STD = 0.447e-6
#: the tester's L1/X (fx.json): 4 s recordings, not converged, σ ≈ 10 µm (95 % ≈ ±20 µm = the gap)
L1X = [19.55e-6, 19.69e-6, 19.74e-6, 19.78e-6, 20.06e-6, 20.27e-6]
L1X_STD = [9.99e-6, 10.08e-6, 10.15e-6, 10.26e-6, 11.05e-6, 11.65e-6]


# --------------------------------------------------------------------------- fleet.toml
DRIVE = """[drivetrain]
J_m = 20.0
J_l = 100.0
N = 1.0
K_S = 2.0e7
D_S = 2000.0
T_Cm = 20.0
T_Cl = 60.0
beta_m = 50.0
beta_l = 300.0
[backlash]
delta1 = {delta1}
"""
COLUMNS = """[columns.time_s]
column = "t"
unit = "s"
[columns.pos_motor_mm]
column = "theta_m"
unit = "{pos}"
[columns.vel_motor_mm_s]
column = "omega_m"
unit = "{vel}"
[columns.pos_scale_mm]
column = "theta_l"
unit = "{pos}"
[columns.vel_scale_mm_s]
column = "omega_l"
unit = "{vel}"
[columns.force_N]
column = "torque_m"
unit = "{torque}"
"""
FLEET = """[fleet]
time = {{ from = "filename", pattern = '(\\d{{8}}T\\d{{6}})', format = "%Y%m%dT%H%M%S" }}
[[axis]]
id = "L1/Z"
drive = "drive.toml"
recordings = "rec/*.csv"
threshold = {threshold}
"""


def _fleet(tmp_path: Path, threshold: str, linear: bool = True) -> Path:
    cols = (
        COLUMNS.format(pos="mm", vel="mm/s", torque="N")
        if linear
        else COLUMNS.format(pos="rad", vel="rad/s", torque="N·m")
    )
    (tmp_path / "drive.toml").write_text(DRIVE.format(delta1="10.0e-6" if linear else "0.093") + cols)
    p = tmp_path / "fleet.toml"
    p.write_text(FLEET.format(threshold=threshold))
    return p


@pytest.mark.parametrize(
    ("threshold", "metres"),
    [('30\nthreshold_unit = "um"', 30e-6), ('30\nthreshold_unit = "µm"', 30e-6),
     ('0.03\nthreshold_unit = "mm"', 30e-6), ("30e-6", 30e-6), ('30e-6\nthreshold_unit = "m"', 30e-6)],
)  # fmt: skip
def test_a_linear_axis_takes_its_threshold_in_micrometres(tmp_path, threshold, metres):
    (a,) = load_fleet(_fleet(tmp_path, threshold)).axes
    assert a.kind == "prismatic" and a.threshold_rad == pytest.approx(metres, rel=1e-12)
    assert a.transmission is None


def test_unit_slips_on_a_linear_axis_get_a_hint_in_micrometres(tmp_path):
    def refused(threshold: str, linear: bool = True) -> str:
        p = _fleet(tmp_path, threshold, linear)
        with pytest.raises(ConfigError) as exc:
            load_fleet(p)
        msg = str(exc.value)
        assert "\n" not in msg and msg.startswith(f"{p.resolve()}: table [[axis]] #1 (id 'L1/Z')"), msg
        return msg.split("(id 'L1/Z')", 1)[1]

    # was: "30 rad (1719°) at the load …; the key is in rad — 30 mrad is threshold = 0.03" (30 mm)
    assert refused("30") == (
        ", key 'threshold': 30 m is 3e+04 mm of lost motion on a linear axis, no backlash threshold"
        ' (limit 1000 µm); the key is in m — 30 µm is threshold = 30 with threshold_unit = "um"'
        " (or threshold = 3e-05 in m)"
    )
    # following the old hint (0.03 = 30 mm) is refused too
    assert "0.03 m is 30 mm of lost motion on a linear axis" in refused("0.03")
    assert "30 mm is 30 mm of lost motion" in refused('30\nthreshold_unit = "mm"')
    # a lead in mm/rad or an angle means nothing on a linear axis
    assert "'transmission' (mm of load travel per rad) has no meaning on a linear axis" in refused(
        '0.03\nthreshold_unit = "mm"\ntransmission = 1.59'
    )
    assert "threshold_unit = 'rad' on a linear axis" in refused('30e-6\nthreshold_unit = "rad"')
    # negative controls: a rotary axis (positions in rad) keeps its rad hint and its mm with a
    # transmission, and refuses µm without one
    assert refused("30", linear=False) == (
        ", key 'threshold': 30 rad (1719°) at the load is no backlash threshold (limit 0.5 rad); the key"
        " is in rad — 30 mrad is threshold = 0.03"
    )
    (a,) = load_fleet(_fleet(tmp_path, '300\nthreshold_unit = "um"\ntransmission = 2.0', linear=False)).axes
    assert a.kind == "rotary" and a.threshold_rad == pytest.approx(0.15)
    assert "threshold_unit = 'um' needs 'transmission'" in refused('30\nthreshold_unit = "um"', linear=False)


# --------------------------------------------------------------------------- store and views
@dataclasses.dataclass(frozen=True)
class _Axis:
    name: str
    threshold_rad: float
    kind: str
    drive_path: Path = Path("/x/drive.toml")
    drive_hash: str = "c" * 64
    transmission: float | None = None
    horizon_days: float = 30.0
    not_excited_alarm: int = 5


def _estimate(axis: str, i: int, delta: float, std: float) -> EstimateRow:
    return EstimateRow(
        axis=axis,
        path=f"/r/{axis.replace('/', '-')}_{i}.csv",
        size_bytes=100 + i,
        mtime_ns=10**18 + i,
        content_hash=f"{axis}{i}".encode().hex().ljust(64, "0"),
        start_time=T0 + timedelta(days=i),
        duration_s=6.0,
        sample_rate_hz=8000.0,
        samples=48000,
        method="default",
        code_version="drivelash 0.1.0",
        config_hash="c" * 64,
        status="ok",
        reason="6 crossings of the gap",
        delta=delta,
        delta_std=std,
        excitation_ok=True,
        converged=True,
        estimate_rate_hz=8000.0,
    )


def _store(db: Path, rotary: bool = True) -> None:
    """L1/Z (the tester's jump, linear, threshold 100 µm) and — the negative control — M01/X, a
    rotary axis of 186 mrad wearing 1 mrad a day towards 0.2 rad."""
    axes = [_Axis("L1/Z", 100e-6, "prismatic")] + ([_Axis("M01/X", 0.2, "rotary")] if rotary else [])
    rows = [_estimate("L1/Z", i, d, L1Z_STD) for i, d in enumerate(L1Z)]
    if rotary:
        rows += [_estimate("M01/X", i, 0.186 + 1e-3 * i + 1e-4 * (-1) ** i, 1e-4) for i in range(7)]
    with Store(db) as st:
        st.commit_batch(rows, st.upsert_axes(axes))


def test_a_store_of_revision_0003_keeps_working_and_reads_its_axes_as_rotary(tmp_path):
    from alembic import command
    from alembic.config import Config

    from drivelash.wear.store import MIGRATIONS

    db = tmp_path / "old.sqlite"
    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS))
    eng = sa.create_engine(f"sqlite:///{db}")
    with eng.begin() as conn:
        cfg.attributes["connection"] = conn
        command.upgrade(cfg, "0003")
        conn.exec_driver_sql(
            "INSERT INTO axis (name, machine, threshold_rad, horizon_days, not_excited_alarm, updated_at) "
            "VALUES ('M01/X', 'M01', 0.2, 30, 5, '2026-01-01 00:00:00')"
        )
    eng.dispose()
    with Store(db) as st:
        assert st.revision() == "0004"
        (a,) = st.axes()
        assert a["kind"] == "rotary"  # NULL: written before the kind was stored
        ids = st.upsert_axes([_Axis("M01/X", 0.2, "rotary"), _Axis("L1/Z", 1e-4, "prismatic")])
        st.commit_batch([_estimate("L1/Z", 0, 20e-6, L1Z_STD)], ids)
        assert {x["name"]: x["kind"] for x in st.axes()} == {"M01/X": "rotary", "L1/Z": "prismatic"}
        (row,) = st.estimates("L1/Z")
        assert row["axis_kind"] == "prismatic"
        # a laser check of a linear axis is its δ in m, without a transmission
        st.add_measurement("L1/Z", T0, value=20.06, std=0.05, unit="um")
        (m,) = st.measurements("L1/Z")
        assert m["value_rad"] == pytest.approx(20.06e-6) and m["std_rad"] == pytest.approx(0.05e-6)


def _recording(path: Path, axis: str | None) -> Path:
    """A 1 s, 2 kHz recording in Trace names and SI (a carriage's ±1 mm sine in m, or the same
    numbers as rad), its own metadata saying the axis kind when ``axis`` is given."""
    from drivelash.io.trace import Trace

    t = np.arange(2000) / 2000.0
    x = 1e-3 * np.sin(2 * np.pi * t)
    v = 2e-3 * np.pi * np.cos(2 * np.pi * t)
    cols = {"t": t, "theta_m": x + 5e-6, "omega_m": v, "theta_l": x, "omega_l": v, "torque_m": 100 * v}
    Trace(cols, {"axis": axis} if axis else {}).to_parquet(path)
    return path


def test_a_recording_whose_kind_contradicts_its_axis_is_refused_at_ingest(tmp_path, monkeypatch):
    """A Parquet file whose metadata says prismatic, on an axis whose drive file has no [columns]
    (rotary): its δ in m would be trended and shown as rad. A failed row naming both kinds."""
    import drivelash.estimation.pipeline as pipeline
    from drivelash.errors import DataError
    from drivelash.io.config import load_config
    from drivelash.wear.estimate import RecordingTask, estimate_recording
    from drivelash.wear.fleet import TimeSpec

    def reached(*a, **k):  # the estimator itself is not the subject: the kind check before it
        raise DataError("estimator reached")

    monkeypatch.setattr(pipeline, "estimate_trace", reached)
    (tmp_path / "drive.toml").write_text(DRIVE.format(delta1="10.0e-6"))
    drive = load_config(tmp_path / "drive.toml")
    spec = TimeSpec.model_validate(
        {"from": "filename", "pattern": r"(\d{8}T\d{6})", "format": "%Y%m%dT%H%M%S"}
    )

    def run(path: Path, kind: str) -> str:
        task = RecordingTask("L1/Z", str(path), 1, 1, drive, spec, "default", "c" * 64, "v", None, kind)
        row = estimate_recording(task)
        assert row.status == "failed"
        return row.reason

    lin = _recording(tmp_path / "rec_20261120T080000.parquet", "prismatic")
    assert run(lin, "rotary") == (
        f"{lin}: the recording is linear (positions in a length unit), but axis L1/Z is rotary "
        "(positions in rad) by its drive file's [columns]; give the position columns' unit there (a "
        "length unit — m, mm, um — makes the axis linear)"
    )
    # negative controls: matching kinds reach the estimator (a rotary file on a rotary axis too)
    assert run(lin, "prismatic").endswith("estimator reached")
    rot = _recording(tmp_path / "rec_20261121T080000.parquet", None)
    assert run(rot, "rotary").endswith("estimator reached")
