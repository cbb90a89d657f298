"""The runtime of a learned TE model: loaded model, table, compensator, exports (no torch).

::

    from drivelash.te.runtime import (
        Compensator, CompensatorParams, build_table, export_table, load_model, measured_range,
    )

    model = load_model(MODEL_DIR)                       # NumPy/numba predictor, validated on load
    x_min, x_max = measured_range(model)                # [m]; build_table refuses positions beyond it
    table = build_table(model, x_min, x_max, 0.2e-3, torque_max, n_torque)
    comp = Compensator(table, CompensatorParams(...))
    v_c, v_te, v_bl = comp.step(x_d_n, x_d_next, torque_m, omega_m, alpha_m)   # every 5 ms
"""

from drivelash.te.runtime.compensator import Compensator, CompensatorParams, compensate_run, init_state
from drivelash.te.runtime.export import export_table, load_table
from drivelash.te.runtime.persist import ModelFileError, load_model, save_model
from drivelash.te.runtime.predictor import TEModel, te_def_point, te_point
from drivelash.te.runtime.table import TEPredictor, TETable, build_table, measured_range, table_te

__all__ = [
    "Compensator",
    "CompensatorParams",
    "ModelFileError",
    "TEModel",
    "TEPredictor",
    "TETable",
    "build_table",
    "compensate_run",
    "export_table",
    "init_state",
    "load_model",
    "load_table",
    "measured_range",
    "save_model",
    "table_te",
    "te_def_point",
    "te_point",
]
