"""Demo step: an ISO 230-2 evaluation of a simulated laser check (``make demo``)."""

from __future__ import annotations

from pathlib import Path

from rich.console import Console

#: The demo axis: 0.5 m ball-screw axis with 12 µm lost motion (``SyntheticAxis`` defaults).
DEMO_TARGETS = 11
DEMO_RUNS = 5


def demo_iso230(out_dir: Path, console: Console) -> None:
    """Simulate the standard test cycle with a laser, evaluate it, write JSON and HTML.

    Writes ``iso230-recording.csv`` (t, commanded, laser, encoder in mm),
    ``iso230.json`` and the report ``iso230.html`` (the standard's chart, the dwells).
    """
    from drivelash.commands.iso230 import run_iso230
    from drivelash.io.outputs import Outputs
    from drivelash.io.trace import Trace
    from drivelash.iso230.synthetic import SyntheticAxis, synthetic_recording

    out_dir = Path(out_dir)
    axis = SyntheticAxis()
    cols, _ = synthetic_recording(axis, m=DEMO_TARGETS, n=DEMO_RUNS, seed=0)
    with Outputs("demo", force=True) as out:  # the demo directory is the demo's own
        rec = out.file(out_dir / "iso230-recording.csv", option="-o", kinds=(".csv",))
        assert rec is not None
        Trace(
            {
                "t": cols["t"],
                "cmd_mm": cols["P_cmd"] * 1e3,
                "laser_mm": cols["P_actual"] * 1e3,
                "encoder_mm": cols["P_axis"] * 1e3,
            },
            {"source": "drivelash demo: synthetic ISO 230-2 test, lost motion 12 um"},
        ).to_csv(out.staging(rec))
    config = Path(__file__).resolve().parents[3] / "examples" / "iso230_recording.toml"
    s = run_iso230(
        rec, config, json_out=out_dir / "iso230.json", report=out_dir / "iso230.html", force=True, quiet=True
    )
    r, d = s["reversal"], s["drift"]
    console.print(
        f"iso230: {s['targets']} targets × {s['runs_per_direction']} runs,"
        f" {s['dwells']['count']} dwells found;"
        f" B = {r['B'] * 1e6:.2f} µm, −B̄ = {-r['B_mean'] * 1e6:.2f} ± {r['u_B_mean'] * 1e6:.2f} µm, of which"
        f" {-d['bias_B_mean'] * 1e6:.2f} µm is laser drift ({d['rate'] * 3.6e9:.0f} µm/h)"
        f" — simulated lost motion {axis.delta * 1e6:.0f} µm; report: {out_dir / 'iso230.html'}"
    )
