"""KUKA KR300: the backlash of axes 1-3 in recordings A, B, C — one report per recording.

Run from the repository root (needs ../shared/data/kuka-kr300)::

    .venv/bin/python examples/kuka/summary.py OUTDIR

For each recording it runs ``drivelash identify --model two-mass --json --report`` on axes
1-3 (``examples/kuka/axisN.toml``), then the ``estimate --identify`` computation (the online
law on the identified drive, or the reason it cannot run), and writes ``OUTDIR/kuka_<rec>.md``
(the three axes: lost motion with its 95 % interval or the stated reason it cannot be
determined, the online δ̂, the excitation verdict, the fit diagnostics) beside the per-axis
JSON and HTML reports, and
``OUTDIR/kuka_summary.md``: the nine cases and the spread across A-C.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[1] / ".." / "shared" / "data" / "kuka-kr300"
RECORDINGS = ("A", "B", "C")
AXES = (1, 2, 3)


def _mrad(x: float | None) -> str:
    return "–" if x is None or not math.isfinite(x) else f"{1e3 * x:.3g}"


def run(outdir: Path) -> dict[str, dict[int, dict]]:
    """Identify the nine cases, write the reports, return the JSON summaries."""
    import drivelash as dl
    from drivelash.commands.data import run_identify
    from drivelash.estimation.backlash_api import estimate_with_identification

    outdir.mkdir(parents=True, exist_ok=True)
    results: dict[str, dict[int, dict]] = {}
    for rec in RECORDINGS:
        results[rec] = {}
        for axis in AXES:
            stem = outdir / f"kuka_{rec}_axis{axis}"
            results[rec][axis] = run_identify(
                DATA / f"rec_{rec}.mat",
                HERE / f"axis{axis}.toml",
                model="two-mass",
                json_out=stem.with_suffix(".json"),
                report=stem.with_suffix(".html"),
                quiet=True,
                force=True,
            )
            cfg = dl.load_config(HERE / f"axis{axis}.toml")
            trace = dl.load_trace(DATA / f"rec_{rec}.mat", cfg)
            results[rec][axis]["online"] = estimate_with_identification(trace, cfg).summary
        (outdir / f"kuka_{rec}.md").write_text(recording_report(rec, results[rec]), encoding="utf-8")
    (outdir / "kuka_summary.md").write_text(summary_table(results), encoding="utf-8")
    return results


def _row(doc: dict) -> tuple[str, str, str]:
    d = doc["parameters"]["delta"]
    if d["identifiable"]:
        val = f"{_mrad(d['value'])} [{_mrad(d['ci95'][0])}, {_mrad(d['ci95'][1])}]"
    else:
        low = d["ci95"][0]  # None (JSON null) when the interval is open
        val = f"not determined (≥ {_mrad(low)})" if low is not None and low > 0 else "not determined"
    return val, "yes" if doc["backlash_visible"] else "no", doc["backlash_reason"]


def recording_report(rec: str, docs: dict[int, dict]) -> str:
    """Markdown report of one recording (axes 1-3)."""
    lines = [
        f"# KUKA KR300, recording {rec}: backlash of axes 1-3\n",
        "| axis | lost motion δ [mrad] (95 % interval) | online δ̂ [mrad] | backlash seen | verdict | "
        "K_S [N·m/rad] | rel. motor error | plausible |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for axis, doc in docs.items():
        val, seen, why = _row(doc)
        ks = doc["parameters"]["K_S"]
        ks_s = f"{ks['value']:.3g}" if ks["identifiable"] else "–"
        rel = doc["fit"].get("relative_error_motor")
        ok = "yes" if doc["plausible"] else "no"
        on = doc["online"]
        online = _mrad(on["delta"]) if on["delta"] is not None else on["reason"]
        rel_s = f"{rel:.2f}" if rel is not None else "–"
        lines.append(f"| {axis} | {val} | {online} | {seen} | {why} | {ks_s} | {rel_s} | {ok} |")
    lines.append("")
    for axis, doc in docs.items():
        for w in doc["warnings"]:
            lines.append(f"- axis {axis}: {w}")
        for n in doc["fit"].get("notes", []):
            lines.append(f"- axis {axis} (note): {n}")
    return "\n".join(lines) + "\n"


def summary_table(results: dict[str, dict[int, dict]]) -> str:
    """The nine cases side by side, one row per axis, and the spread across A-C."""
    lines = [
        "| axis | A | B | C | spread of δ across A-C |",
        "|---|---|---|---|---|",
    ]
    for axis in AXES:
        cells = []
        vals = []
        for rec in RECORDINGS:
            doc = results[rec][axis]
            cells.append(_row(doc)[0])
            d = doc["parameters"]["delta"]
            if d["identifiable"]:
                vals.append(d["value"])
        spread = (
            f"{_mrad(max(vals) - min(vals))} mrad ({len(vals)} of 3 determined)"
            if len(vals) > 1
            else (f"{len(vals)} of 3 determined")
        )
        lines.append(f"| {axis} | " + " | ".join(cells) + f" | {spread} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "kuka-output")
    res = run(out)
    print((out / "kuka_summary.md").read_text(encoding="utf-8"))
    print(json.dumps({r: {a: d["backlash_reason"] for a, d in v.items()} for r, v in res.items()}, indent=1))
