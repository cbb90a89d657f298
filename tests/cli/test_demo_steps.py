"""What the README says `make demo` runs: a small compensation run among its steps, and it ends
with a small fleet (the order of ``drivelash demo``'s steps)."""

from __future__ import annotations


def test_demo_includes_a_compensation_run_and_ends_with_a_fleet():
    from drivelash.commands.demo import _steps

    names = [s.__name__ for s in _steps()]
    assert names == ["demo_simulate", "demo_estimate", "demo_compensate", "demo_iso230", "demo_fleet"]
    assert names[-1] == "demo_fleet" and "demo_compensate" in names
