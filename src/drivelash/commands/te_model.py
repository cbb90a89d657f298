"""``drivelash te fit`` and ``drivelash te evaluate``: learn the transmission errors of a campaign.

Heavy imports (torch, optuna, scikit-learn, numba kernels) happen inside the commands.
"""

from __future__ import annotations

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
    holdout_loads: tuple[float, ...] | None = None,
    n_trials: int = 10,
    max_epochs: int = 40,
    echo: Any = print,
    force: bool = False,
    warn: Any = None,
) -> dict[str, Any]:
    """Check, fit both directions on a campaign and save the model; returns the training record.

    Parameters
    ----------
    campaign_dir, model_dir : Path
        Input campaign, output model directory (written as a whole, atomically).
    max_load : float
        Largest training load [N].
    holdout_loads : tuple of float, optional
        Loads [N] left out of training; None derives them from the campaign's loads
        (:func:`~drivelash.te.learn.fit.default_holdout`).
    n_trials, max_epochs : int
        Hyperband trials per direction, epoch limit of the network.
    echo, warn : callable
        Progress lines; plausibility warnings (default: ``echo``).
    force : bool
        Replace ``model_dir`` even if it is not a drivelash output.
    """
    from drivelash.io.outputs import Outputs
    from drivelash.te.protocol.campaign import load_campaign

    warn = warn or echo
    t0 = time.perf_counter()
    with Outputs("te fit", inputs=[campaign_dir], force=force) as out:
        d = out.directory(model_dir, option="-o")
        camp = load_campaign(campaign_dir)  # fails early, before the heavy imports

        from drivelash.te.learn.fit import default_holdout
        from drivelash.te.protocol.plausibility import check_campaign

        report = check_campaign(camp, max_load)
        report.raise_errors()  # an error is the one line the user sees; warnings only when it goes on
        for f in report.warnings:
            warn(f.line())
        holdout = default_holdout(camp.loads, max_load) if holdout_loads is None else tuple(holdout_loads)
        _check_holdout(holdout, camp.loads, max_load, camp.manifest_path)

        from drivelash.te.learn.fit import fit_te_model, prepare_campaign
        from drivelash.te.learn.network import MLPRegressor
        from drivelash.te.learn.stacked import StackedTERegressor
        from drivelash.te.protocol.bench import model_context
        from drivelash.te.runtime.persist import save_model

        pipeline, geo, runs = prepare_campaign(camp)
        t_prep = time.perf_counter() - t0
        echo(
            f"preprocessed {sum(len(r) for r in runs.values())} load runs in {t_prep:.1f} s; held out: "
            + (", ".join(f"{f:g} N" for f in holdout) or "none")
        )
        est = StackedTERegressor(nn=MLPRegressor(max_epochs=max_epochs), n_trials=n_trials)
        trained = fit_te_model(pipeline, geo, runs, max_load, holdout, est, log=echo)
        trained.info["preprocess_s"] = t_prep
        trained.info["plausibility"] = report.to_dict()
        trained.context = model_context(camp, max_load, holdout, valid_x=report.valid_range)
        save_model(trained, out.staging(d))
    total = time.perf_counter() - t0
    echo(
        f"fit both directions (Hyperband + grid search) in {trained.info['fit_time_total_s']:.1f} s "
        f"(total with preprocessing {total:.1f} s) -> {model_dir}"
    )
    for line in trained.info.get("limitations", []):
        echo(f"limitation: {line}")
    num = trained.info["numerics"]  # always recorded by fit_te_model
    echo(
        f"torch code path: ATen {num['aten_in_use']}, MKL_CBWR={num['MKL_CBWR']} ("
        + (
            "pinned: the same network on every Intel CPU with AVX2"
            if num["pinned"]
            else "not the pinned AVX2 path: the network may differ on other machines"
        )
        + ")"
    )
    return trained.info


def _check_holdout(holdout: tuple[float, ...], loads: tuple[float, ...], max_load: float, where: Any) -> None:
    """Every held-out load is an in-range load of the campaign, and two training loads remain."""
    from drivelash.errors import DataError, ParameterError

    for h in holdout:
        if not any(abs(h - f) < 1e-6 for f in loads):
            have = ", ".join(f"{f:g}" for f in loads)
            raise ParameterError(
                "te fit", "holdout-loads", f"{h:g} N is not a load of the campaign ({have} N)"
            )
        if h > max_load + 1e-9:
            raise ParameterError("te fit", "holdout-loads", f"{h:g} N is above --max-load {max_load:g} N")
    train = [f for f in loads if f <= max_load + 1e-9 and all(abs(f - h) > 1e-6 for h in holdout)]
    if len(train) < 2:
        held = ", ".join(f"{h:g}" for h in holdout)
        msg = f"only {len(train)} training load(s) left after holding out {held} N; hold out fewer loads"
        raise DataError(msg, path=str(where))


