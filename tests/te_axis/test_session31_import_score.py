"""Session 31, tester D: `te import` advice and checks, `te score` pairing, CNC table headers.

The synthetic axis of :mod:`.synth` (known TE, exact kinematics, 1 m travel) is spoilt the way
a real CNC trace is; no fit is needed.
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from drivelash.te.protocol.plausibility import check_runs

from .synth import BENCH, Run, record, standard_runs

SHORT = {"lo": 0.05, "hi": 0.45}


def _records(runs=None):
    runs = runs if runs is not None else [dataclasses.replace(r, **SHORT) for r in standard_runs()]
    return [record(r, f"run{i:02d}.csv") for i, r in enumerate(runs)]


def _check(recs, **kw):
    kw.setdefault("max_load", 3000.0)
    return check_runs(recs, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, source="axis.toml", **kw)


def _found(rep, check):
    return [f for f in rep.findings if f.check == check]


# --- D1: the zero advice names the motor column; a scale outside the axis's frame is refused ----------


def _shift(recs, dx):
    """Scale and motor moved together by dx [m] (TE unchanged)."""
    return [dataclasses.replace(r, x_T=r.x_T + dx, theta_m=r.theta_m + dx / BENCH.r_eff) for r in recs]


def _motor_zero(recs, theta0):
    return [dataclasses.replace(r, theta_m=r.theta_m + theta0) for r in recs]


def test_zero_advice_shifts_the_motor_column_and_following_it_imports():
    """Before: "set offset = 3.82086 (m) on the x_T column" — the scale (the tables' machine
    coordinates) moved by metres. The advice is now an offset on theta_m [rad]; applied, the
    campaign imports with x_T where the scale recorded it."""
    recs = _motor_zero(_records(), 1000.3)  # raw multi-turn counts: arbitrary motor zero
    rep = _check(recs)
    f = _found(rep, "zero")[0]
    assert f.level == "error" and "x_T column" not in f.message
    m = re.search(r"set offset = (-?\d+\.\d+) \(rad\) on the theta_m column", f.message)
    assert m, f.message
    off = float(m.group(1))
    assert off == pytest.approx(-1000.3, abs=0.05)
    fixed = _check([dataclasses.replace(r, theta_m=r.theta_m + off) for r in recs])
    assert fixed.errors == [] and not _found(fixed, "zero") and not _found(fixed, "frame")
    assert min(i["range_m"][0] for i in fixed.runs) == pytest.approx(0.05, abs=1e-3)


def test_zero_advice_adds_to_an_offset_already_on_theta_m():
    recs = _motor_zero(_records(), 1000.3)
    f = _found(_check(recs, column_offsets={"theta_m": 2.0}), "zero")[0]
    m = re.search(r"set offset = (-?\d+\.\d+) \(rad\) \(now 2\) on the theta_m column", f.message)
    assert m and float(m.group(1)) == pytest.approx(2.0 - 1000.3, abs=0.05), f.message


def test_x_t_moved_beyond_the_travel_by_an_offset_is_refused():
    """Following the old advice: x_T + 3.82 m on the 1 m axis (motor and scale agree again) was
    accepted with no finding; now a frame error naming the x_T offset."""
    recs = _shift(_records(), 3.82)
    rep = _check(recs, column_offsets={"x_T": 3.82})
    f = _found(rep, "frame")
    assert len(f) == 1 and f[0].level == "error", [x.line() for x in rep.findings]
    assert "3.87 … 4.27 m" in f[0].message and "offset = 3.82 (m) on the x_T column" in f[0].message
    assert "theta_m" in f[0].message


def test_x_t_just_beyond_the_travel_is_a_warning_and_inside_nothing():
    shift = 1.2  # 1.25 … 1.65 m on a 1 m axis: odd, not impossible (machine zero off the travel)
    recs = _shift(_records(), shift)
    rep = _check(recs)
    f = _found(rep, "frame")
    assert len(f) == 1 and f[0].level == "warning" and rep.errors == []
    # negative controls: the clean campaign, and negative machine coordinates within the travel
    assert not _found(_check(_records()), "frame")
    rep = _check(_shift(_records(), -0.9))
    assert not _found(rep, "frame") and rep.errors == []


def test_a_scale_out_of_its_frame_still_gets_the_x_t_advice():
    """The scale itself shifted (zero_mm) and out of the frame: the x_T offset is the fix."""
    runs = [dataclasses.replace(r, **SHORT, zero_mm=1234.5) for r in standard_runs()]
    f = _found(_check(_records(runs)), "zero")[0]
    # the zero of all runs (1234.5 mm), not the first run's median (-1.23448 m before session 36)
    assert "offset = -1.2345 (m)" in f.message and "on the x_T column" in f.message


# --- D4: a run that reverses inside ---------------------------------------------------------------------


def _out_and_back(F=1000.0):
    fwd = record(Run("load", 1, F, 0.1, **SHORT))
    back = record(Run("load", -1, F, 0.1, **SHORT))
    t = np.concatenate([fwd.t, back.t + fwd.t[-1] + 1e-3])
    cat = {k: np.concatenate([getattr(fwd, k), getattr(back, k)]) for k in ("x_T", "theta_m", "torque_m")}
    return dataclasses.replace(fwd, label="outback.csv", t=t, **cat)


def test_out_and_back_run_is_named_as_such_not_as_torque_sign():
    """Before: "mean motor torque -2.25e-06 N·m opposes the motion … set scale = -1 on the
    torque_m column" (+ mixed-zero); the advice broke every other run."""
    recs = _records()
    recs[4] = _out_and_back(recs[4].load)  # the +1 1000 N pass recorded out and back
    rep = _check(recs)
    f = [x for x in rep.findings if x.file == "outback.csv"]
    assert len(f) == 1 and f[0].check == "reversal" and f[0].level == "error", [x.line() for x in f]
    assert "reverses at 450.0 mm" in f[0].message and "split the file" in f[0].message
    assert not _found(rep, "torque")
    assert not _found(_check(_records()), "reversal")  # negative control: one-way passes


