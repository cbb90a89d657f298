"""``te import --for-score``: passes recorded to be scored are imported without geometric runs (A4).

Before (session 20, tester A): ``te score``'s documented input (a ``te import`` of the scored
passes) was refused: "no geometric (no-load) run in direction +1"; compensated passes at a
single load in one direction: "only 1 training load(s)" — although nothing is learnt from them.
"""

from __future__ import annotations

import dataclasses

from cli_runner import run_in_process
from drivelash.te.protocol.campaign import load_campaign

from .synth import standard_runs, write_axis


def _score_axis(tmp_path):
    runs = [dataclasses.replace(r, lo=0.05, hi=0.45) for r in standard_runs(loads=(0.0, 1500.0))]
    runs = [r for r in runs if r.kind == "load"]  # no geometric runs
    runs = [r for r in runs if not (r.direction == -1 and r.load > 0)]  # one load in direction -1
    return write_axis(tmp_path / "rec", runs)


def test_score_passes_import_with_for_score_and_are_refused_without(tmp_path, capsys):
    axis = _score_axis(tmp_path)
    code, out, err = run_in_process(["te", "import", str(axis), "-o", str(tmp_path / "c0")], capsys)
    assert (
        code == 2 and "no geometric (no-load) run in direction +1" in err
    )  # negative control: a fit campaign
    assert not (tmp_path / "c0").exists()
    code, out, err = run_in_process(
        ["te", "import", str(axis), "-o", str(tmp_path / "c1"), "--for-score"], capsys
    )
    assert code == 0, err
    assert "warning" in err and "no geometric (no-load) run in direction -1" in err
    assert "only 1 training load(s)" in err
    camp = load_campaign(tmp_path / "c1")
    assert len(camp.select(kind="load")) == 3 and not camp.select(kind="geometric")


def test_for_score_keeps_the_other_checks_errors(tmp_path, capsys):
    """A flipped encoder is still refused with --for-score (only fit-only checks are relaxed)."""
    runs = [dataclasses.replace(r, lo=0.05, hi=0.45) for r in standard_runs(loads=(0.0, 1500.0))]
    runs = [r if i != 3 else dataclasses.replace(r, sign=-1) for i, r in enumerate(runs) if r.kind == "load"]
    axis = write_axis(tmp_path / "rec", runs)
    code, _, err = run_in_process(
        ["te", "import", str(axis), "-o", str(tmp_path / "c"), "--for-score"], capsys
    )
    assert code == 2 and "encoder sign" in err, err
