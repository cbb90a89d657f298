"""`estimate` on a linear axis prints its lost motion in µm, not mrad (session 31 tester C, C7:
"δ̂ = 0.002 mrad … converged (band 2 mrad)" on an axis in metres). The JSON stays SI (m).

Recording: bench-0B, 6 s, seed 1, rewritten exactly in units s = 1e-3 and mapped as a linear axis
(positions in m, velocities in m/s, force in N): a 186 µm gap (tests/estimation/test_session31_scale.py
for why the numbers carry over). Negative control: the same recording as an angle prints mrad.
"""

from __future__ import annotations

import json
import re

import pytest

from linear_bench import UNITS, write_linear_bench


@pytest.fixture(scope="module")
def linear(tmp_path_factory):
    return write_linear_bench(tmp_path_factory.mktemp("lin"))


def _run(d, capsys, cfg):
    from cli_runner import run_in_process

    out = d / f"{cfg}.json"
    code, stdout, err = run_in_process(
        [
            "estimate",
            str(d / "lin.parquet"),
            "--config",
            str(d / f"{cfg}.toml"),
            "--json",
            str(out),
            "--force",
        ],
        capsys,
    )
    assert code == 0, err
    return stdout, json.loads(out.read_text())


def test_linear_axis_prints_micrometres(linear, capsys):
    stdout, js = _run(linear, capsys, "lin")
    m = re.search(r"δ̂ = ([0-9.]+) µm ± ([0-9.]+) µm \(95 %\)\s+\(δ1 = ([0-9.]+) µm\)", stdout)
    assert m, stdout
    assert float(m.group(1)) == pytest.approx(1e6 * js["delta"], abs=5e-4)  # the JSON's metres, printed in µm
    assert float(m.group(3)) == pytest.approx(93.0, abs=5e-4)
    assert abs(float(m.group(1)) - 186.0) < 2.0  # the 186 µm gap
    assert "mrad" not in stdout.split("excitation")[0]
    if js["converged"]:
        assert re.search(r"converged \(band [0-9.]+ µm\)", stdout), stdout


def test_negative_control_an_angle_prints_mrad(linear, capsys):
    text = (linear / "lin.toml").read_text(encoding="utf-8")
    for u in UNITS.values():
        text = text.replace(
            f'unit = "{u}"',
            {"m": 'unit = "rad"', "m/s": 'unit = "rad/s"', "N": 'unit = "Nm"'}.get(u, f'unit = "{u}"'),
        )
    (linear / "ang.toml").write_text(text, encoding="utf-8")
    stdout, js = _run(linear, capsys, "ang")
    m = re.search(r"δ̂ = ([0-9.]+) mrad", stdout)
    assert m and float(m.group(1)) == pytest.approx(1e3 * js["delta"], abs=5e-4), stdout
    assert "µm" not in stdout


def test_the_online_law_warnings_on_a_linear_axis_are_in_micrometres(linear, capsys):
    """Session 34 (left open since session 32): the online law's own warnings said "mrad" on a
    linear axis. δ1 stated 30 µm high (123 for 93 µm): δ̂ 215.9 µm leaves the observed Δθ range
    of 203.1 µm — the warning says so in µm, with the numbers the JSON carries in m."""
    text = (linear / "lin.toml").read_text(encoding="utf-8")
    (linear / "d1.toml").write_text(text.replace("delta1 = 9.3e-05", "delta1 = 0.000123"), encoding="utf-8")
    assert "delta1 = 0.000123" in (linear / "d1.toml").read_text(encoding="utf-8")
    stdout, js = _run(linear, capsys, "d1")
    flat = " ".join(stdout.split())
    rng = js["extra"]["dtheta_range"] if "extra" in js else None
    m = re.search(r"δ̂ = ([0-9.]+) µm exceeds the whole Δθ range observed \(([0-9.]+) µm\)", flat)
    assert m, flat
    assert float(m.group(1)) == pytest.approx(1e6 * js["delta"], abs=0.05)
    if rng is not None:
        assert float(m.group(2)) == pytest.approx(1e6 * rng, abs=0.05)
    assert "mrad" not in flat and " rad" not in flat.replace("rad/s", "")
    assert not js["converged"]


def _estimate(d, capsys, cfg):
    from cli_runner import run_in_process

    return run_in_process(["estimate", str(d / "lin.parquet"), "--config", str(d / f"{cfg}.toml")], capsys)


def test_a_delta1_slip_on_a_linear_axis_is_read_as_micrometres(linear, capsys):
    """Session 34 tester G, G10: ``delta1 = 10`` (µm meant) on a linear axis was refused with "δ1 =
    10 rad … if 10 is in mrad, write 0.01" — 10 mm on a carriage. Now the [columns] mapping's length
    unit makes the hint metres → µm. Negative control: the same file mapped as an angle keeps mrad."""
    text = (linear / "lin.toml").read_text(encoding="utf-8")
    (linear / "slip.toml").write_text(text.replace("delta1 = 9.3e-05", "delta1 = 10.0"), encoding="utf-8")
    code, out, err = _estimate(linear, capsys, "slip")
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "δ1 = 10 m exceeds δ_max = 2 m" in err and "if 10 is in µm, write 1e-05" in err, err
    ang = text.replace('unit = "m/s"', 'unit = "rad/s"').replace('unit = "m"', 'unit = "rad"')
    (linear / "slip_ang.toml").write_text(ang.replace("delta1 = 9.3e-05", "delta1 = 10.0"), encoding="utf-8")
    code, out, err = _estimate(linear, capsys, "slip_ang")
    assert code == 2 and "δ1 = 10 rad" in err and "if 10 is in mrad, write 0.01" in err, err


def test_a_delta1_of_millimetres_on_a_micrometre_gap_is_named_not_called_gravity(linear, capsys):
    """G10: δ1 = 0.01 m (10 mm; the 186 µm gap's δ1 is 93 µm) lay inside the unscaled 0.05 rad floor
    of the 'outside the observed offsets' test and was reported as "one flank keeps the load (…
    gravity, or a preload)". The floor now follows the angle scale σ (0.0203 here): the δ1 is named."""
    text = (linear / "lin.toml").read_text(encoding="utf-8")
    (linear / "mm.toml").write_text(text.replace("delta1 = 9.3e-05", "delta1 = 0.01"), encoding="utf-8")
    code, out, err = _estimate(linear, capsys, "mm")
    assert code == 0, err
    flat = " ".join(out.split())
    assert "delta1 = 0.01 m is outside the observed motor–load offset range" in flat, flat
    assert "gravity" not in flat and "not converged" in flat
