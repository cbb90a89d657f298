"""How much a learned TE model depends on its training seed and on the last digits of its data.

Run from the repository root on a campaign (the README's: ``drivelash te campaign -o C --seed 0``)::

    .venv/bin/python examples/te_seed_spread.py C [--seeds 5] [--noise-um 2.6e-5]

It fits the stacked model exactly as ``drivelash te fit C`` does (same defaults: Hyperband with
10 trials of at most 40 epochs, then the trees), once per training seed 0 … K−1
(``StackedTERegressor(random_state=s)``, seed 0 is ``te fit``'s model), and once more with seed 0
on the same runs with white noise of ``--noise-um`` µm RMS added to the target TE_def — the size
of the difference between the simulator's data and the same data written as CNC traces and read
back (issue 12's round trip). It prints the training, held-out and extrapolation MAE [µm] of each
model, of the averages of the first k seeds' predictions, and of the perturbed model, all scored
on the unperturbed runs (the splits of ``te evaluate``).

What it shows (docs/assumptions.md, "Stage 1"): the training is chaotic in its data, so a single
network's held-out and extrapolation MAE are a draw from a wide spread; the average over seeds
is better and steadier. It takes about K + 1 times a ``te fit`` (≈ 2 min each on 2 cores).
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np

from drivelash.te.learn.baselines import compare, split_summary
from drivelash.te.learn.fit import TrainedTEModel, default_holdout, fit_te_model, prepare_campaign, split_of
from drivelash.te.learn.network import MLPRegressor
from drivelash.te.learn.stacked import StackedTERegressor
from drivelash.te.protocol.campaign import load_campaign

#: ``drivelash te fit``'s defaults (commands/te_model.py).
MAX_LOAD, N_TRIALS, MAX_EPOCHS = 3000.0, 10, 40


class _Mean:
    """Predictor of one direction: the mean TE_def [µm] of several fitted models."""

    def __init__(self, models: list[TrainedTEModel], direction: int) -> None:
        self.models, self.direction = models, direction

    def predict(self, X: np.ndarray) -> np.ndarray:
        return np.mean([m.predict_def_um(X[:, 0], X[:, 1], self.direction) for m in self.models], axis=0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("campaign", type=Path)
    ap.add_argument("--seeds", type=int, default=5, help="training seeds 0 … K−1 (default 5)")
    ap.add_argument("--noise-um", type=float, default=2.6e-5, help="noise on TE_def [µm RMS]")
    a = ap.parse_args()

    camp = load_campaign(a.campaign)
    holdout = default_holdout(camp.loads, MAX_LOAD)
    pipeline, geo, runs = prepare_campaign(camp)

    def fit(seed: int, data: dict) -> TrainedTEModel:
        est = StackedTERegressor(
            nn=MLPRegressor(max_epochs=MAX_EPOCHS, random_state=seed), n_trials=N_TRIALS, random_state=seed
        )
        print(f"-- training seed {seed}")
        return fit_te_model(pipeline, geo, data, MAX_LOAD, holdout, est, log=print)

    models = [fit(s, runs) for s in range(a.seeds)]
    rng = np.random.default_rng(0)
    noisy = {
        k: [replace(r, te_def_um=r.te_def_um + rng.normal(0.0, a.noise_um, r.te_def_um.size)) for r in v]
        for k, v in runs.items()
    }
    perturbed = fit(0, noisy)

    preds = {f"seed {s}": [m] for s, m in enumerate(models)}
    preds.update({f"mean of seeds 0-{k - 1}": models[:k] for k in range(2, a.seeds + 1)})
    preds[f"seed 0, target + {a.noise_um:g} um noise"] = [perturbed]
    predictors = {name: {"pos": _Mean(ms, 1), "neg": _Mean(ms, -1)} for name, ms in preds.items()}
    rows = compare(predictors, runs, pipeline, lambda r: split_of(r.meta["load"], MAX_LOAD, holdout))
    summary = split_summary(rows)
    splits = [s for s in ("train", "held-out", "extrapolation") if s in summary]
    print(f"\nMAE of TE_def [um] on {a.campaign} (held out: {', '.join(f'{h:g} N' for h in holdout)})")
    print(f"{'model':<40}" + "".join(f"{s:>15}" for s in splits))
    for name in preds:
        print(f"{name:<40}" + "".join(f"{summary[s]['mae'][name]:>15.4f}" for s in splits))


if __name__ == "__main__":
    main()
