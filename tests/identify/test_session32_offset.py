"""The rigid identification's force offset reaches `observe` (session 31 tester C, C11: `identify
--model rigid --out` dropped the offset −3.17 N, so `observe`'s report drew the reference at
±F_c = ±20.41 N while d̂ sat at +17.0 / −24.2 N — an apparent 3.2 N observer bias).

Real data: EMPS (DATA_EMPS.mat); the identified F_c ± offset is the reference the data README's
model gives; d̂'s constant-velocity means are closer to F_c sign q̇ + offset than to F_c sign q̇.
"""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.io import load_config
from identify.helpers import EMPS_CONFIG, emps_file


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    from drivelash.commands.data import run_identify

    d = tmp_path_factory.mktemp("off")
    frag = d / "dt.toml"
    summary = run_identify(emps_file("DATA_EMPS.mat"), EMPS_CONFIG, out=frag, quiet=True)
    return d, frag, summary


def _drawn(monkeypatch) -> dict:
    """The reference line `observe` hands to its report: its label and values at q̇ = +1 / −1."""
    import drivelash.report as rp

    seen: dict = {}
    real = rp.render_observe_report

    def spy(*a, expected=None, expected_label="", **k):
        seen["label"] = expected_label
        seen["values"] = None if expected is None else list(expected(np.array([1.0, -1.0])))
        return real(*a, expected=expected, expected_label=expected_label, **k)

    monkeypatch.setattr(rp, "render_observe_report", spy)
    return seen


def test_fragment_carries_the_offset(identified):
    _, frag, summary = identified
    offset = summary["parameters"]["offset"]["value"]
    assert offset == pytest.approx(-3.17, abs=0.005)  # the README's figure
    cfg = load_config(frag)
    assert cfg.identification.torque_offset == offset == summary["torque_offset"]
    assert cfg.drivetrain.T_Cm == pytest.approx(20.41, abs=0.005)


def test_observe_draws_coulomb_plus_offset(identified, monkeypatch):
    from drivelash.commands.data import run_observe

    d, frag, summary = identified
    seen = _drawn(monkeypatch)
    obs = run_observe(
        emps_file("DATA_EMPS.mat"), EMPS_CONFIG, drivetrain=frag, report=d / "o.html", quiet=True, force=True
    )
    f_c, off = summary["parameters"]["F_c"]["value"], summary["torque_offset"]
    assert obs["torque_offset"] == off
    assert seen["label"] == "T_Cm sign q̇ + torque_offset ([drivetrain], [identification])"
    assert seen["values"] == pytest.approx([f_c + off, -f_c + off], rel=1e-12)
    for mean, sign in ((obs["mean_disturbance_forward"], 1), (obs["mean_disturbance_backward"], -1)):
        with_offset = abs(mean - (sign * f_c + off))
        assert with_offset < 0.7 < abs(mean - sign * f_c), (mean, with_offset)  # 0.24 / 0.61 vs 3.4 / 3.0 N


def test_negative_control_a_fragment_without_offset(identified, monkeypatch):
    from drivelash.commands.data import run_observe

    d, frag, summary = identified
    seen = _drawn(monkeypatch)
    plain = d / "plain.toml"
    plain.write_text(
        frag.read_text(encoding="utf-8").split("\n# the recorded motor torque")[0], encoding="utf-8"
    )
    assert load_config(plain).identification is None
    obs = run_observe(
        emps_file("DATA_EMPS.mat"), EMPS_CONFIG, drivetrain=plain, report=d / "p.html", quiet=True, force=True
    )
    assert "torque_offset" not in obs
    assert seen["label"] == "T_Cm sign q̇ ([drivetrain]; no torque_offset given)"
    f_c = summary["parameters"]["F_c"]["value"]
    assert seen["values"] == pytest.approx([f_c, -f_c], rel=1e-12)
