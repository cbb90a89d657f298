"""Learning the transmission errors (spec 02 §3–4): preprocessing → features → stacked model → fit.

Names are imported on first use (scikit-learn is loaded only when a learner is
needed, so the runtime can use the preprocessing without it)::

    from drivelash.te.learn import TEPipeline, StackedTERegressor, fit_te_model, prepare_campaign
"""

from __future__ import annotations

import importlib
from typing import Any

#: Public name → submodule that defines it.
_EXPORTS: dict[str, str] = {
    # preprocessing
    "GRID_STEP": "preprocess",
    "GearGeometry": "preprocess",
    "GeometricCurve": "preprocess",
    "RunData": "preprocess",
    "TEPipeline": "preprocess",
    "direction_key": "preprocess",
    "lowpass": "preprocess",
    "transmission_error": "preprocess",
    # features
    "bump_features": "features",
    # stage 1
    "MLPRegressor": "network",
    "tune_mlp": "network",
    "PINNED_NUMERICS": "numerics",
    "pin_training_numerics": "numerics",
    # the stack
    "StackedTERegressor": "stacked",
    "default_trees": "stacked",
    # fitting a campaign
    "TrainedTEModel": "fit",
    "fit_te_model": "fit",
    "prepare_campaign": "fit",
    "split_of": "fit",
    "stack_runs": "fit",
    # baselines
    "GeometricOnly": "baselines",
    "StageOne": "baselines",
    "compare": "baselines",
    "fit_hgb": "baselines",
    "fit_trees_only": "baselines",
    "mae_table": "baselines",
    "split_summary": "baselines",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *_EXPORTS])
