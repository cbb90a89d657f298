"""Two-mass identification of a linear (prismatic) axis in SI units (session 34, tester G, G1).

A linear axis recorded in m, m/s and N came out with every parameter "not determined" (all 5614
windows "in the gap", "deflection below what the recording resolves" for a 24 µm deflection =
240 encoder counts), while the same samples declared ×1000 as rad identified within 0.5 % of the
truth. Cause: the contact grid's linear solves (:func:`grid_start`) are regularised by 1e-12 of
the *mean* diagonal of their Gram matrices, which the force column (~90 N) dominates — on an axis
whose Δθ spans 5e-5 m the contact columns (~1e-5 m per window) fell below that ridge, and the grid
chose contacts as if the shaft carried no force. The grid now measures a linear axis's lengths in
mm (:func:`grid_length_scale`), the numbers its ridge was validated at on rotary axes in rad.
"""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from drivelash.estimation.identify_result import UNITS
from drivelash.estimation.identify_two_mass import identify_two_mass
from drivelash.io.trace import Trace
from identify.linear_axis import TRUTH, as_rotary, linear_axis_trace

#: Length scale of the "×1000 as rad" copy.
K = 1e3
#: How each parameter scales when lengths are multiplied by K (forces unchanged): F = m ẍ, F = k x,
#: F = d ẋ, F = β ẋ — masses, stiffness and damping /K; Coulomb friction and offset ×1; gap ×K.
SCALE = {
    "J_m": 1 / K, "J_l": 1 / K, "K_S": 1 / K, "D_S": 1 / K, "beta_m": 1 / K, "beta_l": 1 / K,
    "T_Cm": 1.0, "T_Cl": 1.0, "torque_offset": 1.0, "delta": K, "delta1": K,
}  # fmt: skip


@pytest.fixture(scope="module")
def linear():
    """2 s at 8 kHz, a ±10 mm 1.5 Hz sine through a 20 µm gap (8 crossings); its identification in
    SI and that of the same samples ×1000 declared as rad."""
    tr = linear_axis_trace(20e-6, 10e-6, duration=2.0, freq=1.5)
    return tr, identify_two_mass(tr, 1.0), identify_two_mass(as_rotary(tr, K), 1.0)


def test_linear_axis_in_si_identifies_like_the_same_data_declared_as_rad(linear):
    """Same physics in another unit, same result: every value and interval bound of the SI fit,
    scaled as physics says, equals the ×1000-as-rad fit's to 1e-6 relative (measured: ≤ 2e-8 on
    the tester's lin20 / lin28 / lin50 recordings; the fit is the same least-squares problem in
    other units, so only rounding differs). Before the fix: J_m, J_l, K_S, δ, δ1 not determined."""
    _, si, rad = linear
    assert si.backlash_visible and rad.backlash_visible, si.verdict
    for n, q in rad.parameters.items():
        p = si.parameters[n]
        assert p.identifiable and q.identifiable, (n, p.reason)
        tol = 1e-6 * max(abs(q.high - q.low), abs(q.value))
        for a, b in ((p.value, q.value), (p.low, q.low), (p.high, q.high)):
            assert math.isclose(a * SCALE[n], b, rel_tol=0.0, abs_tol=tol), (n, a * SCALE[n], b)


def test_linear_axis_in_si_recovers_the_truth(linear):
    """Masses, stiffness, gap and flank in SI: the truth inside each 95 % interval, and within
    2 % (J_m, J_l), 1 % (K_S) and 0.5 % (δ, δ1). Measured on this 2 s recording: J_m −0.7 %,
    J_l +0.1 %, K_S +0.3 %, δ +0.10 %, δ1 +0.11 %."""
    _, si, _ = linear
    truth = {**TRUTH, "delta": 20e-6, "delta1": 10e-6}
    limits = {"J_m": 0.02, "J_l": 0.02, "K_S": 0.01, "delta": 0.005, "delta1": 0.005}
    for n, lim in limits.items():
        p = si[n]
        assert p.covers(truth[n]), (n, p.value, p.interval_text())
        assert abs(p.value / truth[n] - 1.0) <= lim, (n, p.value)


