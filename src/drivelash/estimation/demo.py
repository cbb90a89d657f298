"""Demo step: estimate the deadzone of the simulated ``bench-0A`` trace (``make demo``)."""

from __future__ import annotations

from pathlib import Path

from rich.console import Console

from drivelash.io.outputs import write_json

DEMO_SCENARIO = "bench-0A"


def demo_estimate(out_dir: Path, console: Console) -> None:
    """Run both estimator methods on ``out_dir/bench-0A.parquet`` and print them next to the truth.

    Simulates the scenario itself when the simulation step did not write the file. Writes
    ``estimate-bench-0A.json``, ``estimate-bench-0A.png`` and the self-contained HTML report
    ``estimate-bench-0A.html`` of the default method.
    """
    from drivelash.estimation.reproduce import estimate_scenario, score
    from drivelash.io.trace import Trace
    from drivelash.report import write_estimate_report
    from drivelash.report.estimation_figures import estimate_figure
    from drivelash.sim.scenarios import get_scenario

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    sc = get_scenario(DEMO_SCENARIO)
    path = out_dir / f"{DEMO_SCENARIO}.parquet"
    trace = Trace.from_parquet(path) if path.exists() else sc.simulate()
    summary = {}
    for method in ("paper", "default"):
        res = estimate_scenario(sc, trace, method)  # as `drivelash estimate --method`
        m = score(DEMO_SCENARIO, method, trace, res)
        summary[method] = m | {"reason": res.reason, "convergence_time_s": res.convergence_time_s}
        truth = float(trace["delta_true"][-1])
        console.print(
            f"estimate ({method:7s}): δ̂ = {1e3 * res.delta:8.3f} mrad   true δ = "
            f"{1e3 * truth:8.3f} mrad   error {1e3 * (res.delta - truth):+.3f}"
            f" mrad, MAEE(last 20 s) {1e3 * m['maee_rad']:.3f} mrad, into 10 mrad "
            + (f"after {c10:.2f} s" if (c10 := m["conv_10mrad_s"]) is not None else "not settled")
            + f", excitation {'ok' if res.excitation_ok else 'NOT ok'}"
            + f", {'converged' if res.converged else 'NOT converged'}"
        )
        if method == "default":
            estimate_figure(trace, res, out_dir / f"estimate-{DEMO_SCENARIO}.png")
            report = write_estimate_report(out_dir / f"estimate-{DEMO_SCENARIO}.html", trace, res)
            console.print(f"  report: {report}")
    write_json(out_dir / f"estimate-{DEMO_SCENARIO}.json", summary)