# --- D3: passes of one direction imported for te score --------------------------------------------------


def test_for_score_accepts_passes_of_one_direction():
    """Before: "no load run in direction -1" was an error with --for-score too."""
    runs = [Run("load", 1, F, v, **SHORT) for F, v in ((1000.0, 0.05), (2500.0, 0.1))]
    rep = _check(_records(runs), for_score=True)
    assert rep.errors == [], [f.line() for f in rep.errors]
    one = "no pass in direction -1: only the other direction is scored"
    assert any(one in f.message for f in rep.warnings)
    assert not any("direction -1" in f.message and "geometric" in f.message for f in rep.warnings)
    # negative control: a fit campaign still needs both directions
    assert any("no load run in direction -1" in f.message for f in _check(_records(runs)).errors)


# --- D8, D9: te score pairs by velocity within a tolerance; max load from the imports ------------------


def _score_dirs(tmp_path, capsys, max_load="2000"):
    """Passes of the synthetic axis without `velocity` in [[runs]] (measured at import): the
    compensated recording runs 1e-4 faster (the TE slope a compensation removes, scale noise)."""
    from cli_runner import run_in_process

    from .synth import write_axis

    gains = "[gains]\nK_v = 230.0\nK_p = 15.7\nT_n = 0.003\ntorque_limit = 100.0\n"
    passes = [(1, 0.1, 1000.0), (1, 0.2, 2500.0), (-1, 0.1, 1000.0)]
    dirs = []
    for tag, k in (("unc", 1.0), ("comp", 1.0 + 1e-4)):
        runs = [Run("load", d, F, v * k, **SHORT) for d, v, F in passes]
        axis = write_axis(tmp_path / f"rec_{tag}", runs, gains)
        listed = axis.read_text().splitlines()
        axis.write_text("\n".join(ln for ln in listed if not ln.startswith("velocity")))
        amp = 5e-3 if tag == "unc" else 1e-3  # path error on the scale [mm]: 5 µm, compensated 1 µm
        for f in axis.parent.glob("*.csv"):
            head, *rows = f.read_text().splitlines()
            cells = [r.split(",") for r in rows]
            for c in cells:
                x = float(c[2])
                c[2] = f"{x + amp * np.sin(2 * np.pi * x / (BENCH.tooth_pitch * 1e3)):.9f}"
            f.write_text("\n".join([head, *(",".join(c) for c in cells)]) + "\n")
        out = tmp_path / f"c_{tag}"
        code, so, err = run_in_process(
            ["te", "import", str(axis), "-o", str(out), "--for-score", "--max-load", max_load], capsys
        )
        assert code == 0, err
        dirs.append(out)
        summary = so
    return dirs, summary


def test_score_pairs_measured_velocities_and_splits_by_the_imports_max_load(tmp_path, capsys):
    """Before: paired to 1e-9 — "no compensated run with direction +1, 50 mm/s, 1000 N" for
    passes measured at 50.000 and 50.005 mm/s; the 2500 N pass above the import's 2000 N
    counted as in range unless --max-load was given again."""
    import json

    from cli_runner import run_in_process

    (unc, comp), summary = _score_dirs(tmp_path, capsys)
    assert re.search(r"velocities 100, 200 mm/s", summary), summary  # distinct, not "50, 50, 100"
    code, out, err = run_in_process(
        ["te", "score", "--uncompensated", str(unc), "--compensated", str(comp), "-o", str(tmp_path / "s"),
         "--gains", "axis"], capsys,
    )  # fmt: skip
    assert code == 0, err
    doc = json.loads((tmp_path / "s" / "score.json").read_text())
    assert doc["unmatched"] == [] and len(doc["passes"]["pass_averages"]) == 3, doc["unmatched"]
    assert "no compensated run" not in out
    assert doc["train_max_load"] == 2000.0 and doc["passes"]["mean_beyond_range"] is not None, out
    assert "in range (<= 2000 N, the imports' max load)" in out and "beyond it" in out, out
    assert "F=2500 N" in out and "(beyond the training load)" in out


