"""ISO 230-2 checks in the wear history: stored once as a second source of the axis, in the same
unit as the recording-based estimates, compared with the estimate nearest in time."""

from __future__ import annotations

import dataclasses
import json
import math
from datetime import datetime
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from drivelash.iso230.synthetic import SyntheticAxis, synthetic_table
from drivelash.wear.store import EstimateRow, Store

LEAD = 0.01  # m per screw revolution
K_MM = LEAD / (2 * math.pi) * 1e3  # mm of travel per rad: the axis transmission in the store
AXIS = SyntheticAxis(delta=12e-6, sigma=0.5e-6)

TABLE_TOML = """
[columns."Target [mm]"]
column = "P_target"
unit = "mm"
[columns.Run]
column = "run"
[columns.Dir]
column = "direction"
[columns."Error [um]"]
column = "x_dev"
unit = "um"
"""


@dataclasses.dataclass(frozen=True)
class _Axis:
    name: str
    drive_path: str = "drive.toml"
    drive_hash: str = "h" * 64
    threshold_rad: float = 0.02
    transmission: float | None = K_MM
    horizon_days: float = 30.0
    not_excited_alarm: int = 5


def laser_files(tmp_path: Path, extra: str = "") -> tuple[Path, Path]:
    """A 9-target × 5-run laser table of :data:`AXIS` (12 µm lost motion) in mm / µm, and its
    config (``extra`` appended, e.g. a ``[transmission]`` table)."""
    tb = synthetic_table(AXIS, m=9, n=5, seed=6)
    csv = tmp_path / "laser.csv"
    pd.DataFrame(
        {
            "Target [mm]": tb["P_target"] * 1e3,
            "Run": tb["run"].astype(int),
            "Dir": tb["direction"].astype(int),
            "Error [um]": tb["x_dev"] * 1e6,
        }
    ).to_csv(csv, index=False)
    toml = tmp_path / "iso.toml"
    toml.write_text(TABLE_TOML + extra, encoding="utf-8")
    return csv, toml


def _estimate(i: int, day: int, delta: float, **kw) -> EstimateRow:
    base = dict(
        axis="M01/X",
        path=f"/rec/{i}.parquet",
        size_bytes=100 + i,
        mtime_ns=10**18 + i,
        content_hash=f"{i:064x}",
        start_time=datetime(2026, 3, day, 6, 0),
        duration_s=8.0,
        sample_rate_hz=8000.0,
        samples=64000,
        method="default",
        code_version="drivelash test",
        config_hash="c" * 64,
        status="ok",
        reason="fine",
        delta=delta,
        delta1_estimate=delta / 2,
        delta_std=0.2e-3,
        excitation_ok=True,
        converged=True,
    )
    base.update(kw)
    return EstimateRow(**base)


@pytest.fixture
def setup(tmp_path) -> tuple[Path, Path, Path]:
    db = tmp_path / "wear.sqlite"
    st = Store(db)
    ids = st.upsert_axes([_Axis("M01/X"), _Axis("M01/Y", transmission=None)])
    d12 = 12e-3 / K_MM  # rad: 12 µm at the load
    st.commit_batch(
        [
            _estimate(1, 1, 0.5 * d12),  # older
            _estimate(2, 9, d12),  # the last excited one before the check (10 March)
            _estimate(3, 9, 3 * d12, excitation_ok=False),  # not excited: never used
            _estimate(4, 20, 2 * d12),  # after the check
        ],
        ids,
    )
    st.close()
    csv, toml = laser_files(tmp_path)
    (tmp_path / "est.json").write_text(json.dumps({"delta": 12e-3 / K_MM, "excitation_ok": True}))
    return db, csv, toml


def test_check_is_stored_and_compared_with_the_history(setup, tmp_path, run_cli):
    db, csv, toml = setup
    j = tmp_path / "o.json"
    argv = ["iso230", str(csv), "-c", str(toml), "--db", str(db), "--axis", "M01/X"]
    code, out, err = run_cli([*argv, "--time", "2026-03-10T09:00", "--json", str(j)])
    assert code == 0, err
    s = json.loads(j.read_text())
    # the deadzone is the excited estimate of 9 March, converted with the store's transmission
    c = s["deadzone_comparison"]
    assert "recording 2.parquet" in c["deadzone_source"]
    assert c["deadzone_at_load"] == pytest.approx(12e-6, rel=1e-9) and c["agree"]
    assert s["time"] == "2026-03-10T09:00:00+00:00" and s["time_from"] == "--time"
    with Store(db, create=False) as st:
        rows = st.measurements("M01/X")
    assert len(rows) == 1
    m = rows[0]
    assert m["source"] == "iso230-2" and m["unit"] == "m"
    assert m["value"] == pytest.approx(s["lost_motion"]["value"], rel=1e-12)
    assert m["value"] == pytest.approx(12e-6, abs=3 * m["std"])
    # in rad on the deadzone's scale, next to the estimates (the store converts with K_MM)
    assert m["value_rad"] == pytest.approx(m["value"] * 1e3 / K_MM, rel=1e-12)
    details = json.loads(m["details"])
    assert details["B"] == pytest.approx(s["axis"]["B"]) and details["targets"] == 9
    assert "stored as measurement" in out
    # the same file again: no second row
    code, _, err = run_cli([*argv, "--time", "2026-03-10T09:00"])
    assert code == 0, err
    with Store(db, create=False) as st:
        assert len(st.measurements("M01/X")) == 1


