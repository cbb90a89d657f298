"""One limit for the TE's zero from import to export (tester H, TH14).

A 2 mm zero offset between scale and motor encoder was a warning at ``te import`` (error only
beyond 5 mm), was fitted, and then ``te export`` refused the ``.ini``/``.COM`` tables (no-load TE
beyond 1 mm) while it wrote the ``.csv`` table with the 2 mm in it. Now ``te import`` refuses
beyond the export's limit, with the offset to set, and the runtime table refuses what the CNC
layouts refuse.
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from drivelash.errors import DataError
from drivelash.te.protocol import plausibility
from drivelash.te.protocol.plausibility import check_runs
from drivelash.te.runtime import cnc
from drivelash.te.runtime.export import export_table
from drivelash.te.runtime.table import TETable

from .synth import BENCH, record, standard_runs

SHORT = {"lo": 0.05, "hi": 0.45}


def _check(zero_mm: float):
    runs = [dataclasses.replace(r, **SHORT, zero_mm=zero_mm) for r in standard_runs()]
    recs = [record(r, f"run{i:02d}.csv") for i, r in enumerate(runs)]
    return check_runs(recs, BENCH.r_eff, BENCH.tooth_pitch, BENCH.travel, 3000.0, source="axis.toml")


def test_import_refuses_a_zero_offset_the_cnc_export_would_refuse():
    assert plausibility.ZERO_ERROR == cnc.TE_LIMIT == 1e-3  # one limit, shared
    rep = _check(2.0)
    zero = [f for f in rep.findings if f.check == "zero"]
    assert zero and zero[0].level == "error" and zero[0].file == "run00.csv", [f.line() for f in zero]
    assert re.match(r"TE is \+1\.9\d\d mm", zero[0].message), zero[0].message  # 2 mm less the rack's TE
    assert "limit 1 mm, te export's for a no-load TE" in zero[0].message
    assert "set offset = " in zero[0].message and "on the theta_m column" in zero[0].message
    with pytest.raises(DataError, match="implausible campaign: TE is"):
        rep.raise_errors()
    # a geometric run whose median lies just inside but whose TE reaches beyond the limit
    rep = _check(0.99)
    run00 = next(r for r in rep.runs if r["file"] == "run00.csv")
    assert abs(run00["te_median_m"]) < 1e-3
    (err,) = [f for f in rep.findings if f.level == "error" and f.check == "zero" and f.file == "run00.csv"]
    # named by the TE that crosses the limit, not by the median inside it (session 34 last read)
    assert re.match(r"TE reaches 1\.\d{3} mm \(median \+0\.9\d\d mm; limit 1 mm", err.message), err.message
    assert "set offset = " in err.message


def test_small_zero_offsets_stay_warnings_that_name_the_export_limit():
    rep = _check(0.7)  # negative control: 0.5 … 1 mm (and the clean campaign: nothing)
    zero = [f for f in rep.findings if f.check == "zero"]
    assert zero and all(f.level == "warning" for f in zero), [f.line() for f in zero]
    assert "te export refuses a no-load TE beyond 1 mm" in zero[0].message
    assert not [f for f in _check(0.0).findings if f.check == "zero"]


def _table(noload_m: float) -> TETable:
    te = np.full((2, 3, 2), noload_m)  # flank +1 torques [0, 1], flank −1 [−1, 0]
    te[0, :, 1] += 20e-6  # the loaded columns a little further
    te[1, :, 0] -= 20e-6
    return TETable(0.0, 1e-3, np.array([0.0, -1.0]), np.array([1.0, 1.0]), te)


@pytest.mark.parametrize("suffix", [".csv", ".json"])
def test_runtime_table_refuses_the_no_load_te_the_cnc_layouts_refuse(tmp_path, suffix):
    path = tmp_path / f"t{suffix}"
    with pytest.raises(DataError, match=r"no-load TE of 2 mm in direction \+1 \(limit 1 mm\)"):
        export_table(_table(2e-3), path)
    assert not path.exists()
    export_table(_table(0.9e-3), path)  # negative control: inside the limit, written
    assert path.exists()
