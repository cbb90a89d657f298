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
            None,
            "--max-load",
            help="Largest training load [N]: passes above it count as beyond range (default: the max load"
            " the imports recorded, te import --max-load).",
        ),
        force: bool = typer.Option(False, "--force", help="Replace an existing output that is not ours."),
    ) -> None:
        """Improvement per 100 mm section and per pass from recorded passes, and monitoring by eq. (3)."""
        from drivelash.io.outputs import Outputs
        from drivelash.te.protocol.campaign import load_campaign
        from drivelash.te.protocol.score import ScoreConfig, score_campaigns

        with Outputs("te score", inputs=[uncompensated, compensated], force=force) as outs:
            d = outs.directory(out, option="-o")
            unc = load_campaign(uncompensated)
            comp = load_campaign(compensated)
            source = "--max-load"
            if max_load is None:
                max_load, source = recorded_max_load(unc, comp), "the imports' max load"
            cfg = ScoreConfig(section_length=section_mm * 1e-3, train_max_load=max_load)
            result = score_campaigns(unc, comp, cfg, gains=gains, progress=typer.echo)
            result["train_max_load_source"] = source if max_load is not None else None
            if d is not None:
                _write(outs.staging(d), result, cfg, unc, comp)
        typer.echo(format_score(result))
        if out is not None:
            typer.echo(f"outputs in {out}/")


def recorded_max_load(*campaigns: object) -> float | None:
    """The training load limit [N] the imports recorded (``import.max_load`` of their manifests; the
    smallest if they differ), None if none did (finding D9: a 4000 N pass of a model trained to
    3000 N counted as in range unless ``--max-load`` was repeated)."""
    found = []
    for c in campaigns:
        block = getattr(getattr(c, "manifest", None), "import_", None) or {}
        v = block.get("max_load")
        if isinstance(v, (int, float)) and v > 0:
            found.append(float(v))
    return min(found) if found else None


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


def _pct(v: object) -> str:
    import math

    return f"{100 * v:.1f} %" if isinstance(v, float) and math.isfinite(v) else "n/a"


def format_score(result: dict) -> str:
    """The figures of a score as a short text block."""
    p = result["passes"]
    g = result["gains"]
    lines = [
        f"set position: {', '.join(result['set_position'])}",
        f"average improvement {100 * p['average_improvement']:.1f} % over {len(p['pass_averages'])} passes",
    ]
    lim = result.get("train_max_load")
    if lim is not None:
        inr, beyond = p.get("mean_in_range"), p.get("mean_beyond_range")
        n_in = sum(a["load"] <= lim for a in p["pass_averages"])
        n_out = len(p["pass_averages"]) - n_in
        src = result.get("train_max_load_source")
        split = f"in range (<= {lim:g} N{', ' + src if src else ''}) {_pct(inr)} over {n_in} pass(es)"
        split += f", beyond it {_pct(beyond)} over {n_out}" if n_out else ", none beyond it"
        lines.append(split)
    for a in p["pass_averages"]:
        beyond = " (beyond the training load)" if lim is not None and a["load"] > lim else ""
        lines.append(f"  d={a['direction']:+d} v={a['velocity'] * 1e3:g} mm/s F={a['load']:g} N: "
                     f"{100 * a['improvement']:.1f} %{beyond}")  # fmt: skip
    u = g["used"]
    if u is None:
        lines.append(f"eq. (3) gains ({g['source']}): implausible ({g.get('implausible')}), not used")
    else:
        weak = g["source"] == "identified"
        lines.append(f"eq. (3) gains ({g['source']}): K_v {u['K_v']:.4g} 1/s, K_p {u['K_p']:.4g} N*m*s/rad, "
                     f"T_n {u['T_n'] * 1e3:.4g} ms"
                     + (" (K_v identified; K_p, T_n weakly determined: effective values for eq. (3), not the"
                        " drive's velocity-controller settings)" if weak else ""))  # fmt: skip
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
