"""``DriveIdentification``'s repr is a short table, not the dataclass dump (session 34, tester G,
G12: a notebook echo of ``identify_drive(...)`` printed one ~6.5 kB line — every field, the
correlation matrix and the whole ``fit`` dictionary with its HAC, Hausman and window-shift
diagnostics). Control: the fields themselves are unchanged and still on the object."""

from __future__ import annotations

import numpy as np

from drivelash.estimation.identify_result import DriveIdentification
from drivelash.estimation.identify_result import ParameterEstimate as P

WHY = "the shaft torque is not distinguishable in the motor torque " * 3  # a long reason
HEAD = "DriveIdentification(model='two-mass', N=1, plausible=True, backlash_visible=True, warnings=0"


def _ident() -> DriveIdentification:
    params = {
        "J_m": P.normal("J_m", 0.0199774, 0.000285),
        "K_S": P.unknown("K_S", WHY),
        "delta": P.normal("delta", 0.0199924, 4.3e-5),
    }
    fit = {f"diagnostic_{i}": {"hausman": list(range(20)), "hac_lags": i} for i in range(40)}  # ~6 kB
    return DriveIdentification(
        "two-mass", params, ("J_m", "delta"), np.eye(2), N=1.0, backlash_visible=True,
        reason="both contacts seen: 6 traversals of the gap", fit=fit, method="two-mass LS",
    )  # fmt: skip


def test_repr_is_a_short_table():
    ident = _ident()
    text = repr(ident)
    lines = text.splitlines()
    assert len(text) < 1000 and len(lines) == 1 + len(ident.parameters) + 1
    assert lines[0] == HEAD
    assert lines[1] == "  J_m = 0.0199774 kg·m²  95 % " + ident["J_m"].interval_text()
    assert lines[2].startswith("  K_S = –  (the shaft torque") and lines[2].endswith("…)")
    assert len(lines[2]) <= len("  K_S = –  ()") + 100  # identify_result.REPR_REASON_CHARS
    assert lines[-1] == "  backlash: both contacts seen: 6 traversals of the gap)"
    assert "hausman" not in text and "diagnostic_" not in text and "array" not in text
    assert str(ident) == text  # print() shows the same table


def test_control_the_fields_are_unchanged():
    ident = _ident()
    assert ident["K_S"].reason == WHY and len(ident.fit) == 40 and ident.correlation.shape == (2, 2)
    assert ident["J_m"] == _ident()["J_m"] and ident.verdict == "backlash: " + ident.reason