def test_pairing_tolerance_negative_control():
    """Another commanded speed (2 % off, beyond the 1 % tolerance) or another load is not paired."""
    from types import SimpleNamespace as R

    from drivelash.te.protocol.score import _partner

    ru = R(direction=1, load=1000.0, velocity=0.05)
    near = R(direction=1, load=1000.0, velocity=0.050005)
    assert _partner(ru, [R(direction=1, load=1000.0, velocity=0.051), near], 0.01) is near
    assert _partner(ru, [R(direction=1, load=1000.0, velocity=0.051)], 0.01) is None
    assert _partner(ru, [R(direction=1, load=2000.0, velocity=0.05)], 0.01) is None
    assert _partner(ru, [R(direction=-1, load=1000.0, velocity=0.05)], 0.01) is None


# --- D10: the constant part of the TE; D5: the tables hold the backlash -------------------------------


def test_constant_part_of_the_te_is_warned_with_the_motor_offset():
    """Before: a 0.45 mm zero between raw motor counts and the scale passed silently (run limit 0.5 mm)."""
    theta0 = 0.45e-3 / BENCH.r_eff  # motor zero 0.45 mm at the table off the scale's
    rep = _check(_motor_zero(_records(), theta0))
    f = [x for x in rep.warnings if "constant part" in x.message]
    assert len(f) == 1 and rep.errors == [], [x.line() for x in rep.findings]
    assert rep.constant_te == pytest.approx(-0.45e-3, abs=5e-6)
    m = re.search(r"add ([-+]\d+\.\d+) rad to the offset of the theta_m column", f[0].message)
    assert m and float(m.group(1)) == pytest.approx(-theta0, rel=0.02), f[0].message
    # negative control: the clean synthetic axis (±20 µm backlash per direction, runout 25 µm)
    clean = _check(_records())
    assert not [x for x in clean.warnings if "constant part" in x.message]
    assert abs(clean.constant_te) < 10e-6


class _Linear:
    """No-load curves TE+ = 1 µm + 1 µm/mm·(x − 100 mm), TE− = 21 µm + 3 µm/mm·(x − 100 mm)."""

    def geometric_range(self):
        return 0.100, 0.104

    def geometric(self, x, direction):
        u = np.clip(np.asarray(x, dtype=float), 0.100, 0.104) - 0.100
        return 1e-6 + 1e-3 * u if direction > 0 else 21e-6 + 3e-3 * u


def test_cnc_headers_say_the_backlash_is_in_them_and_give_the_constant_part(tmp_path):
    """Before: neither layout named the control's own backlash compensation (double compensation)
    nor the table's constant part."""
    from drivelash.te.runtime.cnc import geometric_table, write_heidenhain, write_sinumerik

    tab = geometric_table(_Linear(), step=1e-3)
    ini = write_sinumerik(tab, tmp_path / "a.ini").read_text()
    com = write_heidenhain(tab, tmp_path / "x.com").read_text()
    head = [ln for ln in ini.splitlines() if ln.startswith(";")]
    b = "20.000 ... 28.000 um"
    assert any("MD32450 $MA_BACKLASH[0]" in ln and b in ln and "= 0" in ln for ln in head)
    assert any("constant part" in ln and "+15.000 um" in ln for ln in head)
    tail = com.split("[END]")[1]
    assert "MP710" in tail and "backLash" in tail and "20.000 ... 28.000 um" in tail and "+15.000 um" in tail


# --- D2: identified K_p, T_n are reported as weakly determined --------------------------------------


def test_identified_velocity_loop_gains_are_weakly_determined():
    """Before: "K_p 54.13 N*m*s/rad, T_n 8.688 ms" with a 2 % σ for the drive's 15.7 and 3.05 ms."""
    from drivelash.commands.te_score import format_score
    from drivelash.control.path_error import predict_path_error
    from drivelash.params import CascadeGains
    from drivelash.te.protocol.score import identify_loop_gains

    true = CascadeGains(K_v=231.0, K_p=15.7, T_n=0.00305, torque_limit=60.0)
    t = np.arange(0.0, 2.0, 1e-3)
    te = 5e-6 * np.sin(2 * np.pi * 7.5 * t) + 20e-6 * np.sin(2 * np.pi * 0.4 * t)
    m = t > 0.2
    e = predict_path_error(te, t, 0.0068, true)[m]
    g, info = identify_loop_gains([{"t": t, "te": te, "mask": m, "e": e}], 0.0068, None, detrend=False)
    assert g.K_v == pytest.approx(231.0, rel=0.05)
    assert info["relative_std"]["K_p"] is None and info["relative_std"]["T_n"] is None
    assert info["weakly_determined"] == ["K_p", "T_n"] and "weakly determined" in info["note"]
    res = {"set_position": ["recorded"], "unmatched": [], "warnings": [],
           "passes": {"average_improvement": 0.8, "pass_averages": []},
           "gains": {"source": "identified", "used": {"K_v": 231.0, "K_p": 54.1, "T_n": 0.0087}}}  # fmt: skip
    line = [ln for ln in format_score(res).splitlines() if ln.startswith("eq. (3)")][0]
    assert "K_v identified; K_p, T_n weakly determined" in line
    res["gains"]["source"] = "axis file"  # negative control: the axis file's gains are stated as such
    assert "weakly" not in format_score(res)
