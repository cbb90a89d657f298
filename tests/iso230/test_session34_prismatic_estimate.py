"""``iso230 --estimate`` with an estimate of a linear (prismatic) axis (session 34, tester G, G6).

The estimate of a linear axis is in metres at the table already; it was multiplied by the
``[transmission]`` lead/2π: "deadzone at the load 0.031 µm, E_n = 183 disagree" when both the
laser and the estimator said 20 µm, and without a ``[transmission]`` (a linear motor) the command
refused. The estimate JSON now says ``"axis": "prismatic"`` (G8): it is compared as it is, a
lead given beside it is not applied and a note says so. Negative controls: an estimate JSON
without ``axis`` (written before it existed) and a rotary one are converted by the lead as before.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from drivelash.errors import ConfigError
from drivelash.iso230 import Deadzone, Transmission, approaches_from_rows, compare, evaluate, read_deadzone

LEAD = 0.01  # m per screw revolution (tester G's iso.toml)
DELTA = 19.784e-6  # m: tester G's δ̂ of a 20 µm lost motion
U_DELTA = 0.448e-6


def _laser(path):
    """11 targets × 5 runs, lost motion 20 µm, noise 0.3 µm (tester G's laser.csv)."""
    rng = np.random.default_rng(0)
    lines = ["Target [mm],Run,Dir,Error [um]"]
    for run in range(1, 6):
        for tgt in np.linspace(0, 500, 11):
            for d in (1, -1):
                lines.append(f"{tgt},{run},{d},{float(-d * 10 + 0.01 * tgt + rng.normal(0, 0.3))!r}")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _config(path, lead: bool):
    cols = (
        '[columns."Target [mm]"]\ncolumn = "P_target"\nunit = "mm"\n[columns.Run]\ncolumn = "run"\n'
        '[columns.Dir]\ncolumn = "direction"\n[columns."Error [um]"]\ncolumn = "x_dev"\nunit = "um"\n'
    )
    path.write_text(cols + (f"[transmission]\nlead = {LEAD}\n" if lead else ""), encoding="utf-8")
    return path


def _estimate(path, axis: str | None, converged: bool = True):
    data = {"delta": DELTA, "delta_std": U_DELTA, "excitation_ok": True, "converged": converged}
    if axis is not None:
        data["axis"] = axis
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


@pytest.mark.parametrize("lead", [True, False])
def test_a_prismatic_estimate_is_compared_in_metres(tmp_path, run_cli, lead):
    laser, cfg = _laser(tmp_path / "laser.csv"), _config(tmp_path / "iso.toml", lead)
    est, out = _estimate(tmp_path / "est.json", "prismatic"), tmp_path / "iso.json"
    code, stdout, err = run_cli(
        ["iso230", str(laser), "--config", str(cfg), "--estimate", str(est), "--json", str(out)]
    )
    assert code == 0, err
    c = json.loads(out.read_text(encoding="utf-8"))["deadzone_comparison"]
    assert c["factor"] == 1.0 and c["deadzone_unit"] == "m" and c["deadzone_axis"] == "prismatic"
    assert c["deadzone_at_load"] == DELTA and c["u_deadzone_at_load"] == U_DELTA
    assert c["lost_motion_iso"] == pytest.approx(20e-6, abs=0.2e-6)
    assert c["agree"] and c["E_n"] < 1
    flat = " ".join(stdout.split())
    assert "deadzone at the load 19.784 ± 0.448" in flat and "agree" in flat and "disagree" not in flat
    note = "prismatic axis (δ̂ in m at the table): compared as it is, [transmission] not applied"
    assert (note in " ".join(err.split())) == lead


@pytest.mark.parametrize("axis", [None, "rotary"])
def test_negative_control_an_angle_estimate_is_converted_by_the_lead(tmp_path, run_cli, axis):
    """A JSON without ``axis`` (before session 34) or a rotary one: δ [rad] × lead/2π as before."""
    laser, cfg = _laser(tmp_path / "laser.csv"), _config(tmp_path / "iso.toml", True)
    est, out = _estimate(tmp_path / "est.json", axis), tmp_path / "iso.json"
    argv = ["iso230", str(laser), "--estimate", str(est)]
    code, _, err = run_cli([*argv, "--config", str(cfg), "--json", str(out)])
    assert code == 0, err
    c = json.loads(out.read_text(encoding="utf-8"))["deadzone_comparison"]
    assert c["factor"] == pytest.approx(LEAD / (2 * math.pi), rel=1e-15)
    assert c.get("deadzone_unit", "rad") == "rad"
    assert c["deadzone_at_load"] == pytest.approx(DELTA * LEAD / (2 * math.pi), rel=1e-12)
    assert "not applied" not in err
    # and without a [transmission] an angle still cannot be put at the table
    code, _, err = run_cli([*argv, "--config", str(_config(tmp_path / "bare.toml", False))])
    assert code == 2 and "needs a [transmission] table" in err


def test_prismatic_estimate_beside_a_rotary_iso_test_is_refused_and_its_note_is_in_micrometres(tmp_path):
    rows = np.array([(P, j, d, -d * 1e-4) for P in (0.0, 0.5, 1.0) for j in (1, 2, 3) for d in (1, -1)])
    rotary = evaluate(approaches_from_rows(rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3], unit="rad"))
    assert rotary.unit == "rad"
    with pytest.raises(ConfigError, match="prismatic axis .* rotary one .*cannot be compared"):
        compare(rotary, Deadzone(DELTA, U_DELTA, "est.json", axis="prismatic"), Transmission(i_G=1.0))
    dz = read_deadzone(_estimate(tmp_path / "e.json", "prismatic", converged=False))
    assert dz.prismatic and "u = 0.448 µm" in dz.note and "mrad" not in dz.note
    assert "u = 0.000448 mrad" in read_deadzone(_estimate(tmp_path / "r.json", None, converged=False)).note
    (tmp_path / "bad.json").write_text(json.dumps({"delta": DELTA, "axis": "linear"}))
    with pytest.raises(Exception, match="key 'axis' must be 'rotary' or 'prismatic'"):
        read_deadzone(tmp_path / "bad.json")
