"""``estimate --identify`` whose online law cannot run still states the axis kind and the units of
its length keys (reviewer's left-over of session 34: that summary had no ``axis``/``units`` while
every other estimate summary has them since G8 — a script reading ``delta1`` of a linear axis could
not tell m from rad). Negative control: the same numbers declared as an angle say rotary / rad.
"""

from __future__ import annotations

import math

import drivelash as dl
from drivelash.io.trace import Trace
from identify.linear_axis import as_rotary, linear_axis_trace


def _positions_only(tr: Trace) -> Trace:
    return Trace({n: tr[n] for n in tr.names if not n.startswith("omega")}, dict(tr.meta))


def test_not_run_summary_of_a_linear_axis_states_m_and_n(tmp_path):
    tr = linear_axis_trace(20e-6, 10e-6, duration=2.0, freq=1.5)
    cfg = tmp_path / "lin.toml"
    cfg.write_text("[drivetrain]\nN = 1.0\n", encoding="utf-8")
    s = dl.estimate_backlash(_positions_only(tr), cfg, identify=True).summary
    assert s["online_run"] is False and s["delta"] is None
    assert s["axis"] == "prismatic"
    assert s["units"]["delta1"] == "m" and s["units"]["contact_threshold"] == "N"
    # the δ1 it reports is the identification's, in m (10 µm), as its unit says
    assert math.isclose(s["delta1"], 10e-6, rel_tol=0.01), s["delta1"]
    # negative control: the same samples ×1000 declared as rad
    r = dl.estimate_backlash(_positions_only(as_rotary(tr)), cfg, identify=True).summary
    assert r["online_run"] is False
    assert r["axis"] == "rotary" and r["units"]["delta1"] == "rad"
    assert r["units"]["contact_threshold"] == "N·m"
