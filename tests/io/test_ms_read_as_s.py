"""Time in ms declared as s on a recording without a velocity column (B4): one line naming the
file, the time column and the fix — not ``identification.cutoff_hz``, a key the user never set.

Reference: EMPS (1 kHz) exported as the tester did (``;``-separated, decimal comma, ms and mm);
with the right unit the same file gives the published M = 95.11 kg.
"""

from __future__ import annotations

import numpy as np
import pytest

from cli_runner import run_in_process
from drivelash.errors import DataError
from drivelash.io.config import SamplingSection
from drivelash.io.load import _check_time
from realdata import shared_data

CFG = """[columns.time_ms]
column = "t"
unit = "{unit}"
[columns.x_mm]
column = "theta_m"
unit = "mm"
[columns.force_N]
column = "torque_m"
unit = "N"
"""


def test_jittered_ms_stamps_declared_as_s_are_refused():
    rng = np.random.default_rng(0)
    t = np.cumsum(
        1.0 + rng.choice([-1.6e-5, 2.4e-5], 5000, p=[0.6, 0.4])
    )  # EMPS's decimal ms stamps: median 0.999984
    assert np.median(np.diff(t)) < 1.0
    with pytest.raises(
        DataError, match=r'implausible sample period 0\.99998\d* s.*declares unit = "s"; time stamps in ms'
    ):
        _check_time(t, "f.csv", "time_ms", SamplingSection(), [], "s")
    slow = np.arange(1000.0) * 0.1  # negative control: an ISO 230-2 series at 10 Hz
    assert _check_time(slow, "f.csv", "t", SamplingSection(), [], "s") is None


def test_emps_csv_in_ms_declared_as_s(tmp_path, capsys):
    import pandas as pd
    import scipy.io as sio

    m = sio.loadmat(shared_data("emps", "DATA_EMPS.mat"), squeeze_me=True)
    df = pd.DataFrame({"time_ms": m["t"] * 1e3, "x_mm": m["qm"] * 1e3, "force_N": m["vir"] * 35.15065188})
    csv = tmp_path / "emps_mm_ms.csv"
    df.to_csv(csv, index=False, sep=";", decimal=",")
    (tmp_path / "bad.toml").write_text(CFG.format(unit="s"))
    code, _, err = run_in_process(["identify", str(csv), "-c", str(tmp_path / "bad.toml")], capsys)
    assert code == 2
    assert "cutoff_hz" not in err  # was: identification.cutoff_hz: must lie in (0, fs/2 = 0.500008) Hz
    assert "emps_mm_ms.csv" in err and "column 'time_ms'" in err and 'set unit = "ms"' in err
    assert len(err.strip().splitlines()) == 1
    # negative control: the unit the message names gives the published mass
    (tmp_path / "ok.toml").write_text(CFG.format(unit="ms"))
    code, out, err = run_in_process(
        ["identify", str(csv), "-c", str(tmp_path / "ok.toml"), "--json", str(tmp_path / "o.json")], capsys
    )
    assert code == 0, err
    import json

    js = json.loads((tmp_path / "o.json").read_text())
    assert json.dumps(js).count("95.1") >= 1
