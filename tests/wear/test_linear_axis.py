"""Wear tracking of a linear (prismatic) axis: δ in m, lost motion 5–60 µm (session 34 tester G).

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
import json
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np
import pytest

from drivelash.errors import ConfigError
from drivelash.wear.alarms import axis_alarms
from drivelash.wear.fleet import load_fleet
from drivelash.wear.store import EstimateRow, Store
from drivelash.wear.trend import analyse, usable

T0 = datetime(2026, 11, 20, 8, 0)
#: the tester's L1/Z (fz.json): δ̂ [m] of 7 daily 6 s recordings, true 20 µm then 60 µm
L1Z = [19.794e-6, 19.786e-6, 19.826e-6, 19.81e-6, 59.94e-6, 59.94e-6, 59.95e-6]
L1Z_STD = 0.447e-6
#: the tester's L1/X (fx.json): 4 s recordings, not converged, σ ≈ 10 µm (95 % ≈ ±20 µm = the gap)
L1X = [19.55e-6, 19.69e-6, 19.74e-6, 19.78e-6, 20.06e-6, 20.27e-6]
L1X_STD = [9.99e-6, 10.08e-6, 10.15e-6, 10.26e-6, 11.05e-6, 11.65e-6]


def _rows(deltas, std, converged=True, kind="prismatic"):
    stds = std if isinstance(std, list) else [std] * len(deltas)
    return [
        {
            "status": "ok",
            "excitation_ok": True,
            "converged": converged,
            "delta": d,
            "delta_std": s,
            "start_time": T0 + timedelta(days=i),
            "path": f"rec_{i:03d}.csv",
            "reason": "6 crossings of the gap",
            "axis_kind": kind,
        }
        for i, (d, s) in enumerate(zip(deltas, stds, strict=True))
    ]


def _axis(threshold, kind="prismatic", name="L1/Z"):
    return {
        "name": name,
        "threshold_rad": threshold,
        "horizon_days": 30.0,
        "not_excited_alarm": 5,
        "kind": kind,
    }


def test_a_jump_on_a_linear_axis_is_an_alarm_and_the_level_after_it_stays_flat():
    rows = _rows(L1Z, L1Z_STD)
    trend, used = analyse(rows, 100e-6, "prismatic")
    assert len(used) == 7
    # was: change_points [], noise 2e-5 (the floor), linear b = 8.6 µm/day, crossing in 4.3 days
    (cp,) = trend.change_points
    assert cp.index == 4 and cp.size == pytest.approx(40.1e-6, abs=0.2e-6)
    assert trend.sigma < 0.1e-6  # the estimates' own scatter (0.045 µm), not a 20 µm floor
    now = float(trend.curve(np.array([trend.t_now]))[0][0])
    assert now == pytest.approx(59.95e-6, abs=0.05e-6)
    assert abs(trend.params["b"]) < 0.05e-6  # flat after the jump: µm/day
    assert trend.forecast is not None and trend.forecast.t_cross is None  # never reaches 100 µm
    al = {a.kind: a for a in axis_alarms(_axis(100e-6), rows, trend)}
    assert set(al) == {"jump"}, al
    assert al["jump"].message == "L1/Z: sudden backlash increase of 40.11 µm at 2026-11-24 UTC"
    # negative control: the same numbers on a rotary axis are 20 → 60 µrad, far below its 2 mrad
    # jump minimum — no jump there, as before (the rotary rules are unchanged)
    rot, _ = analyse(_rows(L1Z, L1Z_STD, kind="rotary"), 100e-6, "rotary")
    assert rot.change_points == [] and rot.sigma == 2e-5


def test_unconverged_estimates_of_a_linear_axis_enter_only_within_the_scaled_limit():
    rows = _rows(L1X, L1X_STD, converged=False)
    # was: all six admitted (±20 µm < "5 mrad") and a forecast crossing of 30 µm in 74 days
    assert not any(usable(r) for r in rows)
    trend, used = analyse(rows, 30e-6, "prismatic")
    assert used == [] and trend.model is None and trend.forecast is None
    al = {a.kind for a in axis_alarms(_axis(30e-6, name="L1/X"), rows, trend)}
    assert al == {"not_converged"}
    # the rotary rule scaled (5 mrad → 1.25 µm at 95 %): ±0.98 µm enters, ±1.37 µm does not
    assert usable(_rows([20e-6], 0.5e-6, converged=False)[0])
    assert not usable(_rows([20e-6], 0.7e-6, converged=False)[0])
    # negative control: on a rotary axis the same σ (10 µrad) is far inside its 5 mrad gate, and
    # 2.6 mrad (95 % 5.1 mrad) outside it, as before
    assert all(usable(r) for r in _rows(L1X, L1X_STD, converged=False, kind="rotary"))
    assert not usable(_rows([0.2], 2.6e-3, converged=False, kind="rotary")[0])


def test_alarm_texts_of_a_linear_axis_are_in_micrometres():
    # the tester's L1/Y with a 12 µm threshold and a 14 µm gap: was "backlash above the threshold
    # 0.01 mrad (fitted 0.01 mrad)"
    y = [14.0e-6 + 0.01e-6 * i for i in range(6)]
    rows = _rows(y, 0.4e-6)
    trend, _ = analyse(rows, 12e-6, "prismatic")
    msg = {a.kind: a.message for a in axis_alarms(_axis(12e-6, name="L1/Y"), rows, trend)}
    assert msg["threshold"] == "L1/Y: backlash above the threshold 12.00 µm (fitted 14.05 µm)", msg
    # negative control: a rotary axis says mrad, as before
    rot = [0.180 + 1e-4 * i for i in range(6)]
    rrows = _rows(rot, 1e-4, kind="rotary")
    rtrend, _ = analyse(rrows, 0.175, "rotary")
    rmsg = {a.kind: a.message for a in axis_alarms(_axis(0.175, "rotary", "M01/X"), rrows, rtrend)}
    assert rmsg["threshold"] == "M01/X: backlash above the threshold 175.00 mrad (fitted 180.50 mrad)"


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
    # a value already in µm gets no hint to write it in µm (the last read: the hint repeated it)
    msg = refused('2000\nthreshold_unit = "um"')
    assert "2000 um is 2 mm of lost motion" in msg and "in µm already" in msg, msg
    assert "threshold = 2000 with" not in msg
    msg = refused('5000\nthreshold_unit = "um"\ntransmission = 2.0', linear=False)
    assert "2.5 rad at the load" in msg and "check the value and the transmission" in msg, msg
    assert "µm is threshold" not in msg


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


def test_status_forecast_and_report_of_a_linear_axis_are_in_micrometres(tmp_path, cli250):
    db = tmp_path / "wear.sqlite"
    _store(db)
    res = cli250(["track", "status", "--db", str(db)])
    assert res.returncode == 0, res.stderr
    lines = {ln.split()[0]: ln for ln in res.stdout.splitlines() if ln.strip().startswith(("L1/Z", "M01/X"))}
    # a fleet of both kinds: each cell carries its unit (was "0.06 | 0.10" under "[mrad]")
    assert "δ now  " in res.stdout and "[mrad]" not in res.stdout and "[µm]" not in res.stdout
    assert "59.95 µm" in lines["L1/Z"] and "100.00 µm" in lines["L1/Z"] and "jump" in lines["L1/Z"]
    assert "192.0" in lines["M01/X"] and "mrad" in lines["M01/X"]
    assert "alarm jump: L1/Z: sudden backlash increase of 40.11 µm at 2026-11-24 UTC" in res.stdout
    res = cli250(["track", "forecast", "L1/Z", "--db", str(db)])
    assert res.returncode == 0, res.stderr
    assert "threshold 100.000 µm; fitted now 59.951 µm (noise 0.040 µm); model: linear" in res.stdout
    assert "jump of +40.11 µm at 2026-11-24 08:00 UTC" in res.stdout and "forecast crossing" not in res.stdout
    doc = json.loads(cli250(["track", "forecast", "L1/Z", "--db", str(db), "--json", "-"]).stdout)
    assert doc["axis_kind"] == "prismatic" and doc["si_unit"] == "m" and doc["threshold_rad"] == 100e-6
    assert doc["params_units"].startswith("a, J* [m]; b, v [m/day]")
    # negative control: the rotary axis's forecast is in mrad, its JSON in rad
    res = cli250(["track", "forecast", "M01/X", "--db", str(db)])
    assert "threshold 200.000 mrad; fitted now" in res.stdout
    rdoc = json.loads(cli250(["track", "forecast", "M01/X", "--db", str(db), "--json", "-"]).stdout)
    assert rdoc["axis_kind"] == "rotary" and rdoc["params_units"].startswith("a, J* [rad]; b, v [rad/day]")


def test_a_fleet_of_linear_axes_has_micrometres_in_the_headers_and_the_report(tmp_path, cli250):
    from drivelash.commands.track import run_status, status_table
    from drivelash.report.fleet import OVERVIEW_HEADER, overview_header, render_fleet_report

    db = tmp_path / "wear.sqlite"
    _store(db, rotary=False)
    summ = run_status(str(db), quiet=True)
    assert overview_header(summ)[1:3] == ["δ now [µm]", "threshold [µm]"]
    _, legend = status_table(summ, "t", 60)
    assert legend is not None and legend.startswith("δ now, thresh.: µm;")
    html = render_fleet_report(summ, {}, title="t", store="s")
    assert "threshold [µm]" in html and "[mrad]" not in html.split("<svg")[0].split("<img")[0]
    assert "1.25 µm on a linear axis" in html
    # the figure's axis and legend: draw it and read them back
    import matplotlib

    from drivelash.report.fleet import _axis_figure

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure()
    _axis_figure(summ[0], []).draw(fig)
    ax = fig.axes[0]
    assert ax.get_ylabel() == "lost motion δ [µm]"
    labels = ax.get_legend_handles_labels()[1]
    assert "threshold 100.0 µm" in labels
    assert max(ax.get_ylim()) > 60  # plotted in µm (was 0.06 on a "mrad" axis)
    plt.close(fig)
    # negative control: a rotary fleet keeps the "[mrad]" headers
    db2 = tmp_path / "rot.sqlite"
    with Store(db2) as st:
        st.commit_batch(
            [_estimate("M01/X", i, 0.186 + 1e-3 * i, 1e-4) for i in range(6)],
            st.upsert_axes([_Axis("M01/X", 0.2, "rotary")]),
        )
    assert overview_header(run_status(str(db2), quiet=True)) == OVERVIEW_HEADER


def test_a_store_of_revision_0003_keeps_working_and_reads_its_axes_as_rotary(tmp_path):
    from .conftest import old_store

    db = old_store(
        tmp_path / "old.sqlite",
        "0003",
        "INSERT INTO axis (name, machine, threshold_rad, horizon_days, not_excited_alarm, updated_at) "
        "VALUES ('M01/X', 'M01', 0.2, 30, 5, '2026-01-01 00:00:00')",
    )
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


def test_iso230_takes_a_linear_axis_estimate_from_the_store_in_metres(tmp_path):
    """The session's last read: ``iso230 --db`` built the store's estimate without the axis kind,
    so a linear axis's δ (m at the table) was taken as rotary (then refused without a
    [transmission], or multiplied by its lead/2π). Negative control: the rotary axis stays rotary."""
    from drivelash.iso230.history import deadzone_from_store

    db = tmp_path / "w.sqlite"
    _store(db)
    with Store(db) as st:
        lin = deadzone_from_store(st, "L1/Z", T0 + timedelta(days=10))
        rot = deadzone_from_store(st, "M01/X", T0 + timedelta(days=10))
    assert lin is not None and lin.axis == "prismatic" and lin.delta == pytest.approx(59.95e-6)
    assert rot is not None and rot.axis == "rotary"
