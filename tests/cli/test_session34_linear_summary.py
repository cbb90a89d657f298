"""The estimate summary (``estimate --json``, ``BacklashEstimate.summary``) states the axis kind
and the unit of its gap, displacement and effort values (session 34, tester G, G8: on a linear
axis ``convergence_band_rad`` held metres and nothing in the JSON said so — a script, or
``iso230 --estimate`` (G6), could not tell metres from radians).

Recording: tests/linear_bench.py (bench-0B in units 1e-3, 3 s). Negative control: the same
numbers mapped as angles say "rotary" and rad / N·m. The notebook API's summary is the JSON's.
"""

from __future__ import annotations

import json

import pytest

from cli_runner import run_in_process
from linear_bench import write_linear_bench


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    return write_linear_bench(tmp_path_factory.mktemp("lin35"), duration=3.0)


def _json(d, capsys, cfg):
    out = d / f"{cfg}.json"
    code, _, err = run_in_process(
        ["estimate", str(d / "lin.parquet"), "--config", str(d / f"{cfg}.toml"), "--json", str(out),
         "--force"],
        capsys,
    )  # fmt: skip
    assert code == 0, err
    return json.loads(out.read_text(encoding="utf-8"))


@pytest.mark.parametrize(
    ("cfg", "axis", "length", "effort"), [("lin", "prismatic", "m", "N"), ("ang", "rotary", "rad", "N·m")]
)
def test_summary_states_axis_and_units(bench, capsys, cfg, axis, length, effort):
    import drivelash as dl
    from drivelash.estimation.pipeline import SUMMARY_EFFORT_KEYS, SUMMARY_LENGTH_KEYS

    js = _json(bench, capsys, cfg)
    assert js["axis"] == axis
    units = js["units"]
    assert units["delta"] == units["convergence_band_rad"] == units["delta_interval_95"] == length
    assert units["maee_rad"] == units["steady_state_peak_rad"] == units["dtheta_range"] == length
    assert units["contact_threshold"] == effort
    assert set(units) == set(SUMMARY_LENGTH_KEYS) | set(SUMMARY_EFFORT_KEYS)
    for k in ("delta", "delta1", "delta_std", "delta1_estimate", "delta1_used", "contact_deflection"):
        assert k in js and units[k] == length, k
    # the notebook API's summary is the command's JSON (without its signature and paths)
    est = dl.estimate_backlash(bench / "lin.parquet", bench / f"{cfg}.toml")
    assert est.summary == {k: v for k, v in js.items() if k not in ("generator", "trace", "config")}
