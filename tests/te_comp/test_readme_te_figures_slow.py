"""Every transmission-error figure of README.md, measured on the seed-0 run (`make test-slow`).

The figures, their tolerances and the README text are in :mod:`readme_figures`; the run
is the :func:`te_seed0` fixture (the README's own commands). Timing figures (fit time,
prediction and compensation speed) are ``make bench`` output, not asserted here.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from .readme_figures import (
    FIGURES,
    OTHER_CPU_MEASURED,
    OTHER_CPU_MODEL,
    cpu_dependent,
    cpu_model,
    on_reference_cpu,
)

pytestmark = pytest.mark.slow

#: The learning figures and what follows from the network (te validate's pass averages).
network_figures = cpu_dependent(
    "the README's learning figures", ", ".join(f"{k} {v:g}" for k, v in OTHER_CPU_MEASURED.items())
)


def _check(name: str, measured: float) -> None:
    value, tol, _ = FIGURES[name]
    assert measured == pytest.approx(value, abs=tol), (
        f"{name}: measured {measured:.6g}, README {value:g} ± {tol:g}"
    )


@pytest.fixture(scope="module")
def evaluation(te_seed0):
    return json.loads((te_seed0["E"] / "evaluation.json").read_text())


@pytest.fixture(scope="module")
def summary(te_seed0):
    return json.loads((te_seed0["V"] / "summary.json").read_text())


@pytest.fixture(scope="module")
def model_meta(te_seed0):
    return json.loads((te_seed0["M"] / "model.json").read_text())


# -- virtual bench ----------------------------------------------------------------------
@pytest.fixture(scope="module")
def eq3_mae(te_seed0):
    """Eq. (3) applied to the TE measured along no-load passes vs the simulated path error
    (the computation of ``benchmarks/bench_rack.py``), µm, per velocity."""
    from drivelash.control.path_error import predict_path_error
    from drivelash.sim.rack_axis import constant_velocity_pass
    from drivelash.te.protocol.campaign import load_campaign

    camp = load_campaign(te_seed0["C"])
    sim, bench = camp.simulator(), camp.bench
    out = {}
    for v in (0.01, 0.05, 0.1):
        _, xd, vd = constant_velocity_pass(0.05, bench.travel - 0.05, v)
        tr = sim.run(xd, vd, 0.0)
        e = tr["x_d"] - tr["x_T"]
        e_hat = predict_path_error(bench.te_from_measurement(tr["x_T"], tr["theta_m"]), tr["t"], bench.J_s,
                                   sim.gains)  # fmt: skip
        t_a = max(np.pi * v / (2 * 0.5), 0.05)
        sel = (tr["t"] > 0.1 + t_a + 0.3) & (tr["t"] < tr["t"][-1] - 0.1 - t_a - 0.01)
        out[v] = float(np.mean(np.abs(e - e_hat)[sel]) * 1e6)
    return out


@pytest.mark.parametrize(("name", "v"), [("eq3_mae_10mm_s_um", 0.01), ("eq3_mae_50mm_s_um", 0.05),
                                         ("eq3_mae_100mm_s_um", 0.1)])  # fmt: skip
def test_eq3_predicts_the_simulated_path_error(eq3_mae, name, v):
    _check(name, eq3_mae[v])


# -- learning ------------------------------------------------------------------------------
@network_figures
def test_training_mae(evaluation):
    _check("train_mae_um", evaluation["summary"]["train"]["mae"]["stacked"])


@network_figures
def test_held_out_mae_and_ratio(evaluation):
    s = evaluation["summary"]["held-out"]
    _check("heldout_mae_um", s["mae"]["stacked"])
    _check("heldout_ratio_pct", 100 * s["ratio"]["stacked"])


@network_figures
def test_extrapolation_mae_and_ratio(evaluation):
    s = evaluation["summary"]["extrapolation"]
    _check("extrapolation_mae_um", s["mae"]["stacked"])
    _check("extrapolation_ratio_pct", 100 * s["ratio"]["stacked"])


def test_stage1_share(model_meta):
    shares = [100 * m["stage1_share"] for m in model_meta["models"].values()]
    _check("stage1_share_min_pct", min(shares))
    _check("stage1_share_max_pct", max(shares))


def test_stacked_beats_every_baseline_at_every_held_out_load(evaluation):
    """README: better than every baseline pooled and at every held-out load."""
    for row in evaluation["table"]:
        if row["split"] == "held-out":
            mae = row["mae"]
            for base in ("geo-only", "stage1-only", "trees-only", "hgb"):
                assert mae["stacked"] < mae[base], (row["direction"], row["load"], base, mae)


# -- compensation ---------------------------------------------------------------------------
@network_figures
def test_constant_velocity_passes(summary):
    p = summary["passes"]
    _check("average_improvement_pct", 100 * p["average_improvement"])
    _check("min_in_range_pass_pct", 100 * p["min_in_range_pass_average"])
    _check("min_in_range_section_pct", 100 * p["min_in_range_section"])
    _check("min_beyond_range_pass_pct", 100 * p["min_beyond_range_pass_average"])


def test_sine_reversal_and_spectrum(summary):
    s = summary["sine"]
    _check("reversal_uncomp_um", max(s["reversal_error_uncomp_um"]))
    _check("reversal_comp_um", max(s["reversal_error_comp_um"]))
    _check("reversal_reduction_pct", 100 * s["reversal_reduction"])
    _check("hf_ratio", s["hf_ratio"])


def test_monitoring_flags_only_the_defect_and_update_restores(summary):
    m = summary["monitoring"]
    assert m["defect_covered"] and m["false_sections_per_m"] == 0.0  # "flagged (only its section)"
    # "a 15 µm rack defect at 1.305 m is flagged (only its section)": one flagged interval, one
    # 100 mm section, and it holds the defect (the sections start at the model's valid range,
    # 0.055 m on the seed-0 campaign — where its no-load curves hold data — so the edges are
    # 1255 / 1355 mm; before the valid-range fix they started at the runs' 0.0500107 m and the
    # defect sat at 1300.01 mm)
    centre_mm = 1e3 * summary["config"]["defect_center"]
    assert centre_mm == pytest.approx(1305.0, abs=0.1)  # the README's "at 1.305 m"
    ((lo, hi),) = m["flagged_intervals_mm"]
    assert hi - lo == pytest.approx(1e3 * summary["config"]["section_length"], abs=1e-6)
    assert lo < centre_mm < hi
    _check("monitor_defect_section_before_pct", 100 * m["improvement_defect_section_before_update"])
    _check("monitor_defect_section_after_pct", 100 * m["improvement_defect_section_after_update"])
    assert m["defect_flagged_after_update"] is False  # "and clears the flag"


def test_other_cpu_figures_the_readme_quotes(evaluation, summary):
    """On the CPU the README's second set of figures comes from (an AMD EPYC, session 27), they are
    measured at the quoted values (each with the tolerance of the reference figure of that name)."""
    if on_reference_cpu() or not cpu_model().startswith(OTHER_CPU_MODEL):
        pytest.skip(f"the other-CPU figures were measured on an {OTHER_CPU_MODEL}, this is {cpu_model()!r}")
    s, p = evaluation["summary"], summary["passes"]
    measured = {
        "train_mae_um": s["train"]["mae"]["stacked"],
        "heldout_mae_um": s["held-out"]["mae"]["stacked"],
        "heldout_ratio_pct": 100 * s["held-out"]["ratio"]["stacked"],
        "extrapolation_mae_um": s["extrapolation"]["mae"]["stacked"],
        "extrapolation_ratio_pct": 100 * s["extrapolation"]["ratio"]["stacked"],
        "average_improvement_pct": 100 * p["average_improvement"],
        "min_in_range_pass_pct": 100 * p["min_in_range_pass_average"],
        "min_in_range_section_pct": 100 * p["min_in_range_section"],
        "min_beyond_range_pass_pct": 100 * p["min_beyond_range_pass_average"],
    }
    for name, value in OTHER_CPU_MEASURED.items():
        assert measured[name] == pytest.approx(value, abs=FIGURES[name][1]), (name, measured[name], value)
