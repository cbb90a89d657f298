"""A pass too short for the trimmed ends names its file (session 36, helper's finding on te update).

Before: ``drivelash: error: column 'x_T': run shorter than twice the trim length`` — which of the
update's passes, and how short, was not said. Now the line names the file, the direction, the
pass's travel and the trim. (Full-length passes of the same campaign update: the negative control is
tests/te_learn/test_update_cli.py.)"""

from __future__ import annotations

import numpy as np

from cli_runner import run_in_process
from drivelash.io.trace import Trace

from .conftest import pass_columns, te_def_um
from .test_update_cli import T_S, V
from .test_update_worse_cause import _campaign, parent  # noqa: F401  (the module's fixture)


def _short(path, model, F: float, d: int) -> None:
    x = np.arange(0.10, 0.125, V * T_S)
    x = x if d > 0 else x[::-1]
    Trace(pass_columns(model, x, d, F, te_def_um(x, F), T_S), {}).to_parquet(path)


def test_a_short_update_pass_is_named(parent, tmp_path, capsys):  # noqa: F811
    root, m1, model = parent
    camp = _campaign(tmp_path / "c", model, (0.0, 1000.0, 1500.0, 2000.0, 3000.0))
    _short(camp / "neg_F1000.parquet", model, 1000.0, -1)  # 25 mm of a 280 mm stroke
    out = tmp_path / "m2"
    code, so, se = run_in_process(["te", "update", str(m1), str(camp), "-o", str(out)], capsys)
    text = so + se
    assert code == 2 and "Traceback" not in text and not out.exists(), text
    last = text.strip().splitlines()[-1]
    assert last.startswith(f"drivelash: error: {camp / 'neg_F1000.parquet'}, column 'x_T': "), last
    assert "the pass in direction -1 covers 24.9" in last, last
    assert "mm at constant velocity, too short for the" in last, last
    assert text.count("error") == 1, text