#: Rotary unit labels that must not appear on a linear axis (the masses were "kg·m²", the reasons
#: "rad" and "mrad"; G1's secondary finding).
ROTARY_LABELS = ("kg·m²", "N·m", "/rad", "mrad")


def test_linear_axis_results_are_labelled_in_kg_n_per_m_and_micrometres(linear):
    """The parameter units (table, JSON ``unit``), the TOML comments and the JSON summary of a
    prismatic trace say kg, N/m, N·s/m, N and m (δ also in µm), with a comment that the keys keep
    their rotary names; nothing says kg·m², N·m, N·m/rad or mrad. The ×1000-as-rad copy of the same
    samples keeps its rotary labels. Before: every unit the rotary one on both."""
    _, si, rad = linear
    units = {n: q.unit for n, q in si.parameters.items()}
    assert units == {
        "J_m": "kg", "J_l": "kg", "K_S": "N/m", "D_S": "N·s/m", "T_Cm": "N", "beta_m": "N·s/m",
        "T_Cl": "N", "beta_l": "N·s/m", "torque_offset": "N", "delta": "m", "delta1": "m",
    }  # fmt: skip
    toml = si.to_toml()
    summary = json.dumps(si.as_dict(), ensure_ascii=False)
    for text in (toml, summary):
        assert not [w for w in ROTARY_LABELS if w in text], [w for w in ROTARY_LABELS if w in text]
    assert "J_m, J_l are masses [kg]" in toml and "K_S [N/m]" in toml
    assert re.search(r"# delta = 2\.00\d+e-05 m \(20\.0\d* µm\)", toml), toml
    assert si.as_dict()["axis"] == "prismatic"
    # negative control: the same physics declared as an angle keeps the rotary units and text
    assert {n: q.unit for n, q in rad.parameters.items()} == {n: UNITS[n] for n in rad.parameters}
    assert rad.axis == "rotary" and "masses" not in rad.to_toml() and "µm" not in rad.to_toml()


def test_linear_axis_reasons_and_totals_speak_in_micrometres_and_newtons(linear):
    """The reasons of a linear axis whose shaft the recording does not resolve are in its units.
    The same recording with the table locked to the carriage (θ_l = θ_m within ±0.1 µm, no gap, no
    deflection): the rigid contact is not rejected, so the motor equation carries the total mass —
    "J_m + J_l/N² = 120.4 [118.8, 122] kg" (truth 20 + 100 kg), the gap "wider than the whole Δθ
    range of the recording (0.2 µm)"; nowhere kg·m², N·m, /rad, mrad or rad. Before:
    "J_m + J_l/N² = … kg·m²", "… rad is wider than … (0.0002 mrad)"."""
    tr, _, _ = linear
    cols = {n: np.asarray(tr[n]).copy() for n in tr.names}
    cols["theta_l"] = cols["theta_m"] + 1e-7 * np.round(np.sin(7.0 * cols["t"]))
    cols["omega_l"] = cols["omega_m"].copy()
    rigid = identify_two_mass(Trace(cols, {"axis": "prismatic"}), 1.0)
    texts = [rigid.verdict, *rigid.warnings, *(q.reason for q in rigid.parameters.values())]
    texts += list(rigid.fit["notes"]) + [rigid.to_toml()]
    found = [(w, t) for t in texts for w in (*ROTARY_LABELS, " rad ", " rad)") if w in t]
    assert not found, found
    total = rigid.fit["motor_side_totals"]["J_m"]
    assert total["unit"] == "kg" and abs(total["value"] / 120.0 - 1.0) < 0.02, total
    assert re.search(r"J_m \+ J_l/N² = [\d.]+ \[[\d.]+, [\d.]+\] kg \(95 %\)", rigid["J_m"].reason)
    assert "Δθ range of the recording (0.2 µm)" in rigid["delta1"].reason, rigid["delta1"].reason


