"""One file unlike the others is named as such, not only by advice on the shared [columns]
mapping (tester H, TH6 and TH7).

TH6: a loaded pass exported in µm under a column declared mm made its 6.5 µm end-of-pass overshoot
a 6.5 mm "reversal" ("split the file"). TH7: a pass whose rows were written in reverse time order
was told "fix 'direction'", and after that "set scale = -1 on the torque_m column" — a change that
breaks the other 19 files. Negative controls: the same faults in every file keep the [columns]
advice without the note, and a pass merely listed with the wrong direction keeps "fix 'direction'".
"""

from __future__ import annotations

import dataclasses

import numpy as np

from drivelash.te.protocol.plausibility import check_runs

from .synth import BENCH, record, standard_runs

SHORT = {"lo": 0.05, "hi": 0.45}
X_UNIT = ("pos_scale_mm", "mm")


def _recs():
    return [record(dataclasses.replace(r, **SHORT), f"run{i:02d}.csv") for i, r in enumerate(standard_runs())]


def _check(recs):
    return check_runs(
        recs, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0, source="axis.toml", x_unit=X_UNIT
    )


def _overshoot(r, um=6.5):
    """The pass with a settling overshoot of ``um`` at its end (0.1 s out, 0.1 s back, 1 kHz)."""
    dt = float(np.median(np.diff(r.t)))
    bump = um * 1e-6 * np.sin(np.linspace(0, np.pi, 200)) * np.sign(r.x_T[-1] - r.x_T[0])
    t = np.concatenate([r.t, r.t[-1] + dt * np.arange(1, 201)])
    x = np.concatenate([r.x_T, r.x_T[-1] + bump])
    th = np.concatenate([r.theta_m, r.theta_m[-1] + bump / BENCH.r_eff])
    return dataclasses.replace(
        r, t=t, x_T=x, theta_m=th, torque_m=np.concatenate([r.torque_m, np.zeros(200)])
    )


def _errors(rep, file=None):
    return [f for f in rep.errors if file is None or f.file == file]


def test_one_loaded_pass_in_um_is_named_as_a_unit_slip_of_that_file():
    recs = [_overshoot(r) for r in _recs()]
    assert not _errors(_check(recs))  # the overshoot alone is no reversal
    recs[5] = dataclasses.replace(recs[5], x_T=recs[5].x_T * 1e3)  # run05: 1000 N, −1, in µm
    f = _errors(_check(recs), "run05.csv")
    assert len(f) == 1 and f[0].check == "ratio", [x.line() for x in f]
    assert "looks like um declared as mm" in f[0].message and "split the file" not in f[0].message
    assert "but only 1 of 10 runs disagree: if the others are right, this file was" in f[0].message
    # negative control: every file in µm keeps the [columns] advice
    every = _check([dataclasses.replace(r, x_T=r.x_T * 1e3) for r in map(_overshoot, _recs())])
    assert all(
        "set unit = 'um' in [columns.pos_scale_mm]" in e.message for e in every.errors if e.check == "ratio"
    )


def _reversed(r):
    return dataclasses.replace(r, x_T=r.x_T[::-1], theta_m=r.theta_m[::-1], torque_m=r.torque_m[::-1])


def test_a_pass_reversed_in_time_is_named_so_and_the_torque_column_left_alone():
    recs = _recs()
    recs[5] = _reversed(recs[5])  # run05: 1000 N, direction −1, rows in reverse time order
    f = _errors(_check(recs), "run05.csv")
    assert len(f) == 1 and f[0].check == "direction", [x.line() for x in f]
    assert "the rows look reversed in time" in f[0].message and "fix 'direction'" not in f[0].message
    # the user relabels it +1 anyway: no advice to flip the torque column of all files
    recs[5] = dataclasses.replace(recs[5], direction=1)
    f = [x for x in _errors(_check(recs), "run05.csv") if x.check == "torque"]
    assert len(f) == 1 and "but only 1 of 6 runs disagree" in f[0].message, f
    assert "re-export it like them, since [columns] applies to every file" in f[0].message


def test_the_shared_advice_stays_where_it_is_right():
    recs = _recs()
    # a pass only listed with the wrong direction (its torque agrees with its motion)
    wrong = list(recs)
    wrong[5] = dataclasses.replace(recs[5], direction=1)
    f = _errors(_check(wrong), "run05.csv")
    assert len(f) == 1 and f[0].check == "direction" and "fix 'direction' of this run" in f[0].message, f
    # the torque column's sign flipped in every file
    flipped = _check([dataclasses.replace(r, torque_m=-r.torque_m) for r in recs])
    torque = [e for e in flipped.errors if e.check == "torque" and e.file != "axis.toml"]
    assert torque and all("set scale = -1 on the torque_m column" in e.message for e in torque)
    assert not any("only" in e.message for e in torque)
