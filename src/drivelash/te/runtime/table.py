"""The runtime lookup table of a TE model: position × torque grid per flank.

The fitted model is sampled once into a :class:`TETable` (bilinear interpolation,
clamped at the edges), which the ``@njit`` kernel :func:`table_te` evaluates inside
the compensation cycle (:mod:`drivelash.te.runtime.compensator`, which counts the cycles
it spends beyond the grid). The table spans at most :func:`measured_range`, the one
definition of the positions where a model was measured.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numba import njit

from drivelash.errors import DataError, ParameterError

__all__ = [
    "DIRECTIONS",
    "TEPredictor",
    "TETable",
    "build_table",
    "measured_range",
    "table_bytes",
    "table_size",
    "table_te",
]

#: Direction codes: index 0 ⇔ positive flank (+1), index 1 ⇔ negative flank (−1).
DIRECTIONS = (1, -1)


class TEPredictor(Protocol):
    """Anything that predicts the transmission error of one flank.

    ``predict(x_T [m], torque [N·m], direction ±1) -> TE [m]``, vectorised over
    ``x_T`` and ``torque`` (broadcast).
    """

    def predict(self, x_T: np.ndarray, torque: np.ndarray, direction: int) -> np.ndarray: ...


@dataclass(frozen=True)
class TETable:
    """Transmission error on a regular position × torque grid per flank.

    Parameters
    ----------
    x0 : float
        First grid position [m].
    dx : float
        Position step [m].
    torque0 : numpy.ndarray
        First grid torque per flank, shape (2,) [N·m] (index 0: flank +1, 1: flank −1).
    dtorque : numpy.ndarray
        Torque step per flank, shape (2,) [N·m].
    te : numpy.ndarray
        TE values, shape (2, n_x, n_torque) [m].
    meta : dict
        Provenance (model directory, units, axis name).
    """

    x0: float
    dx: float
    torque0: np.ndarray
    dtorque: np.ndarray
    te: np.ndarray
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        te = np.ascontiguousarray(np.asarray(self.te, dtype=np.float64))
        if te.ndim != 3 or te.shape[0] != 2 or te.shape[1] < 2 or te.shape[2] < 1:
            raise DataError(f"TE table must have shape (2, n_x>=2, n_torque>=1), got {te.shape}")
        if not np.all(np.isfinite(te)):
            raise DataError("TE table holds non-finite values")
        if not self.dx > 0:
            raise DataError(f"position step must be > 0, got {self.dx}")
        t0 = np.ascontiguousarray(np.asarray(self.torque0, dtype=np.float64).reshape(2))
        dtq = np.ascontiguousarray(np.asarray(self.dtorque, dtype=np.float64).reshape(2))
        if te.shape[2] > 1 and not np.all(dtq > 0):
            raise DataError(f"torque steps must be > 0, got {dtq}")
        object.__setattr__(self, "te", te)
        object.__setattr__(self, "torque0", t0)
        object.__setattr__(self, "dtorque", dtq)

    @property
    def x_grid(self) -> np.ndarray:
        """Grid positions [m]."""
        return self.x0 + self.dx * np.arange(self.te.shape[1])

    def torque_grid(self, direction: int) -> np.ndarray:
        """Grid torques of a flank [N·m]."""
        d = _dir_index(direction)
        return self.torque0[d] + self.dtorque[d] * np.arange(self.te.shape[2])

    def predict(self, x_T: np.ndarray, torque: np.ndarray, direction: int) -> np.ndarray:
        """Bilinear interpolation of the table (same protocol as the models) [m]."""
        x, t = np.broadcast_arrays(np.asarray(x_T, dtype=np.float64), np.asarray(torque, dtype=np.float64))
        out = np.empty(x.shape)
        _table_batch(
            self.te,
            self.x0,
            self.dx,
            self.torque0,
            self.dtorque,
            _dir_index(direction),
            np.ascontiguousarray(x.ravel()),
            np.ascontiguousarray(t.ravel()),
            out.reshape(-1),
        )
        return out

    def backlash(self, x_T: np.ndarray, torque: float = 0.0) -> np.ndarray:
        """Gap between the flank curves TE(−1) − TE(+1) at equal torque [m]."""
        return self.predict(x_T, -abs(torque), -1) - self.predict(x_T, abs(torque), 1)


def _dir_index(direction: int) -> int:
    if direction == 1:
        return 0
    if direction == -1:
        return 1
    raise ParameterError("TETable", "direction", f"must be +1 or -1, got {direction!r}")


def build_table(
    model: TEPredictor,
    x_min: float,
    x_max: float,
    dx: float,
    torque_max: float,
    n_torque: int,
    torque_min: float = 0.0,
    meta: dict[str, Any] | None = None,
) -> TETable:
    """Sample a TE model into a :class:`TETable`.

    The torque grid of flank +1 runs over [torque_min, torque_max], that of flank
    −1 over [−torque_max, −torque_min] (the load acts against the motion, so the
    motor torque has the sign of the flank).

    Parameters
    ----------
    model : TEPredictor
        Fitted model with ``predict(x_T, torque, direction)`` [m].
    x_min, x_max : float
        Position range [m]; within :func:`measured_range` of ``model`` (refused otherwise).
    dx : float
        Position step [m].
    torque_max : float
        Largest torque magnitude of the grid [N·m].
    n_torque : int
        Number of torque grid points per flank (≥ 1).
    torque_min : float
        Smallest torque magnitude of the grid [N·m].
    meta : dict, optional
        Provenance stored in the table.

    Returns
    -------
    TETable
    """
    if not (math.isfinite(x_min) and math.isfinite(x_max) and x_max > x_min and dx > 0):
        raise ParameterError(
            "build_table", "x_max", "position range must be non-empty and finite with dx > 0"
        )
    if n_torque < 1 or not (math.isfinite(torque_max) and torque_max >= torque_min):
        raise ParameterError("build_table", "n_torque", "need n_torque >= 1 and torque_max >= torque_min")
    lo, hi = measured_range(model)
    if x_min < lo - 1e-9 or x_max > hi + 1e-9:
        raise ParameterError(
            "build_table",
            "x_min",
            f"positions [{x_min:.6g}, {x_max:.6g}] m leave the model's valid range"
            f" [{lo:.6g}, {hi:.6g}] m (where its no-load runs of both directions were measured)",
        )
    n_x = table_size(x_min, x_max, dx)
    x = x_min + dx * np.arange(n_x)
    tq = np.linspace(torque_min, torque_max, n_torque)
    step = tq[1] - tq[0] if n_torque > 1 else 1.0
    te = np.empty((2, n_x, n_torque))
    for d, sgn in enumerate(DIRECTIONS):
        grid_t = tq if sgn == 1 else -tq[::-1]
        X, T = np.meshgrid(x, grid_t, indexing="ij")
        te[d] = np.asarray(model.predict(X.ravel(), T.ravel(), sgn), dtype=np.float64).reshape(n_x, n_torque)
    torque0 = np.array([tq[0], -tq[-1]])
    return TETable(float(x_min), float(dx), torque0, np.array([step, step]), te, dict(meta or {}))


def measured_range(model: Any) -> tuple[float, float]:
    """Positions [m] where ``model`` was measured: its stored valid range (``context.valid_range``,
    the span the no-load runs of both directions covered) ∩ the span its no-load curves hold
    data (``geometric_range()``; outside it they are held flat, i.e. not measured).

    The one definition of the valid position range: ``te export`` (table and CNC layouts),
    the table ``te validate`` and the compensator read (:func:`build_table`), the passes
    ``te update`` accepts, and the range :func:`~drivelash.te.runtime.persist.save_model`
    stores (so a saved model's ``context.valid_range`` is already this range; a file written
    before is narrowed to it on load). A model without one of them is bounded by the other;
    with neither, ``(-inf, inf)``.
    """
    lo, hi = -math.inf, math.inf
    vr = getattr(getattr(model, "context", None), "valid_range", None)
    if vr is not None:
        lo, hi = float(vr.x_min), float(vr.x_max)
    geo = getattr(model, "geometric_range", None)
    if geo is not None:
        g_lo, g_hi = (float(v) for v in geo())
        lo, hi = max(lo, g_lo), min(hi, g_hi)
    return lo, hi


def check_measured(a: float, b: float, measured: tuple[float, float], unit: str = "m") -> None:
    """Refuse an export range [a, b] [m] that leaves :func:`measured_range`: a ParameterError
    naming ``--x-min``/``--x-max`` with both ranges in ``unit`` (``"m"`` or ``"mm"``)."""
    lo, hi = measured
    tol = 1e-9
    if a < lo - tol or b > hi + tol:
        f, fmt = (1.0, ".6g") if unit == "m" else (1e3, ".3f")
        raise ParameterError(
            "te export",
            "--x-min" if a < lo - tol else "--x-max",
            f"[{a * f:{fmt}}, {b * f:{fmt}}] {unit} leaves the model's valid range "
            f"[{lo * f:{fmt}}, {hi * f:{fmt}}] {unit} "
            "(where its no-load runs of both directions were measured)",
        )


def table_size(x_min: float, x_max: float, dx: float) -> int:
    """Grid positions of a table over [x_min, x_max] [m] with step ``dx`` [m]."""
    return int(math.floor((x_max - x_min) / dx + 1e-9)) + 1


def table_bytes(n_x: int, n_torque: int) -> float:
    """Peak memory of :func:`build_table` [bytes]: the table plus the per-flank query arrays."""
    return 8.0 * n_x * n_torque * (2 + 4)


@njit(cache=True)
def _cell(u, n):
    """Cell index and fraction of grid coordinate ``u`` on ``n`` nodes, clamped to the grid."""
    if u <= 0.0:
        return 0, 0.0
    if u >= n - 1:
        return n - 2, 1.0
    i = min(int(u), n - 2)
    return i, u - i


@njit(cache=True, inline="always")
def table_te(te, x0, dx, torque0, dtorque, d, x, torque):
    """TE [m] at position ``x`` [m] and ``torque`` [N·m] on flank index ``d`` (bilinear, clamped)."""
    n_t = te.shape[2]
    i, fu = _cell((x - x0) / dx, te.shape[1])
    if n_t == 1:
        return te[d, i, 0] * (1.0 - fu) + te[d, i + 1, 0] * fu
    j, fw = _cell((torque - torque0[d]) / dtorque[d], n_t)
    a = te[d, i, j] * (1.0 - fw) + te[d, i, j + 1] * fw
    b = te[d, i + 1, j] * (1.0 - fw) + te[d, i + 1, j + 1] * fw
    return a * (1.0 - fu) + b * fu


@njit(cache=True)
def _table_batch(te, x0, dx, torque0, dtorque, d, x, torque, out):
    for k in range(x.size):
        out[k] = table_te(te, x0, dx, torque0, dtorque, d, x[k], torque[k])
