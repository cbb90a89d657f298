"""Small synthetic data for the transmission-error learning tests (no simulator needed)."""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.te.learn.preprocess import GearGeometry, GeometricCurve, TEPipeline

GEOM = GearGeometry(d_p=0.084882, n_t=20, i_pg=16.0, eps=2.68)
PITCH = np.pi * GEOM.d_p / GEOM.n_t
R_EFF = GEOM.d_p / (2 * GEOM.i_pg)
LOADS = (0.0, 500.0, 1000.0, 1500.0, 2000.0, 2500.0, 3000.0)


def te_def_um(x: np.ndarray, F: float, defect: float = 0.0) -> np.ndarray:
    """A smooth synthetic deformation [µm]: compliance, mesh change, pinion part, one local bump."""
    f = F / 3000.0
    return (
        -4.0 * f * (1 + 0.05 * np.cos(2 * np.pi * x / PITCH))
        - 1.5 * f * np.cos(2 * np.pi * x / PITCH + 0.4)
        + 0.3 * f * np.sin(2 * np.pi * x / (GEOM.n_t * PITCH))
        + 0.4 * f * np.exp(-0.5 * ((x - 0.12) / 0.01) ** 2)
        + defect * np.exp(-0.5 * ((x - 0.2) / 0.008) ** 2)
    )


def torque_of(F: float, x: np.ndarray) -> np.ndarray:
    """Motor torque [N·m] for load F [N]: F r_eff + friction, with a small ripple."""
    return F * R_EFF / 0.95 + 0.4 + 0.02 * np.sin(2 * np.pi * x / 0.05)


def pass_columns(model, x: np.ndarray, d: int, F: float, te_def: np.ndarray, T_s: float) -> dict:
    """The recorded columns of one constant-velocity pass over ``x`` [m] in direction ``d`` at
    load ``F`` [N]: TE = the model's TE_geo + d · ``te_def`` [µm]; θ_m from x − TE."""
    te = model.geometric(x, d) + d * te_def * 1e-6
    return {
        "t": np.arange(x.size) * T_s,
        "x_T": x,
        "theta_m": (x - te) * 2 * GEOM.i_pg / GEOM.d_p,
        "torque_m": torque_of(F, x),
        "direction": np.full(x.size, float(d)),
    }


def design(x: np.ndarray, F: float, pipe: TEPipeline) -> np.ndarray:
    return pipe.design_matrix(x, torque_of(F, x))


@pytest.fixture(scope="session")
def pipe() -> TEPipeline:
    return TEPipeline(GEOM)


@pytest.fixture(scope="session")
def grid_x() -> np.ndarray:
    return np.arange(0.0, 0.3, 100e-6)


@pytest.fixture(scope="session")
def train_xy(pipe: TEPipeline, grid_x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    loads = (0.0, 1000.0, 2000.0, 3000.0)
    X = np.vstack([design(grid_x, F, pipe) for F in loads])
    y = np.concatenate([te_def_um(grid_x, F) for F in loads])
    return X, y


@pytest.fixture(scope="session")
def small_trained(pipe: TEPipeline, train_xy: tuple[np.ndarray, np.ndarray]):
    """A quickly fitted trained model (no tuning) for persistence tests."""
    from drivelash.te.learn.fit import TrainedTEModel
    from drivelash.te.learn.network import MLPRegressor
    from drivelash.te.learn.stacked import StackedTERegressor, default_trees

    X, y = train_xy
    models = {}
    for k, sgn in (("pos", 1.0), ("neg", -1.0)):
        st = StackedTERegressor(
            nn=MLPRegressor(hidden=16, max_epochs=8, patience=3, batch_size=256),
            trees=default_trees().set_params(n_estimators=4),
            tune_nn=False,
            tune_trees=False,
            nn_stride=2,
        )
        models[k] = st.fit(X, sgn * y)
    xg = np.arange(0.0, 0.3 + 1e-9, 50e-6)
    geo = {
        "pos": GeometricCurve(0.0, 50e-6, 20e-6 * np.sin(2 * np.pi * xg / (GEOM.n_t * PITCH))),
        "neg": GeometricCurve(0.0, 50e-6, 40e-6 + 20e-6 * np.sin(2 * np.pi * xg / (GEOM.n_t * PITCH))),
    }
    return TrainedTEModel(
        pipe,
        geo,
        models,
        {"note": "synthetic"},
        {"pos": (-1.0, -0.5), "neg": (1.0, 0.4)},
        synthetic_context(),
    )


def synthetic_context(x_min: float = 0.0, x_max: float = 0.3, torque_max: float = 9.0):
    """The model context of a synthetic model: the paper's bench, the given valid range."""
    from drivelash.io.campaign import AxisBlock
    from drivelash.physics.rack_pinion import RackPinionBench
    from drivelash.te.runtime.compensator import CompensatorParams
    from drivelash.te.runtime.persist import CampaignInfo, ModelContext, ValidRange

    return ModelContext(
        axis=AxisBlock.of(RackPinionBench()),
        valid_range=ValidRange(x_min=x_min, x_max=x_max, torque_max=torque_max, loads=list(LOADS)),
        compensator=CompensatorParams(),
        campaign=CampaignInfo(source="imported"),
    )
