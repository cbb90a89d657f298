"""What the commands print through Rich is printed as written: table names in square brackets
(``[backlash]``, ``[columns]``) in reasons and warnings are not taken for style tags (session 9:
the ``--identify`` δ1 warning printed "warning:  delta1 = 95 mrad", the table name gone)."""

from __future__ import annotations

from drivelash.commands.estimate import _print_summary

SUMMARY = {
    "method": "default",
    "samples": 12000,
    "T_s": 1e-3,
    "delta": 0.1857,
    "delta1": 0.0929,
    "delta_std": 1e-4,
    "excitation_ok": True,
    "reason": "12 crossings of the gap (see [estimator] window)",
    "converged": True,
    "convergence_time_s": 0.09,
    "convergence_band_rad": 3.7e-3,
    "delta1_check_result": "consistent",
    "delta1_estimate": 0.09306,
    "warnings": [
        "[backlash] delta1 = 95 mrad lies outside the recording's 95 % interval [92.73, 93.04] mrad"
    ],
    "identification": {
        "delta": {"identifiable": False},
        "reason": "the torque never reversed across the gap: torque_m scale in [columns]?",
    },
}


def test_estimate_summary_prints_table_names_in_brackets(capsys):
    _print_summary(SUMMARY)
    out = " ".join(capsys.readouterr().out.split())  # Rich wraps long lines
    assert "warning: [backlash] delta1 = 95 mrad" in out
    assert "(see [estimator] window)" in out
    assert "torque_m scale in [columns]?" in out
    assert "[92.73, 93.04]" in out


def test_negative_control_unescaped_rich_drops_them(capsys):
    from rich.console import Console

    Console().print("warning: [backlash] delta1 = 95 mrad")
    assert "[backlash]" not in capsys.readouterr().out


def test_a_note_prints_with_one_prefix_and_the_offline_warnings_print_too(capsys):
    """Session 30 tester A: L2 — a note among the warnings printed as "warning: note: …";
    M4 — with ``--identify`` the online line said "see the identification warning" while that
    warning (the remedy: "add offset = 200.6 rad to theta_l") was only in the JSON."""
    note = "note: the sample rate 1000 Hz is below the 2000 Hz down to which …"
    remedy = "the encoders' zeros are offset — add offset = 200.6 rad to theta_l in [columns]"
    s = SUMMARY | {
        "warnings": [note, "a real warning"],
        "identification": SUMMARY["identification"] | {"warnings": [remedy]},
    }
    _print_summary(s)
    out = " ".join(capsys.readouterr().out.split())
    assert "note: the sample rate 1000 Hz" in out and "warning: note:" not in out
    assert "warning: a real warning" in out  # negative control: a warning keeps its prefix
    assert f"offline warning: {remedy}" in out
