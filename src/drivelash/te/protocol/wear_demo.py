"""Protocol (c) of the validation: a local rack defect, flagged by the monitor, cleared by an update.

:func:`monitoring_demo` lets the rack of the virtual bench develop a local defect,
runs a compensated pass, flags sections with :func:`~drivelash.te.protocol.monitoring.monitor_pass`,
then (with a :class:`TreesUpdater`) refits stage 2 on passes over the worn rack and
checks that the flag clears and the improvement returns.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import DataError, ParameterError
from drivelash.te.protocol.bench import ValidationConfig, table_for
from drivelash.te.protocol.monitoring import (
    SectionReport,
    defect_covered,
    defect_flagged,
    false_sections_per_metre,
    monitor_pass,
    section_edges,
)
from drivelash.te.protocol.passes import pass_range, pass_trajectory, run_pass, score_pass
from drivelash.te.runtime.compensator import Compensator, CompensatorParams
from drivelash.te.runtime.table import TEPredictor, TETable

__all__ = ["TreesUpdater", "monitoring_demo"]


class TreesUpdater:
    """A trainable stacked model of the campaign, for the update half of the monitoring demo.

    The persisted model holds no scikit-learn objects (loading never unpickles), so it
    cannot be refitted; this fits the learner's :func:`drivelash.te.learn.fit.fit_te_model`
    in-process (reduced Hyperband budget; torch is imported here, never by the
    compensator), then :meth:`update` records passes over the worn rack, processes them
    with the *old* geometric curves and calls ``update(X, y, stage="trees")`` per
    direction.

    Parameters
    ----------
    n_trials : int
        Hyperband trials per direction.
    max_epochs : int
        Epoch limit of the network.
    update_velocity : float
        Speed of the new passes [m/s].
    update_loads : tuple of float
        Loads of the new passes [N] (within the training range; both directions).
    update_stride : int
        Every ``update_stride``-th row of the 50 µm grid enters the stage-2 refit
        (set on the models before :meth:`update`). The trees are piecewise constant in
        position, so a defect of slope s is learnt as a staircase with steps
        ≈ s × row spacing; (3) passes such steps to the path error almost unattenuated
        (G_d,CL → −1 at high frequency), the section monitor sees them as model error.
        The demo defect (15 µm, σ = 3 mm: s ≤ 3 µm/mm) on the learner's default
        400 µm rows (stride 8) leaves 1.2 µm steps and the defect section stays flagged
        after the update; on the full 50 µm grid (stride 1) the steps are 0.15 µm.
    echo : callable, optional
        Progress messages.

    Raises
    ------
    ParameterError
        ``update_stride`` is not a positive integer.
    """

    def __init__(
        self,
        n_trials: int = 4,
        max_epochs: int = 25,
        update_velocity: float = 0.05,
        update_loads: tuple[float, ...] = (0.0, 1000.0, 2000.0, 3000.0),
        update_stride: int = 1,
        echo: Callable[[str], None] | None = None,
    ) -> None:
        if not (isinstance(update_stride, (int, np.integer)) and update_stride >= 1):
            raise ParameterError(
                "TreesUpdater", "update_stride", f"must be a positive integer, got {update_stride!r}"
            )
        self.n_trials = n_trials
        self.max_epochs = max_epochs
        self.update_velocity = update_velocity
        self.update_loads = update_loads
        self.update_stride = int(update_stride)
        self.echo = echo or (lambda s: None)
        self.trained: Any = None
        self.fit_time_s = float("nan")
        self.update_time_s = float("nan")

    def fit(self, campaign: Any, max_load: float = 3000.0, reference: Any = None) -> TEPredictor:
        """Fit on the campaign's training runs (load ≤ ``max_load``); returns the model.

        With a ``reference`` (the loaded model being validated) its network and tree
        hyperparameters are reused and no search is run — the same architecture,
        refitted in minutes; otherwise ``n_trials`` Hyperband trials and the grid search.

        Parameters
        ----------
        campaign : Campaign
            The training campaign.
        max_load : float
            Largest training load [N].
        reference : TEModel, optional
            The loaded model being validated: its hyperparameters are reused.
        """
        import torch

        from drivelash.te.learn.fit import fit_te_model, prepare_campaign
        from drivelash.te.learn.network import MLPRegressor
        from drivelash.te.learn.stacked import StackedTERegressor

        torch.set_num_threads(2)
        t0 = time.perf_counter()
        pipeline, geo, runs = prepare_campaign(campaign)
        meta = getattr(reference, "meta", None) or {}
        pos = meta.get("models", {}).get("pos", {})
        nn_p = {k: v for k, v in pos.get("nn_params", {}).items() if k in ("hidden", "dropout", "lr")}
        tree_p = pos.get("tree_params") or {}
        if nn_p:
            from sklearn.base import clone

            from drivelash.te.learn.stacked import default_trees

            trees = clone(default_trees())
            if tree_p:
                trees.set_params(**tree_p)
            est = StackedTERegressor(nn=MLPRegressor(max_epochs=self.max_epochs, **nn_p), trees=trees,
                                     tune_nn=False, tune_trees=False)  # fmt: skip
        else:
            est = StackedTERegressor(nn=MLPRegressor(max_epochs=self.max_epochs), n_trials=self.n_trials)
        self.trained = fit_te_model(pipeline, geo, runs, max_load, (), est, log=self.echo)
        self.fit_time_s = time.perf_counter() - t0
        return self.trained

    def update(self, sim_worn: Any, lo: float, hi: float) -> TEPredictor:
        """Record passes on ``sim_worn`` over [lo, hi] and refit stage 2 only; returns the model.

        Parameters
        ----------
        sim_worn : RackAxisSimulator
            The bench with the worn rack.
        lo, hi : float
            Travel range of the new passes [m].

        Raises
        ------
        DataError
            :meth:`fit` was not called first.
        """
        if self.trained is None:
            raise DataError("TreesUpdater.update needs fit() first")
        from drivelash.te.learn.fit import stack_runs
        from drivelash.te.learn.preprocess import direction_key

        t0 = time.perf_counter()
        tr = self.trained
        r = float(sim_worn.bench.r_eff)
        for d in (1, -1):
            key = direction_key(d)
            runs = []
            _, x_d, v_d = pass_trajectory(sim_worn, lo, hi, self.update_velocity, d)
            for F in self.update_loads:
                res = run_pass(sim_worn, x_d, v_d, F, None, decimate=8)
                cols = {"x_T": res["x_T"], "theta_m": res["theta_m"], "torque_m": res["torque_m"],
                        "direction": np.sign(res["v_d"])}  # fmt: skip
                runs.append(tr.pipeline.process(cols, d, tr.geo[key], meta={"load": F}))
            X, y = stack_runs(runs, tr.pipeline)
            tr.models[key].set_params(update_stride=self.update_stride)
            tr.models[key].update(X, y, stage="trees")
        self.update_time_s = time.perf_counter() - t0
        del r
        return tr


def monitoring_demo(
    drive: Any,
    sim: Any,
    table: TETable,
    params: CompensatorParams,
    cfg: ValidationConfig,
    out: Path,
    updater: TreesUpdater | None,
    say: Callable[[str], None],
    reference: Any = None,
    figures: Any = None,
) -> dict[str, Any]:
    """Protocol (c): flag the defect with the old model, then update stage 2 and re-check.

    With an ``updater`` the demo uses its (trainable) model for both halves, so that
    before and after differ only by the stage-2 update; it is fitted on the drive's
    training campaign (:meth:`~drivelash.te.protocol.bench.ModelDrive.campaign`).
    """
    from drivelash.sim.rack_axis import RackAxisSimulator

    worn = sim.te_model.with_local_defect(cfg.defect_center, cfg.defect_width, cfg.defect_amplitude)
    sim_w = RackAxisSimulator(sim.bench, worn, gains=sim.gains, seed=sim.seed, config=sim.config)
    lo, hi = pass_range(sim, cfg)
    edges = section_edges(lo, hi, cfg.section_length)
    v, F = cfg.monitor_velocity, cfg.monitor_load
    _, x_d, v_d = pass_trajectory(sim_w, lo, hi, v, 1)
    defect = (cfg.defect_center - 2 * cfg.defect_width, cfg.defect_center + 2 * cfg.defect_width)

    held: list[float] = []  # share of the compensation cycles outside the table, per judged pass

    def judge(tab: TETable) -> tuple[SectionReport, float, np.ndarray]:
        unc = run_pass(sim_w, x_d, v_d, F, None)
        comp = run_pass(sim_w, x_d, v_d, F, Compensator(tab, params, 1))
        held.append(float(np.mean(comp["outside"])) if comp["outside"].size else 0.0)
        rep = monitor_pass(sim_w, tab, comp, v, edges)
        mu, mc = score_pass(unc, comp, v, edges)
        imp = 1.0 - mc / mu
        return rep, float(np.nanmean(imp)), imp

    tq_max = float(table.torque_grid(1)[-1])
    if updater is not None:
        say("    fitting a trainable model on the campaign (hyperparameters of the validated model)")
        xr = (float(table.x0), float(table.x_grid[-1]))
        table = table_for(updater.fit(drive.campaign(), cfg.train_max_load, reference), sim.bench, cfg,
                          torque_max=tq_max, x_range=xr)  # fmt: skip
    rep0, imp0_mean, imp0 = judge(table)
    k_def = int(np.searchsorted(edges, cfg.defect_center, side="right") - 1)
    res: dict[str, Any] = {
        "defect": {
            "x_center": cfg.defect_center,
            "sigma": cfg.defect_width,
            "amplitude": cfg.defect_amplitude,
        },
        "pass": {"velocity": v, "load": F, "direction": 1},
        "threshold_um": rep0.threshold * 1e6,
        "flagged_intervals_mm": [(a * 1e3, b * 1e3) for a, b in rep0.flagged_intervals()],
        "defect_covered": defect_covered(rep0, defect),
        "false_sections_per_m": false_sections_per_metre(rep0, defect),
        "improvement_mean_before_update": imp0_mean,
        "improvement_defect_section_before_update": float(imp0[k_def]),
        "estimated_improvement_defect_section": float(rep0.improvement[k_def]),
        "peak_model_error_defect_section_um_before_update": float(rep0.judged_value[k_def] * 1e6),
    }
    rep1 = rep0
    if updater is not None:
        say("    update(stage='trees') on passes over the worn rack")
        new_model = updater.update(sim_w, lo, hi)
        res["fit_time_s"] = updater.fit_time_s
        res["update_time_s"] = updater.update_time_s
        tab1 = table_for(new_model, sim.bench, cfg, torque_max=tq_max, x_range=xr)
        rep1, imp1_mean, imp1 = judge(tab1)
        res.update({
            "update_stride": updater.update_stride,
            "threshold_after_update_um": rep1.threshold * 1e6,
            "peak_model_error_defect_section_um_after_update": float(rep1.judged_value[k_def] * 1e6),
            "flagged_after_update_mm": [(a * 1e3, b * 1e3) for a, b in rep1.flagged_intervals()],
            "defect_flagged_after_update": defect_flagged(rep1, defect),
            "improvement_mean_after_update": imp1_mean,
            "improvement_defect_section_after_update": float(imp1[k_def]),
        })  # fmt: skip
    res["cycles_outside_share"] = max(held)
    if figures is not None:
        figures.fig_monitor(rep0, rep1, defect, out / "monitoring.png")
    return res
