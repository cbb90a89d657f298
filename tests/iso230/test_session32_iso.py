"""Session 32, exploratory tester E (ISO 230-2): slow settling, unit slips, pendulum dwells.

- E1: a slowly settling axis — the averaging windows held a still-moving reading and B̄ came
  out with a tight interval excluding the settled value; now T_settle is lengthened (said in a
  warning) or the measurement refused when the dwells are too short.
- E2: ``T_dwell_min`` equal to the sum of the skips was refused by float round-off.
- E3: a deviation column in µm declared as mm was taken 1000× large without a word.
- E4: a pendulum cycle dwelling at its turn-arounds was refused even with nominal targets.
- E5: ``unit = "in"`` (inch) was unknown.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from drivelash.errors import DataError, ParameterError
from drivelash.io import Trace
from drivelash.io.config import ColumnMap
from drivelash.iso230 import approaches_from_rows, evaluate
from drivelash.iso230.dwell import DwellParams
from drivelash.iso230.inputs import Iso230Params, read_measurement
from drivelash.iso230.synthetic import SyntheticAxis, synthetic_recording, synthetic_table

MAP_TS = {
    "t": {"column": "t", "unit": "s"},
    "cmd": {"column": "P_cmd", "unit": "mm"},
    "laser": {"column": "P_actual", "unit": "mm"},
}


def _recording_csv(tmp_path, name, **kw):
    cols, truth = synthetic_recording(SyntheticAxis(), m=6, n=5, seed=4, drift=0.0, **kw)
    p = tmp_path / f"{name}.csv"
    Trace({"t": cols["t"], "cmd": cols["P_cmd"] * 1e3, "laser": cols["P_actual"] * 1e3}).to_csv(p)
    ref = evaluate(approaches_from_rows(truth["P_target"], truth["run"], truth["direction"], truth["x_dev"]))
    return p, ref


# ------------------------------------------------------------------------------------------ E1
def test_slow_settling_axis_is_settled_later_and_says_so(tmp_path):
    """A 20 rad/s servo leaves the reading moving through the default window (0.25 s skip):
    B̄ read −43.3 µm [−43.7, −42.9] for a settled −12.5; now T_settle is lengthened, a warning
    names the target and the T_settle used, and B̄ agrees with the settled truth."""
    p, ref = _recording_csv(tmp_path, "slow", omega_servo=20.0)
    m = read_measurement(p, MAP_TS)
    res = evaluate(m.approaches)
    note = [w for w in m.warnings if "still moves inside the averaging windows" in w]
    assert len(note) == 1 and "evaluated with T_settle = " in note[0] and "target " in note[0], m.warnings
    lo, hi = res.B_mean_interval
    assert lo <= ref.B_mean <= hi, (res.B_mean, ref.B_mean)
    assert res.B_mean == pytest.approx(ref.B_mean, abs=0.2e-6)


def test_slow_settling_axis_with_short_dwells_is_refused(tmp_path):
    """0.6 s dwells leave no T_settle that settles a 20 rad/s servo: refused (B̄ read −85 µm)."""
    p, _ = _recording_csv(tmp_path, "short", omega_servo=20.0, dwell=0.6)
    with pytest.raises(DataError, match=r"still moves inside the averaging windows .*record longer dwells"):
        read_measurement(p, MAP_TS)


def test_settled_recording_unchanged_and_no_settling_warning(tmp_path):
    """Negative control: the standard 60 rad/s servo (the demo's) gives no settling warning and
    the deviations of the configured windows, bit for bit."""
    from drivelash.iso230.dwell import detect_dwells

    cols, _ = synthetic_recording(SyntheticAxis(), m=6, n=5, seed=4)
    p = tmp_path / "ok.csv"
    Trace({"t": cols["t"], "cmd": cols["P_cmd"] * 1e3, "laser": cols["P_actual"] * 1e3}).to_csv(p)
    m = read_measurement(p, MAP_TS)
    assert not any("still moves" in w for w in m.warnings), m.warnings
    t = np.asarray(m.series["t"])
    d = detect_dwells(t, m.series["P_cmd"], m.series["P_actual"])
    np.testing.assert_array_equal(m.dwells.deviation, d.deviation)


# ------------------------------------------------------------------------------------------ E2
def test_dwell_min_equal_to_the_sum_of_the_skips_is_accepted():
    p = DwellParams(T_dwell_min=0.95, T_settle=0.8)  # 0.8 + 0.05 + 0.1 = 0.9500000000000001
    assert p.T_dwell_min == 0.95
    with pytest.raises(ParameterError, match="T_dwell_min"):
        DwellParams(T_dwell_min=0.94, T_settle=0.8)


# ------------------------------------------------------------------------------------------ E3
def _table_csv(tmp_path, name, x_dev_um, travel_mm=500.0):
    tb = synthetic_table(SyntheticAxis(travel=travel_mm * 1e-3), m=11, n=5, seed=2)
    x = tb["x_dev"] if x_dev_um is None else x_dev_um(tb)
    df = pd.DataFrame(
        {"Target [mm]": tb["P_target"] * 1e3, "Run": tb["run"], "Dir": tb["direction"], "Error [um]": x * 1e6}
    )
    p = tmp_path / f"{name}.csv"
    df.to_csv(p, index=False)
    return p


def _table_map(dev_unit):
    return {
        "Target [mm]": {"column": "P_target", "unit": "mm"},
        "Run": {"column": "run"},
        "Dir": {"column": "direction"},
        "Error [um]": {"column": "x_dev", "unit": dev_unit},
    }


def test_deviations_in_um_declared_as_mm_are_warned(tmp_path):
    """A good 500 mm axis (2 µm/m lead error, 0.25 µm scatter: spread 4.9 µm) declared in mm read
    B = 2241 µm silently (0.98 % of the travel, under the 1 % refusal); now a warning names file,
    column and the slip. Declared right: no warning."""

    def good(tb):
        rng = np.random.default_rng(5)
        return 2e-6 * tb["P_target"] - tb["direction"] * 1e-6 + rng.normal(0, 0.25e-6, tb["run"].size)

    p = _table_csv(tmp_path, "good_axis", good)
    wrong = read_measurement(p, _table_map("mm"))
    w = [x for x in wrong.warnings if "µm declared as mm" in x]
    assert len(w) == 1 and "good_axis.csv" in w[0] and "'Error [um]'" in w[0], wrong.warnings
    right = read_measurement(p, _table_map("um"))
    assert not any("declared as" in x for x in right.warnings), right.warnings


def test_large_genuine_deviations_of_a_short_axis_are_not_warned(tmp_path):
    """Negative control: PSI ecmc's mcu1025 stage spreads 0.13 mm over 40.8 mm of travel (3.2e-3
    of it) and is genuine: no slip warning (the bound is 0.5 mm and 0.1 % of the travel)."""

    def large(tb):
        return 130e-6 * tb["P_target"] / np.ptp(tb["P_target"]) - tb["direction"] * 5e-6

    p = _table_csv(tmp_path, "psi_like", large, travel_mm=40.8)
    m = read_measurement(p, _table_map("um"))
    assert not any("declared as" in x for x in m.warnings), m.warnings


# ------------------------------------------------------------------------------------------ E4
DELTA = 12e-6
TARGETS = np.array([0.0, 0.0183, 0.041, 0.0597, 0.0812, 0.1])


def _pendulum_csv(tmp_path, name, turn_dwell):
    """Pendulum cycle: at each target 5 × (from 5 mm below, dwell, 5 mm past, back, dwell), with
    ``turn_dwell`` [s] at the turn-arounds; load = play of width DELTA behind the command."""
    stops = [(TARGETS[0] - 0.005, 1.0)]
    for P in TARGETS:
        for _ in range(5):
            stops += [(P - 0.005, turn_dwell), (P, 1.0), (P + 0.005, turn_dwell), (P, 1.0)]
    stops.append((TARGETS[-1] + 0.005, 1.0))
    T_s, v = 1e-3, 0.05
    cmd = [np.full(int(round(stops[0][1] / T_s)), stops[0][0])]
    for (a, _), (b, dw) in zip(stops[:-1], stops[1:], strict=True):
        k = max(2, int(round(abs(b - a) / v / T_s)))
        cmd += [np.linspace(a, b, k + 1)[1:], np.full(int(round(dw / T_s)), b)]
    P_cmd = np.concatenate(cmd)
    load = np.empty_like(P_cmd)
    x = P_cmd[0] - DELTA / 2
    for i, c in enumerate(P_cmd):
        x = min(max(x, c - DELTA / 2), c + DELTA / 2)
        load[i] = x
    rng = np.random.default_rng(1)
    laser = load + 3e-6 * np.sin(P_cmd / 0.02) + rng.normal(0, 0.05e-6, P_cmd.size)
    p = tmp_path / f"{name}.csv"
    Trace({"t": np.arange(P_cmd.size) * T_s, "cmd": P_cmd * 1e3, "laser": laser * 1e3}).to_csv(p)
    return p


def test_pendulum_cycle_with_dwells_at_the_turn_arounds(tmp_path):
    """With nominal targets the turn-around dwells are skipped (one warning) and B̄ = −δ as for
    the same cycle with short turn-arounds; without them the refusal asks for the targets."""
    nominal = Iso230Params(targets=tuple(TARGETS))
    short = evaluate(read_measurement(_pendulum_csv(tmp_path, "short", 0.1), MAP_TS).approaches)
    p = _pendulum_csv(tmp_path, "dwell", 1.0)
    m = read_measurement(p, MAP_TS, params=nominal)
    res = evaluate(m.approaches)
    assert sum("turn-arounds), skipped" in w for w in m.warnings) == 1, m.warnings
    assert res.B_mean == pytest.approx(-DELTA, abs=0.05e-6)
    assert res.B_mean == pytest.approx(short.B_mean, abs=0.05e-6)
    with pytest.raises(DataError, match=r"give the nominal \[iso230\] targets"):
        read_measurement(p, MAP_TS)


# ------------------------------------------------------------------------------------------ E5
def test_inch_unit(tmp_path):
    """A table in inches reads like the same table in mm (1 in = 25.4 mm)."""
    assert ColumnMap(column="P_target", unit="in").unit == "in"
    tb = synthetic_table(SyntheticAxis(), m=6, n=5, seed=3)
    p = tmp_path / "inch.csv"
    pd.DataFrame(
        {
            "T": tb["P_target"] / 0.0254,
            "run": tb["run"],
            "direction": tb["direction"],
            "e": tb["x_dev"] / 0.0254,
        }
    ).to_csv(p, index=False)
    m = read_measurement(
        p, {"T": {"column": "P_target", "unit": "in"}, "e": {"column": "x_dev", "unit": "in"}}
    )
    ref = evaluate(approaches_from_rows(tb["P_target"], tb["run"], tb["direction"], tb["x_dev"]))
    assert evaluate(m.approaches).B_mean == pytest.approx(ref.B_mean, rel=1e-9)
