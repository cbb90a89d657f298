"""B beside the deadzone: transmission factors, E_n, reading an estimate."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from drivelash.errors import ConfigError, DataError, ParameterError
from drivelash.iso230 import Deadzone, Transmission, approaches_from_rows, compare, evaluate, read_deadzone
from drivelash.iso230.compare import (
    MAX_COMPENSATION_M,
    MAX_COMPENSATION_RAD,
    MAX_LEAD,
    MAX_PINION_RADIUS,
    check_compensation,
    lost_motion,
)


def test_transmission_factors():
    assert Transmission(lead=0.01).factor("m") == pytest.approx(0.01 / (2 * math.pi), rel=1e-15)
    assert Transmission(lead=0.01, i_G=5).factor("m") == pytest.approx(0.01 / (10 * math.pi), rel=1e-15)
    assert Transmission(pinion_radius=0.05, i_G=2).factor("m") == pytest.approx(0.025, rel=1e-15)
    assert Transmission(i_G=4).factor("rad") == 0.25
    with pytest.raises(ParameterError, match="needs lead"):
        Transmission().factor("m")
    with pytest.raises(ParameterError, match="either lead or pinion_radius"):
        Transmission(lead=0.01, pinion_radius=0.05)
    with pytest.raises(ParameterError, match="rotary axis"):
        Transmission(lead=0.01).factor("rad")


def _result(L: float) -> object:
    """3 targets × 3 runs, x↑ = −L/2 ± 0.1 µm, x↓ = +L/2 ± 0.1 µm: −B̄ = L exactly, u(B̄) known."""
    rows = []
    for P in (0.0, 0.1, 0.2):
        for j, e in enumerate((-1e-7, 0.0, 1e-7), start=1):
            rows += [(P, j, 1, -L / 2 + e), (P, j, -1, L / 2 + e)]
    r = np.array(rows)
    return evaluate(approaches_from_rows(r[:, 0], r[:, 1], r[:, 2], r[:, 3]))


def test_E_n_by_hand():
    res = _result(10e-6)
    # s = 0.1 µm in each direction → u(B_i)² = 2·0.01/3 µm², u(B̄)² = 3·(0.02/3)/9 µm² = 0.02/9 µm²
    u_iso = math.sqrt(0.02 / 9) * 1e-6
    assert res.u_B_mean == pytest.approx(u_iso, rel=1e-12)
    k = 0.01 / (2 * math.pi)
    dz = Deadzone(delta=11e-6 / k, u_delta=0.4e-6 / k, source="x")
    c = compare(res, dz, Transmission(lead=0.01))
    assert c.L_iso == pytest.approx(10e-6, rel=1e-12) and c.L_delta == pytest.approx(11e-6, rel=1e-12)
    E_n = 1e-6 / (2 * math.hypot(u_iso, 0.4e-6))
    assert c.E_n == pytest.approx(E_n, rel=1e-12)
    assert c.agree == (E_n <= 1)
    # the control's reversal compensation is added back to the measured lost motion
    c2 = compare(res, dz, Transmission(lead=0.01), compensation=1e-6)
    assert c2.L_iso == pytest.approx(11e-6, rel=1e-12) and c2.E_n == pytest.approx(0.0, abs=1e-9)
    # no uncertainty for the deadzone: only the ISO side counts
    c3 = compare(res, Deadzone(11e-6 / k, None, "x"), Transmission(lead=0.01))
    assert c3.E_n == pytest.approx(1e-6 / (2 * u_iso), rel=1e-12) and not c3.agree


def test_implausible_lead_pinion_radius_and_compensation_are_refused_with_the_likely_unit():
    """Found by an exploratory tester (s19 F16): `lead = 10` (mm per revolution as in a data sheet)
    was taken as 10 m, `pinion_radius = 42.4` (mm) as 42.4 m, `compensation = 10` (µm) as 10 m
    — without a word. Bounds: docs/assumptions.md ("ISO 230-2", plausibility of the
    transmission and the compensation). Negative controls: the largest plausible values pass."""
    with pytest.raises(ParameterError, match=r"10 m is not a plausible ball-screw lead.*write 0\.01"):
        Transmission(lead=10.0)
    with pytest.raises(ParameterError, match=r"42\.4 m is not a plausible pinion pitch.*write 0\.0424"):
        Transmission(pinion_radius=42.4)
    assert Transmission(lead=MAX_LEAD).lead == MAX_LEAD  # a 100 mm high-helix screw: accepted
    assert Transmission(pinion_radius=MAX_PINION_RADIUS).pinion_radius == MAX_PINION_RADIUS
    res = _result(10e-6)
    dz = Deadzone(1e-3, None, "x")
    for c, hint in ((10.0, "if 10 is in µm, write 1e-05"), (0.01, "if 0.01 is in mm, write 1e-05")):
        with pytest.raises(ParameterError, match="not a plausible reversal compensation") as ei:
            compare(res, dz, Transmission(lead=0.01), compensation=c)
        assert ei.value.field == "compensation" and hint in ei.value.problem
        with pytest.raises(ParameterError, match="compensation"):
            lost_motion(res, c)
    assert lost_motion(res, -MAX_COMPENSATION_M)[0] == pytest.approx(10e-6 - MAX_COMPENSATION_M)
    # a rotary axis: at most 1°; arcsec written as rad are named
    with pytest.raises(ParameterError, match="if 20 is in arcsec, write 9.69627e-05"):
        check_compensation(20.0, "rad")
    check_compensation(MAX_COMPENSATION_RAD, "rad")


def test_transmission_must_fit_the_axis():
    with pytest.raises(ConfigError, match=r"table \[transmission\], key 'lead'"):
        compare(_result(10e-6), Deadzone(1e-3, None, "x"), Transmission())


def test_read_deadzone(tmp_path):
    p = tmp_path / "est.json"
    p.write_text(json.dumps({"delta": 0.012, "delta_std": 0.0004, "excitation_ok": True}))
    dz = read_deadzone(p)
    assert dz.delta == 0.012 and dz.u_delta == 0.0004
    p.write_text(json.dumps({"delta": 0.012}))
    assert read_deadzone(p).u_delta is None
    for bad, msg in (
        ("{", "not a drivelash estimate JSON"),
        (json.dumps({"delta": None}), "key 'delta' must be a finite number"),
        (json.dumps({"delta": 0.01, "delta_std": -1}), "key 'delta_std'"),
        (
            json.dumps({"delta": 0.01, "excitation_ok": False, "reason": "one direction only"}),
            "one direction only",
        ),
    ):
        p.write_text(bad)
        with pytest.raises(DataError, match=msg):
            read_deadzone(p)
    with pytest.raises(DataError, match="no such file"):
        read_deadzone(tmp_path / "missing.json")