def _fit_baselines(X: Any, y: Any) -> tuple[Any, Any, Any]:
    """Geometric-only, trees-only (grid search as stage 2) and HGB (every 4th row) on one direction."""
    from drivelash.te.learn.baselines import GeometricOnly, fit_hgb, fit_trees_only

    return GeometricOnly().fit(X, y), fit_trees_only(X, y)[0], fit_hgb(X[::4], y[::4])


def run_evaluate(
    model_dir: Path, campaign_dir: Path, out_dir: Path | None = None, echo: Any = print, force: bool = False
) -> dict:
    """Score the saved model and the baselines per load and direction; write table, JSON and figure."""
    from drivelash.io.outputs import Outputs

    default = Path(model_dir) / "evaluation"
    target = Path(out_dir) if out_dir is not None else default
    with Outputs(
        "te evaluate", inputs=[model_dir, campaign_dir], force=force, allow_inside=[default]
    ) as outs:
        d = outs.directory(target, option="-o")
        result = _evaluate(model_dir, campaign_dir, outs.staging(d), echo)
    echo(f"wrote {target}/mae_table.txt, evaluation.json, fig6_pos.png, fig6_neg.png")
    return result


def _evaluate(model_dir: Path, campaign_dir: Path, out: Path, echo: Any) -> dict:
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
    from drivelash.io.outputs import GENERATOR, write_json

    (out / "mae_table.txt").write_text(f"# {GENERATOR}\n" + text + "\n", encoding="utf-8")
    write_json(out / "evaluation.json", {"rows": rows, "table": table, "summary": summary}, indent=1)
    for key, d in (("pos", 1), ("neg", -1)):
        train = [r for r in runs[key] if split_of(r.meta["load"], max_load, holdout) == "train"]
        run = max(train, key=lambda r: (r.meta["load"], -r.meta["velocity"]))
        p1 = model.predict_stage1_um(run.x, run.torque, d)
        pt = model.predict_def_um(run.x, run.torque, d)
        share = float(model.meta["models"][key]["stage1_share"])
        plot_fig6(out / f"fig6_{key}.png", run, p1, pt, share, table, key)
    echo(text)
    return {"rows": rows, "table": table, "summary": summary}


def register(app: typer.Typer, te_app: typer.Typer) -> None:
    """Add ``te fit`` and ``te evaluate``."""

    @te_app.command("fit")
    def fit(
        campaign_dir: Path = typer.Argument(..., help="Campaign directory (drivelash te campaign)."),
        out: Path = typer.Option(..., "-o", "--out", help="Model directory to write."),
        max_load: float = typer.Option(3000.0, "--max-load", help="Largest training load [N]."),
        holdout_loads: str = typer.Option(
            "auto",
            "--holdout-loads",
            help="Loads [N] <= max-load left out of training (comma-separated; '' for none);"
            " 'auto' derives them from the campaign's loads.",
        ),
        trials: int = typer.Option(10, "--trials", min=1, help="Optuna (Hyperband) trials per direction."),
        epochs: int = typer.Option(40, "--epochs", min=3, help="Maximum epochs of the network."),
        force: bool = typer.Option(
            False, "--force", help="Replace OUT even if it is not a drivelash output."
        ),
    ) -> None:
        """Check the campaign, fit the stacked NN + bagged-tree model per direction, save it to OUT."""
        import math

        from drivelash.errors import ParameterError

        if not (math.isfinite(max_load) and max_load > 0):
            raise ParameterError("te fit", "max-load", f"must be a finite number > 0, got {max_load!r}")
        holdout = None if holdout_loads.strip() == "auto" else _parse_loads(holdout_loads)
        run_fit(campaign_dir, out, max_load, holdout, trials, epochs, typer.echo, force=force, warn=_warn)

    @te_app.command("evaluate")
    def evaluate(
        model_dir: Path = typer.Argument(..., help="Model directory (drivelash te fit)."),
        campaign_dir: Path = typer.Argument(..., help="Campaign directory."),
        out: Path = typer.Option(
            None, "-o", "--out", help="Output directory (default MODEL_DIR/evaluation)."
        ),
        force: bool = typer.Option(
            False, "--force", help="Replace OUT even if it is not a drivelash output."
        ),
    ) -> None:
        """MAE per load and direction [µm], stacked vs baselines, and a figure like the paper's Fig. 6."""
        run_evaluate(model_dir, campaign_dir, out, typer.echo, force=force)


def _warn(line: str) -> None:
    typer.echo(f"drivelash: warning: {line}", err=True)
