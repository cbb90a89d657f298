"""``drivelash te update MODEL PASSES... -o NEW``: the wear update of a saved model (issue 12 item 4).

The update (stage 2, or both stages) is applied to the restored model and written as a
new model directory; the old one is an input and is never overwritten. The new model
records its parent (path, SHA-256, version) and the update; ``update/update.json`` and
``update/before_after.png`` give the before/after figures. Heavy imports (torch,
scikit-learn) happen inside the command.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import typer


def _parse_loads(text: str) -> tuple[float, ...]:
    from drivelash.errors import ParameterError

    if not text.strip():
        return ()
    try:
        return tuple(float(v) for v in text.split(","))
    except ValueError:
        raise ParameterError(
            "te update", "holdout-loads", f"must be comma-separated numbers, got {text!r}"
        ) from None


def _check_geometry(camp: Any, model: Any, path: Path) -> None:
    """A campaign of another axis (other module, teeth or ratio) is refused."""
    from drivelash.te.protocol.campaign import check_same_axis

    check_same_axis(camp, model.pipeline.geometry, path / "manifest.json", "the model's")


def _check_range(runs: dict[str, list[Any]], model: Any, tol: float = 1e-3) -> None:
    """Passes beyond the model's valid range (± ``tol`` [m]) are refused: their wear cannot be learnt.

    The valid range is :func:`~drivelash.te.runtime.table.measured_range` (where the no-load
    curves hold data, within the span the no-load runs covered), the range ``te export`` writes.
    """
    from drivelash.errors import DataError
    from drivelash.te.runtime.table import measured_range

    lo, hi = measured_range(model)
    for rs in runs.values():
        for r in rs:
            if r.x[0] < lo - tol or r.x[-1] > hi + tol:
                raise DataError(
                    f"pass covers x_T {r.x[0] * 1e3:.1f}..{r.x[-1] * 1e3:.1f} mm, outside the model's valid "
                    f"range {lo * 1e3:.1f}..{hi * 1e3:.1f} mm (refit with te fit instead)",
                    path=r.meta.get("file"),
                )


def _panel(key: str, r: Any, split: str, before: Any, after: Any) -> dict[str, Any]:
    d = r.direction
    return {
        "key": key,
        "name": r.meta.get("name", "?"),
        "split": split,
        "x": r.x,
        "measured": r.te_def_um,
        "before": before.predict_def_um(r.x, r.torque, d),
        "after": after.predict_def_um(r.x, r.torque, d),
    }


def run_update(
    model_dir: Path,
    passes: list[Path],
    out: Path,
    stage: str = "trees",
    holdout_loads: tuple[float, ...] = (),
    stride: int = 1,
    force: bool = False,
    echo: Any = print,
    accept_worse: bool = False,
    warn: Any = None,
) -> dict[str, Any]:
    """Update MODEL on the passes of one or more campaign directories; write the new version to ``out``.

    An update that raises a direction's TE_def MAE on the update (or held-out) passes by more
    than :data:`WORSE_REL` is refused unless ``accept_worse``; then it is written with a warning
    (``warn``, default ``echo``) and recorded in ``update/update.json`` (``worse``).
    """
    from drivelash.errors import DataError
    from drivelash.io.outputs import Outputs, write_json
    from drivelash.te.learn.update import (
        UPDATE_STAGES,
        align_to_parent,
        parent_record,
        restore_trained,
        runs_for_update,
        update_errors,
        update_trained,
    )
    from drivelash.te.protocol.campaign import load_campaign
    from drivelash.te.runtime.persist import load_model, save_model

    if stage not in UPDATE_STAGES:
        from drivelash.errors import ParameterError

        raise ParameterError(
            "te update", "stage", f"must be one of {', '.join(UPDATE_STAGES)}, got {stage!r}"
        )
    with Outputs("te update", inputs=[model_dir, *passes], force=force) as outs:
        target = outs.directory(out, option="-o")
        camps = [(Path(p), load_campaign(p)) for p in passes]  # fail early, before torch
        model, trained = restore_trained(model_dir)
        train: dict[str, list[Any]] = {k: [] for k in trained.models}
        held: dict[str, list[Any]] = {k: [] for k in trained.models}
        for p, camp in camps:
            _check_geometry(camp, model, p)
            for key, rs in runs_for_update(camp, trained).items():
                for r in rs:
                    is_held = any(np.isclose(r.meta["load"], h, rtol=0, atol=1e-6) for h in holdout_loads)
                    (held if is_held else train)[key].append(r)
        _check_range(train, model)
        _check_range(held, model)
        # the per-pass constant against the parent's prediction (finding A7), for the scores too
        align_to_parent(train, model)
        align_to_parent(held, model)
        if holdout_loads and not any(held.values()):
            raise DataError(
                f"no pass at the held-out loads {', '.join(f'{v:g}' for v in holdout_loads)} N",
                path=str(passes[0]),
            )
        n_train = sum(len(v) for v in train.values())
        echo(f"{n_train} update passes, {sum(len(v) for v in held.values())} held out; "
             f"updating model version {parent_record(model_dir, model.meta)['model_version']}")  # fmt: skip
        rec = update_trained(trained, train, stage=stage, update_stride=stride, log=echo, parent=model)
        errors = {"update": update_errors(model, trained, train)}
        if any(held.values()):
            errors["held_out"] = update_errors(model, trained, {k: v for k, v in held.items() if v})
        worse = worse_splits(errors)
        if worse and not accept_worse:
            cause = worse_cause(train, held, model)
            raise DataError(
                f"the update makes the model worse ({'; '.join(worse)}){f' — {cause}' if cause else ''}:"
                " nothing written; give --accept-worse to write it anyway, or refit with te fit",
                path=str(passes[0]),
            )
        parent = parent_record(model_dir, model.meta)
        rec.update({
            "parent": parent,
            "passes": [str(p.resolve()) for p in passes],
            "holdout_loads": list(holdout_loads),
            "mae_te_def_um": errors,
            "worse": worse,
            "accepted_worse": bool(worse),
        })  # fmt: skip
        info = trained.info
        info["model_version"] = parent["model_version"] + 1
        info["parent"] = parent
        info["updates"] = [*info.get("updates", []), {k: v for k, v in rec.items() if k != "parent"}]
        stage_dir = outs.staging(target)
        save_model(trained, stage_dir)
        check = load_model(stage_dir)  # the written version loads and predicts what was trained
        for key in trained.models:
            dd = 1 if key == "pos" else -1
            r = (train[key] or held[key])[0]
            diff = np.max(
                np.abs(check.predict_def_um(r.x, r.torque, dd) - trained.predict_def_um(r.x, r.torque, dd))
            )
            if not diff < 1e-6:
                raise DataError(
                    f"the written model differs from the updated one by {diff:.3g} um", path=str(out)
                )
        panels = []
        for key in sorted(trained.models):
            src, split = (held[key], "held-out") if held.get(key) else (train[key], "update")
            if src:
                r = max(src, key=lambda r: r.meta["load"])
                panels.append(_panel(key, r, split, model, trained))
        from drivelash.report.te_figures import fig_update

        (stage_dir / "update").mkdir()
        write_json(stage_dir / "update" / "update.json", rec)
        fig_update(panels, errors, stage, stage_dir / "update" / "before_after.png")
    echo(format_update(rec, out))
    if worse:
        (warn or echo)(
            f"warning: model version {rec['parent']['model_version'] + 1} in {out} is WORSE than its parent"
            f" ({'; '.join(worse)}); written because of --accept-worse (recorded in update/update.json)"
        )
    return rec


#: An update is "worse" when a direction's TE_def MAE after it exceeds the MAE before by more
#: than this share (on the update passes or, when given, the held-out passes).
WORSE_REL = 0.05


def worse_splits(errors: dict[str, dict[str, dict[str, Any]]]) -> list[str]:
    """The splits/directions whose TE_def MAE the update raised by more than :data:`WORSE_REL`."""
    out = []
    names = {"update": "update passes", "held_out": "held-out passes"}
    for split in ("held_out", "update"):
        for key, e in sorted(errors.get(split, {}).items()):
            b, a = float(e["before_um"]), float(e["after_um"])
            if not a <= b * (1 + WORSE_REL):
                out.append(f"{names[split]} {key}: TE_def MAE {b:.3f} um before, {a:.3f} um after")
    return out


#: The passes' TE_def error against the parent (MAE before the update) growing by more than this
#: factor from the lightest to the heaviest update pass of a direction (each at least
#: :data:`LOAD_GROWTH_MIN_UM` at the heaviest) names the cause "the passes' load dependence differs
#: from the model's": wear is local on the rack and does not scale with the load (the README's
#: 3 µm defect: the before-MAE is flat over 0 … 3000 N), another axis or drive stiffness does.
LOAD_GROWTH = 2.0
LOAD_GROWTH_MIN_UM = 0.5


def worse_cause(train: dict[str, list[Any]], held: dict[str, list[Any]], model: Any) -> str:
    """The measured cause of a worse update, when one is identifiable from the passes, else "".

    In order: held-out loads outside the update passes' load range (the update extrapolates its
    change to them); a pass error against the parent that grows with the load (by more than
    :data:`LOAD_GROWTH`: another axis or drive stiffness, not local wear). Session 36 (tester H):
    the refusal named the MAEs but not why.

    Parameters
    ----------
    train, held : dict
        Processed update and held-out passes per direction (``meta["load"]`` [N]).
    model : TEModel
        The parent (``predict_def_um``).
    """
    for key in sorted(held):
        hl = sorted({float(r.meta["load"]) for r in held[key]})
        tl = sorted({float(r.meta["load"]) for r in train.get(key, [])})
        out = [f for f in hl if tl and not tl[0] - 1e-6 <= f <= tl[-1] + 1e-6]
        if out:
            return (
                f"the held-out loads {', '.join(f'{f:g}' for f in out)} N ({key}) lie outside the update"
                f" passes' loads {tl[0]:g} … {tl[-1]:g} N: the update extrapolates its change to them —"
                " update on passes that span the loads"
            )
    for key in sorted(train):
        rs = sorted(train[key], key=lambda r: float(r.meta["load"]))
        if len({float(r.meta["load"]) for r in rs}) < 2:
            continue
        mae = [
            float(np.mean(np.abs(model.predict_def_um(r.x, r.torque, r.direction) - r.te_def_um))) for r in rs
        ]
        light, heavy = mae[0], mae[-1]
        if heavy >= LOAD_GROWTH_MIN_UM and heavy > LOAD_GROWTH * light:
            return (
                f"the passes differ from the model by {light:.3f} um at {rs[0].meta['load']:g} N and"
                f" {heavy:.3f} um at {rs[-1].meta['load']:g} N ({key}): a load dependence other than the"
                " model's (another axis or drive stiffness), which a wear update does not learn"
            )
    return ""


def format_update(rec: dict[str, Any], out: Path) -> str:
    """The before/after figures of an update as text."""
    lines = []
    for split, label in (("update", "update passes"), ("held_out", "held-out passes")):
        for key, e in sorted(rec["mae_te_def_um"].get(split, {}).items()):
            lines.append(f"{label} {key}: TE_def MAE {e['before_um']:.3f} um before, "
                         f"{e['after_um']:.3f} um after ({e['n_runs']} passes)")  # fmt: skip
    lines.append(f"wrote model version {rec['parent']['model_version'] + 1} to {out} "
                 f"(parent {rec['parent']['path']} kept); figures in {out}/update/")  # fmt: skip
    return "\n".join(lines)


def register(app: typer.Typer, te_app: typer.Typer) -> None:
    """Add ``te update`` to the CLI."""

    @te_app.command("update")
    def update_cmd(
        model_dir: Path = typer.Argument(..., help="Model directory (te fit or an earlier te update)."),
        passes: list[Path] = typer.Argument(..., help="Campaign directories with passes over the worn axis."),
        out: Path = typer.Option(..., "-o", "--out", help="Directory of the new model version."),
        stage: str = typer.Option(
            "trees", "--stage", help="trees (stage 2 only) or both (network, then trees)."
        ),
        holdout_loads: str = typer.Option(
            "",
            "--holdout-loads",
            help="Loads [N] of passes kept out of the update, to judge it (comma-separated).",
        ),
        stride: int = typer.Option(
            1, "--stride", min=1, help="Every n-th 50 um grid row enters the tree refit."
        ),
        force: bool = typer.Option(False, "--force", help="Replace an existing output that is not ours."),
        accept_worse: bool = typer.Option(
            False,
            "--accept-worse",
            help="Write the new version even if it predicts the passes worse than its parent (warned).",
        ),
    ) -> None:
        """Update MODEL_DIR for wear on PASSES (stage 2, or both stages) and write it as a new version."""
        run_update(
            model_dir, passes, out, stage, _parse_loads(holdout_loads), stride, force, typer.echo,
            accept_worse=accept_worse, warn=lambda line: typer.echo(f"drivelash: {line}", err=True),
        )  # fmt: skip
