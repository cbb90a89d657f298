"""``drivelash te fit`` and ``drivelash te evaluate``: learn the transmission errors of a campaign.

Heavy imports (torch, optuna, scikit-learn, numba kernels) happen inside the commands.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import typer


def _parse_loads(text: str) -> tuple[float, ...]:
    from drivelash.errors import ParameterError

    if not text.strip():
        return ()
    try:
        return tuple(float(v) for v in text.split(","))
    except ValueError:
        raise ParameterError(
            "te fit", "holdout-loads", f"must be comma-separated numbers, got {text!r}"
        ) from None


def run_fit(
    campaign_dir: Path,
    model_dir: Path,
    max_load: float = 3000.0,
    holdout_loads: tuple[float, ...] = (1000.0, 2500.0),
    n_trials: int = 10,
    max_epochs: int = 40,
    echo: Any = print,
) -> dict[str, Any]:
    """Fit both directions on a campaign and save the model; returns the training record."""
    from drivelash.te.protocol.campaign import load_campaign

    t0 = time.perf_counter()
    camp = load_campaign(campaign_dir)  # fails early, before the heavy imports

    from drivelash.te.learn.fit import fit_te_model, prepare_campaign
    from drivelash.te.learn.network import MLPRegressor
    from drivelash.te.learn.stacked import StackedTERegressor
    from drivelash.te.runtime.persist import save_model

    pipeline, geo, runs = prepare_campaign(camp)
    t_prep = time.perf_counter() - t0
    echo(f"preprocessed {sum(len(r) for r in runs.values())} load runs in {t_prep:.1f} s")
    est = StackedTERegressor(nn=MLPRegressor(max_epochs=max_epochs), n_trials=n_trials)
    trained = fit_te_model(pipeline, geo, runs, max_load, holdout_loads, est, log=echo)
    trained.info["preprocess_s"] = t_prep
    trained.info["campaign"] = str(campaign_dir)
    trained.info["campaign_seed"] = camp.seed
    save_model(trained, model_dir)
    total = time.perf_counter() - t0
    echo(
        f"fit both directions (Hyperband + grid search) in {trained.info['fit_time_total_s']:.1f} s "
        f"(total with preprocessing {total:.1f} s) -> {model_dir}"
    )
    return trained.info


def _fit_baselines(X: Any, y: Any) -> tuple[Any, Any, Any]:
    """Geometric-only, trees-only (grid search as stage 2) and HGB (every 4th row) on one direction."""
    from drivelash.te.learn.baselines import GeometricOnly, fit_hgb, fit_trees_only

    return GeometricOnly().fit(X, y), fit_trees_only(X, y)[0], fit_hgb(X[::4], y[::4])


def run_evaluate(model_dir: Path, campaign_dir: Path, out_dir: Path | None = None, echo: Any = print) -> dict:
    """Score the saved model and the baselines per load and direction; write table, JSON and figure."""
    from drivelash.te.runtime.persist import load_model

    model = load_model(model_dir)  # fails early (and safely) on a bad model directory

    from drivelash.report.te_figures import plot_fig6
    from drivelash.te.learn.baselines import compare, format_table, mae_table, split_summary
    from drivelash.te.learn.fit import prepare_campaign, split_of, stack_runs
    from drivelash.te.protocol.campaign import load_campaign

    info = model.info
    max_load = float(info.get("max_load", 3000.0))
    holdout = tuple(float(v) for v in info.get("holdout_loads", ()))
    camp = load_campaign(campaign_dir)
    pipeline, _, runs = prepare_campaign(camp, model.pipeline)

    class _Loaded:
        def __init__(self, d: int, stage1: bool = False) -> None:
            self.d, self.stage1 = d, stage1

        def predict(self, X: Any) -> Any:
            f = model.predict_stage1_um if self.stage1 else model.predict_def_um
            return f(X[:, 0], X[:, 1], self.d)

    predictors: dict[str, dict[str, Any]] = {
        "stacked": {"pos": _Loaded(1), "neg": _Loaded(-1)},
        "geo-only": {},
        "stage1-only": {"pos": _Loaded(1, True), "neg": _Loaded(-1, True)},
        "trees-only": {},
        "hgb": {},
    }
    t0 = time.perf_counter()
    from joblib import Parallel, delayed

    keys = list(runs)
    data = {}
    for key in keys:
        train = [r for r in runs[key] if split_of(r.meta["load"], max_load, holdout) == "train"]
        data[key] = stack_runs(train, pipeline)
    fitted = Parallel(n_jobs=2, backend="loky")(delayed(_fit_baselines)(*data[k]) for k in keys)
    for key, (geo_only, trees, hgb) in zip(keys, fitted, strict=True):
        predictors["geo-only"][key] = geo_only
        predictors["trees-only"][key] = trees
        predictors["hgb"][key] = hgb
    echo(f"fitted the baselines in {time.perf_counter() - t0:.1f} s")
    rows = compare(predictors, runs, pipeline, lambda r: split_of(r.meta["load"], max_load, holdout))
    table = mae_table(rows)
    summary = split_summary(rows)
    text = format_table(table, summary)
    out = Path(out_dir) if out_dir is not None else Path(model_dir) / "evaluation"
    out.mkdir(parents=True, exist_ok=True)
    (out / "mae_table.txt").write_text(text + "\n", encoding="utf-8")
    (out / "evaluation.json").write_text(
        json.dumps({"rows": rows, "table": table, "summary": summary}, indent=1), encoding="utf-8"
    )
    figs = []
    for key, d in (("pos", 1), ("neg", -1)):
        train = [r for r in runs[key] if split_of(r.meta["load"], max_load, holdout) == "train"]
        run = max(train, key=lambda r: (r.meta["load"], -r.meta["velocity"]))
        p1 = model.predict_stage1_um(run.x, run.torque, d)
        pt = model.predict_def_um(run.x, run.torque, d)
        share = float(model.meta["models"][key]["stage1_share"])
        figs.append(plot_fig6(out / f"fig6_{key}.png", run, p1, pt, share, table, key))
    echo(text)
    echo(f"wrote {out}/mae_table.txt, evaluation.json, " + ", ".join(p.name for p in figs))
    return {"rows": rows, "table": table, "summary": summary}


def register(app: typer.Typer, te_app: typer.Typer) -> None:
    """Add ``te fit`` and ``te evaluate``."""

    @te_app.command("fit")
    def fit(
        campaign_dir: Path = typer.Argument(..., help="Campaign directory (drivelash te campaign)."),
        out: Path = typer.Option(..., "-o", "--out", help="Model directory to write."),
        max_load: float = typer.Option(3000.0, "--max-load", help="Largest training load [N]."),
        holdout_loads: str = typer.Option(
            "1000,2500",
            "--holdout-loads",
            help="Loads [N] <= max-load left out of training (comma-separated).",
        ),
        trials: int = typer.Option(10, "--trials", min=1, help="Optuna (Hyperband) trials per direction."),
        epochs: int = typer.Option(40, "--epochs", min=3, help="Maximum epochs of the network."),
    ) -> None:
        """Fit the stacked NN + bagged-tree model per direction on CAMPAIGN_DIR and save it to OUT."""
        run_fit(campaign_dir, out, max_load, _parse_loads(holdout_loads), trials, epochs, typer.echo)

    @te_app.command("evaluate")
    def evaluate(
        model_dir: Path = typer.Argument(..., help="Model directory (drivelash te fit)."),
        campaign_dir: Path = typer.Argument(..., help="Campaign directory."),
        out: Path = typer.Option(
            None, "-o", "--out", help="Output directory (default MODEL_DIR/evaluation)."
        ),
    ) -> None:
        """MAE per load and direction [µm], stacked vs baselines, and a figure like the paper's Fig. 6."""
        run_evaluate(model_dir, campaign_dir, out, typer.echo)