def test_fleet_report_shows_the_laser_check(setup, tmp_path, run_cli):
    db, csv, toml = setup
    code, _, err = run_cli(["iso230", str(csv), "-c", str(toml), "--db", str(db), "--axis", "M01/X"])
    assert code == 0, err
    html = tmp_path / "fleet.html"
    code, _, err = run_cli(["track", "report", "--db", str(db), "-o", str(html)])
    assert code == 0, err
    text = html.read_text()
    assert "Measurements of other sources" in text and "iso230-2" in text


@pytest.mark.parametrize(
    ("extra", "needle"),
    [
        (["--db", "{db}"], "--db and --axis go together"),
        (["--db", "{db}", "--axis", "M01/Q"], "no axis 'M01/Q'"),
        (["--db", "{tmp}/none.sqlite", "--axis", "M01/X"], "no such store"),
        (["--db", "{db}", "--axis", "M01/X", "--time", "yesterday"], "--time 'yesterday': not an ISO 8601"),
        (["--db", "{db}", "--axis", "M01/Y", "--estimate", "{tmp}/est.json"], "needs a [transmission] table"),
    ],
)
def test_bad_history_options_are_one_line(setup, tmp_path, run_cli, extra, needle):
    db, csv, toml = setup
    j = tmp_path / "o.json"
    extra = [e.format(db=db, tmp=tmp_path) for e in extra]
    code, out, err = run_cli(["iso230", str(csv), "-c", str(toml), "--json", str(j), *extra])
    assert code == 2, (out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("drivelash: error:") and needle in lines[0], err
    assert not j.exists()
    assert not (tmp_path / "none.sqlite").exists()
    with Store(db, create=False) as st:
        assert st.measurements() == []


def test_trend_plot_draws_the_laser_check_beside_the_estimates(setup, run_cli):
    """The axis trend figure of the fleet report draws the stored check as a point with its
    error bar at its time and at its value on the deadzone scale (mrad), the same scale as
    the estimates of the recordings; an axis without a check draws none (negative control)."""
    import matplotlib
    import matplotlib.dates as mdates
    from matplotlib.container import ErrorbarContainer
    from matplotlib.figure import Figure as MplFigure

    from drivelash.report.fleet import _axis_figure
    from drivelash.wear.alarms import fleet_summary

    matplotlib.use("Agg")
    db, csv, toml = setup
    argv = ["iso230", str(csv), "-c", str(toml), "--db", str(db), "--axis", "M01/X"]
    code, _, err = run_cli([*argv, "--time", "2026-03-10T09:00"])
    assert code == 0, err
    with Store(db, create=False) as st:
        summ = {s["axis"]: s for s in fleet_summary(st)}
        meas = st.measurements()
    assert [m["axis"] for m in meas] == ["M01/X"]
    m = meas[0]

    def containers(axis: str) -> tuple[list[ErrorbarContainer], object]:
        fig = MplFigure()
        _axis_figure(summ[axis], [x for x in meas if x["axis"] == axis]).draw(fig)
        ax = fig.axes[0]
        return [c for c in ax.containers if isinstance(c, ErrorbarContainer)], ax

    bars, ax = containers("M01/X")
    assert len(bars) == 1 and bars[0].get_label() == "iso230-2 (laser check)"
    x, y = bars[0].lines[0].get_data()
    assert mdates.date2num(x[0]) == pytest.approx(mdates.date2num(datetime(2026, 3, 10, 9, 0)), abs=1e-6)
    assert y[0] == pytest.approx(1e3 * m["value_rad"], rel=1e-12)
    # on the estimates' scale: 12 µm at the load is 1e3 * 12e-3 / K_MM mrad, where the
    # estimate of 9 March lies; the check agrees with it within 3 standard uncertainties
    d12_mrad = 12.0 / K_MM
    assert y[0] == pytest.approx(d12_mrad, abs=3e3 * m["std_rad"])
    est_y = np.concatenate([ln.get_ydata() for ln in ax.lines if ln.get_marker() == "o"])
    assert np.any(np.isclose(est_y, d12_mrad, rtol=1e-9))
    assert "iso230-2 (laser check)" in [t.get_text() for t in ax.get_legend().get_texts()]
    bars_y, _ = containers("M01/Y")
    assert bars_y == []


@pytest.mark.parametrize(
    ("name", "argv"),
    [
        (
            "wear.json",
            ["iso230", "{csv}", "-c", "{toml}", "--db", "{db}", "--axis", "M01/X"] + ["--json", "{db}"],
        ),
        ("wear.html", ["track", "report", "--db", "{db}", "-o", "{db}"]),
        ("wear.json", ["track", "forecast", "M01/X", "--db", "{db}", "--json", "{db}"]),
    ],
    ids=["iso230", "track-report", "track-forecast"],
)
def test_an_output_over_the_history_store_is_refused_even_with_force(setup, tmp_path, run_cli, name, argv):
    """A store whose file name has an output's extension, given as the output too: with
    ``--force`` the JSON/HTML replaced the whole wear history (the store was no input)."""
    db0, csv, toml = setup
    db = tmp_path / name
    db0.rename(db)
    before = db.read_bytes()
    args = [a.format(csv=csv, toml=toml, db=db) for a in argv]
    opt = args[args.index(str(db), args.index("--db") + 2) - 1]
    code, _, err = run_cli([*args, "--force"])
    assert code == 2 and err.strip().splitlines() == [
        f"drivelash: error: {opt} {db}: is an input of this command; choose another path"
    ]
    assert db.read_bytes() == before


@pytest.mark.parametrize(
    ("extra", "needle"),
    [
        ("[iso230]\ncompensation = 0.010\n", "key 'compensation': 0.01 m is not a plausible"),
        ("[iso230]\ncompensation = 10\n", "if 10 is in µm, write 1e-05"),
        ("[transmission]\nlead = 10\n", "key 'lead': 10 m is not a plausible"),
    ],
)
def test_a_compensation_or_lead_in_mm_is_refused_before_it_reaches_the_history(
    setup, tmp_path, run_cli, extra, needle
):
    """Found by an exploratory tester (s19 F16): `[iso230] compensation = 0.010` (the control's
    10 µm written in mm) was taken as 10 mm of lost motion and stored for good with --db
    (the fleet report's trend then reached 100 000 mrad); `lead = 10` (mm) as 10 m. Now one
    line naming file, table, key and the likely unit, exit 2, nothing stored. On the old code
    the command exits 0 and stores the measurement. Negative control: 10 µm written in m is
    stored, and the printed number is labelled for what it is (−B̄ + compensation, not "−B̄")."""
    db, csv, _ = setup
    _, toml = laser_files(tmp_path, extra)
    j = tmp_path / "o.json"
    argv = ["iso230", str(csv), "-c", str(toml), "--db", str(db), "--axis", "M01/X", "--json", str(j)]
    code, out, err = run_cli(argv)
    assert code == 2, (out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"drivelash: error: {toml}: table ["), err
    assert needle in lines[0] and "Traceback" not in err, err
    assert not j.exists()
    with Store(db, create=False) as st:
        assert st.measurements() == []
    _, toml = laser_files(tmp_path, "[iso230]\ncompensation = 0.000010\n")
    code, out, err = run_cli(argv)
    assert code == 0, err
    assert "lost motion: ISO −B̄ + compensation = " in " ".join(out.split()), out
    with Store(db, create=False) as st:
        (m,) = st.measurements("M01/X")
    assert m["value"] == pytest.approx(22e-6, abs=3 * m["std"])  # 12 µm measured + 10 µm compensated


def test_the_report_shows_every_warning_the_json_gives(setup, tmp_path, run_cli):
    """Found by an exploratory tester (s19 F19): the HTML report of `iso230` showed only the
    reader's warnings; the deadzone's ("did not converge … not a measurement"), the drift's and
    the history's ("stored in m only …", "no excited estimate …") reached the terminal and the
    JSON only. Here M01/Y has no transmission and no estimate: two such warnings; on the old
    code neither is on the page."""
    import html as h

    db, csv, toml = setup
    j, r = tmp_path / "o.json", tmp_path / "o.html"
    argv = ["iso230", str(csv), "-c", str(toml), "--db", str(db), "--axis", "M01/Y"]
    code, _, err = run_cli([*argv, "--json", str(j), "--report", str(r)])
    assert code == 0, err
    warnings = json.loads(j.read_text())["warnings"]
    assert any("stored in m only" in w for w in warnings), warnings
    assert any("no excited estimate" in w for w in warnings), warnings
    page = r.read_text(encoding="utf-8")
    for w in warnings:
        assert f'<div class="warn">{h.escape(w)}</div>' in page, w
