"""``drivelash te score``: the compensation scored on the user's own recordings (issue 12 item 5).

Heavy imports happen inside the command.
"""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer, te_app: typer.Typer) -> None:
    """Add ``te score`` to the CLI."""

    @te_app.command("score")
    def score_cmd(
        uncompensated: Path = typer.Option(
            ...,
            "--uncompensated",
            help="Campaign directory (te import --for-score) of the passes without compensation.",
        ),
        compensated: Path = typer.Option(
            ...,
            "--compensated",
            help="Campaign directory (te import --for-score) of the same passes with compensation.",
        ),
        out: Path | None = typer.Option(
            None, "-o", "--out", help="Output directory: score.json, improvement_sections.csv, figure."
        ),
        gains: str = typer.Option(
            "auto",
            "--gains",
            help="Loop gains of eq. (3) for monitoring: axis (the axis file), identify (from the "
            "uncompensated recordings) or auto (axis file if it has them).",
        ),
        section_mm: float = typer.Option(100.0, "--section-mm", help="Section length [mm] (paper: 100)."),
        max_load: float | None = typer.Option(
            None, "--max-load", help="Largest training load [N]: passes above it count as beyond range."
        ),
        force: bool = typer.Option(False, "--force", help="Replace an existing output that is not ours."),
    ) -> None:
        """Improvement per 100 mm section and per pass from recorded passes, and monitoring by eq. (3)."""
        from drivelash.io.outputs import Outputs
        from drivelash.te.protocol.campaign import load_campaign
        from drivelash.te.protocol.score import ScoreConfig, score_campaigns

        cfg = ScoreConfig(section_length=section_mm * 1e-3, train_max_load=max_load)
        with Outputs("te score", inputs=[uncompensated, compensated], force=force) as outs:
            d = outs.directory(out, option="-o")
            unc = load_campaign(uncompensated)
            comp = load_campaign(compensated)
            result = score_campaigns(unc, comp, cfg, gains=gains, progress=typer.echo)
            if d is not None:
                _write(outs.staging(d), result, cfg, unc, comp)
        typer.echo(format_score(result))
        if out is not None:
            typer.echo(f"outputs in {out}/")


def _write(d: Path, result: dict, cfg: object, unc: object, comp: object) -> None:
    import csv
    import math

    from drivelash.io.outputs import write_json
    from drivelash.report.te_figures import fig_heatmaps

    d.mkdir(parents=True, exist_ok=True)
    doc = {k: v for k, v in result.items() if k != "rows"}
    doc["inputs"] = {"uncompensated": str(unc.directory), "compensated": str(comp.directory)}
    write_json(d / "score.json", doc)
    with (d / "improvement_sections.csv").open("w", newline="") as fh:
        fh.write("# drivelash te score: path-error MAE per section [um], improvement = 1 - comp/uncomp\n")
        w = csv.DictWriter(fh, fieldnames=list(result["rows"][0]))
        w.writeheader()
        for r in result["rows"]:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
    max_load = getattr(cfg, "train_max_load", None)
    if max_load is None or not math.isfinite(max_load):
        max_load = max(r["load"] for r in result["rows"])  # every pass in range: no dividing line
    fig_heatmaps(result["rows"], max_load, d / "fig9_improvement.png")


def format_score(result: dict) -> str:
    """The figures of a score as a short text block."""
    p = result["passes"]
    g = result["gains"]
    lines = [
        f"set position: {', '.join(result['set_position'])}",
        f"average improvement {100 * p['average_improvement']:.1f} % over {len(p['pass_averages'])} passes",
    ]
    for a in p["pass_averages"]:
        lines.append(f"  d={a['direction']:+d} v={a['velocity'] * 1e3:g} mm/s F={a['load']:g} N: "
                     f"{100 * a['improvement']:.1f} %")  # fmt: skip
    u = g["used"]
    if u is None:
        lines.append(f"eq. (3) gains ({g['source']}): implausible ({g.get('implausible')}), not used")
    else:
        lines.append(f"eq. (3) gains ({g['source']}): K_v {u['K_v']:.4g} 1/s, K_p {u['K_p']:.4g} N*m*s/rad, "
                     f"T_n {u['T_n'] * 1e3:.4g} ms")  # fmt: skip
    m = result.get("monitoring")
    if m:
        lines.append(f"monitoring: eq. (3) on the compensated passes' TE estimates the uncompensated "
                     f"path error within {100 * m['median_relative_error']:.1f} % (median over sections); "
                     f"estimated improvement {100 * m['average_improvement_estimated']:.1f} % "
                     f"(measured {100 * m['average_improvement_measured']:.1f} %)")  # fmt: skip
    for u in result.get("unmatched", []):
        lines.append(f"warning: {u}")
    for w in result.get("warnings", []):
        lines.append(f"warning: {w}")
    return "\n".join(lines)
