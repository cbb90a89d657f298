"""``make demo`` step: a small compensation run that prints the improvement.

A reduced campaign (0.4 m stroke, three loads) is simulated on the virtual bench, a
small stacked model is trained on its loads ≤ 3000 N (one network configuration,
a few epochs, no hyperparameter search — the full search is ``drivelash te fit``),
sampled into the runtime table, and constant-velocity passes are run without and
with compensation. The campaign and model are cached in ``OUT/te-demo/`` so a second
run only simulates the passes.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

#: Demo campaign seed (any seed gives a statistically alike drive).
DEMO_SEED = 7


def small_model(work_dir: Path, echo: Any = None) -> tuple[Path, Path]:
    """A quick campaign and a small trained model in ``work_dir`` (cached); returns (campaign, model) dirs.

    Parameters
    ----------
    work_dir : pathlib.Path
        Cache directory (created).
    echo : callable, optional
        Progress messages.
    """
    from drivelash.sim.rack_campaign import CampaignConfig, run_campaign

    say = echo or (lambda s: None)
    work_dir = Path(work_dir)
    camp_dir = work_dir / "campaign"
    model_dir = work_dir / "model"
    _drop_stale_cache(camp_dir, model_dir)
    if not (camp_dir / "manifest.json").is_file():
        t0 = time.perf_counter()
        cfg = CampaignConfig(stroke=0.4, loads=(0.0, 1500.0, 3000.0, 4500.0), velocities=(0.02, 0.05, 0.1),
                             sine_amplitude=0.1, sine_periods=1.0, sine_loads=())  # fmt: skip
        run_campaign(camp_dir, seed=DEMO_SEED, config=cfg)
        say(f"  simulated a small campaign in {time.perf_counter() - t0:.1f} s")
    if not (model_dir / "model.json").is_file():
        import torch

        from drivelash.te.learn.fit import fit_te_model, prepare_campaign
        from drivelash.te.learn.network import MLPRegressor
        from drivelash.te.learn.stacked import StackedTERegressor
        from drivelash.te.protocol.bench import model_context
        from drivelash.te.protocol.campaign import load_campaign
        from drivelash.te.runtime.persist import save_model

        torch.set_num_threads(2)
        t0 = time.perf_counter()
        camp = load_campaign(camp_dir)
        pipeline, geo, runs = prepare_campaign(camp)
        est = StackedTERegressor(
            nn=MLPRegressor(hidden=32, max_epochs=20, patience=4),
            tune_nn=False,
            tune_trees=False,
            random_state=0,
        )
        trained = fit_te_model(pipeline, geo, runs, 3000.0, (), est)
        trained.context = model_context(camp, 3000.0)
        save_model(trained, model_dir)
        say(f"  trained a small stacked model in {time.perf_counter() - t0:.1f} s")
    return camp_dir, model_dir


def _drop_stale_cache(camp_dir: Path, model_dir: Path) -> None:
    """Remove a cached demo campaign/model this release cannot read (written by an older one)."""
    import shutil

    from drivelash.errors import DrivelashError
    from drivelash.te.protocol.campaign import load_campaign
    from drivelash.te.runtime.persist import load_model

    for d, load in ((camp_dir, load_campaign), (model_dir, load_model)):
        if d.is_dir():
            try:
                load(d)
            except DrivelashError:
                shutil.rmtree(d)
                if d == camp_dir:  # a model of a stale campaign is stale too
                    shutil.rmtree(model_dir, ignore_errors=True)


def demo_compensate(out_dir: Path, console: Any) -> None:
    """Train a small model, compensate constant-velocity passes, print the improvement.

    Parameters
    ----------
    out_dir : pathlib.Path
        Demo output directory; the cache and the exported table go to ``out_dir/te-demo``.
    console : rich.console.Console
        Where to print.
    """
    from drivelash.te.protocol.bench import ValidationConfig, drive_for_model, table_for
    from drivelash.te.protocol.passes import pass_trajectory, run_pass
    from drivelash.te.runtime.compensator import Compensator
    from drivelash.te.runtime.export import export_table
    from drivelash.te.runtime.persist import load_model
    from drivelash.te.runtime.table import measured_range

    console.print("[bold]Transmission-error compensation[/bold] (virtual rack-and-pinion bench)")
    t0 = time.perf_counter()
    work = Path(out_dir) / "te-demo"
    _, model_dir = small_model(work, console.print)
    model = load_model(model_dir)
    sim = drive_for_model(model).simulator()
    cfg = ValidationConfig()
    table = table_for(model, sim.bench, cfg, torque_max=model.context.valid_range.torque_max)
    params = model.context.compensator
    export_table(table, work / "te_table.json", params)
    lo, hi = measured_range(model)  # the passes stay where the model was measured (the table's span)
    rows = []
    for v, F in ((0.05, 1500.0), (0.1, 3000.0), (0.1, 4500.0)):
        _, x_d, v_d = pass_trajectory(sim, lo, hi, v, 1)
        res = []
        for comp in (None, Compensator(table, params, 1)):
            r = run_pass(sim, x_d, v_d, F, comp)
            m = np.abs(np.abs(r["v_d"]) - v) < 1e-9
            res.append(float(np.mean(np.abs(r["e"][m]))))
        rows.append((v, F, res[0], res[1]))
    console.print(f"  constant-velocity passes over {lo * 1e3:.1f} … {hi * 1e3:.1f} mm"
                  " (the model's valid range)")  # fmt: skip
    for v, F, mu, mc in rows:
        tag = "beyond training range" if F > 3000.0 else "in training range"
        console.print(f"  v = {v * 1e3:4.0f} mm/s, F = {F:5.0f} N ({tag}): path-error MAE "
                      f"{mu * 1e6:.3f} -> {mc * 1e6:.3f} um, improvement {1 - mc / mu:.0%}")  # fmt: skip
    console.print(f"  runtime table: {work / 'te_table.json'}; compensation demo took "
                  f"{time.perf_counter() - t0:.0f} s")  # fmt: skip