#: The tester's mapping of a linear axis: positions in mm, velocities in mm/s, force in N.
LINEAR_CONFIG = """[drivetrain]
N = 1.0
[columns.time_s]
column = "t"
unit = "s"
[columns.pos_motor_mm]
column = "theta_m"
unit = "mm"
[columns.vel_motor_mm_s]
column = "omega_m"
unit = "mm/s"
[columns.pos_scale_mm]
column = "theta_l"
unit = "mm"
[columns.vel_scale_mm_s]
column = "omega_l"
unit = "mm/s"
[columns.force_N]
column = "torque_m"
unit = "N"
"""


def test_identify_command_on_a_linear_axis_in_mm_writes_kg_and_newtons(linear, tmp_path, capsys):
    """``drivelash identify REC.csv --model two-mass`` on a mm/mm·s⁻¹/N recording (the tester's
    mapping): exit 0, the table's unit column, the TOML comments and the JSON units are kg, N/m,
    N·s/m, N, m; the [drivetrain] table carries the SI values (J_m in kg, K_S in N/m) under the
    rotary keys. Before: exit 0 with every parameter "not determined" in kg·m², N·m/rad, rad."""
    import pandas as pd

    from cli_runner import run_in_process
    from drivelash.io.config import loads_config

    tr, si, _ = linear
    names = {"t": "time_s", "theta_m": "pos_motor_mm", "omega_m": "vel_motor_mm_s", "theta_l": "pos_scale_mm",
             "omega_l": "vel_scale_mm_s", "torque_m": "force_N"}  # fmt: skip
    mm = {c: tr[n] * (1e3 if n[:5] in ("theta", "omega") else 1.0) for n, c in names.items()}
    rec, cfg = tmp_path / "lin.csv", tmp_path / "lin.toml"
    pd.DataFrame(mm).to_csv(rec, index=False, float_format="%.10g")
    cfg.write_text(LINEAR_CONFIG)
    out, js = tmp_path / "id.toml", tmp_path / "id.json"
    r = run_in_process(["identify", str(rec), "--config", str(cfg), "--model", "two-mass", "--out", str(out),
                        "--json", str(js)], capsys)  # fmt: skip
    assert r.returncode == 0, r.stderr
    table = r.stdout + r.stderr
    assert "kg·m²" not in table and "N·m" not in table and "mrad" not in table, table
    assert all(u in table for u in ("│    kg │", "│   N/m │", "│ N·s/m │", "│     N │", "│     m │")), table
    text = out.read_text()
    assert "kg·m²" not in text and "N·m" not in text and "J_m, J_l are masses [kg]" in text
    got = loads_config(text).to_drivetrain_params()
    assert got.J_m == pytest.approx(si["J_m"].value, rel=1e-6) and got.K_S == pytest.approx(2e7, rel=0.01)
    doc = json.loads(js.read_text())
    assert doc["axis"] == "prismatic" and doc["parameters"]["K_S"]["unit"] == "N/m"


def test_rigid_load_side_of_a_linear_axis_is_in_kg_too(linear):
    """The rigid IDIM-LS load side on a linear axis (``[identification] side = "load"``) said
    J_l in kg·m², β_l in N·m·s/rad and T_Cl in N·m while its motor side said kg (found beside G1).
    Measured here: J_l 94.4 kg (truth 100), T_Cl 61.2 N (60)."""
    from drivelash.estimation.identify import identify_load
    from drivelash.estimation.identify_two_mass import rigid_result

    tr, _, _ = linear
    r = rigid_result(identify_load(tr, J_m=20.0, beta_m=50.0, T_Cm=20.0, N=1.0))
    assert {n: q.unit for n, q in r.parameters.items()} == {
        "J_l": "kg", "beta_l": "N·s/m", "T_Cl": "N", "torque_offset": "N"
    }  # fmt: skip
    assert r.axis == "prismatic" and abs(r["J_l"].value / 100.0 - 1.0) < 0.1
