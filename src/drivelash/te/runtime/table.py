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
    "API_NAMES",
    "DIRECTIONS",
    "GridNames",
    "MAX_TABLE_POINTS",
    "TEPredictor",
    "TETable",
    "TORQUE_RTOL",
    "build_table",
    "check_direction",
    "flank_torque_range",
    "flank_torques",
    "measured_range",
    "mesh_step_limit",
    "table_bytes",
    "table_size",
    "table_te",
    "valid_torque_range",
]

#: Direction codes: index 0 ⇔ positive flank (+1), index 1 ⇔ negative flank (−1).
DIRECTIONS = (1, -1)
#: What a direction may be: an integer (Python or NumPy) or a float equal to +1 or −1 (a
#: recording's ``direction`` column is float64, ``np.sign`` returns floats); never a bool.
_DIRECTION_TYPES = (int, float, np.integer, np.floating)


def check_direction(direction: object, owner: str, key: str = "direction") -> int:
    """The flank ``direction`` as the int +1 or −1, or one line naming what is wrong.

    The one check of a direction argument of the runtime (:class:`TETable`,
    :class:`~drivelash.te.runtime.predictor.TEModel`,
    :class:`~drivelash.te.runtime.compensator.Compensator`): O(1), no array is built.

    Parameters
    ----------
    direction : int
        Flank in contact [-]: +1 moving in +x (positive torque), −1 in −x. An int or NumPy
        integer; a float equal to ±1 is taken too, and a NumPy 0-d integer or float array.
    owner : str
        Name for the message, e.g. ``"TEModel"``.
    key : str
        Name of the argument for the message (``"direction"``, ``"flank"``).

    Returns
    -------
    int
        +1 or −1.

    Raises
    ------
    ParameterError
        Anything else (0, 2, 0.5, NaN, ``"pos"``, True, an array of ≥ 1 dimension): ``owner.key: must be +1 or
        -1, got …``.
    """
    if isinstance(direction, _DIRECTION_TYPES) and not isinstance(direction, bool):
        if direction == 1:
            return 1
        if direction == -1:
            return -1
    elif isinstance(direction, np.ndarray) and direction.ndim == 0 and direction.dtype.kind in "iuf":
        # a NumPy 0-d array is a scalar (``np.sign(v[-1:]).squeeze()``, ``np.asarray(d)``); it
        # was taken before the exact ±1 check, so it is taken when it is ±1
        value = direction[()]
        if value == 1 or value == -1:
            return 1 if value == 1 else -1
    raise ParameterError(owner, key, f"must be +1 or -1, got {direction!r}")


#: Relative slack [-] (of ``torque_max``) of the torque range checks (:func:`check_grid`,
#: ``TEModel.predict(strict=True)``): floating-point noise of a torque computed at the range's
#: end (1e-8 N·m at 10 N·m), far below any motor-current resolution.
TORQUE_RTOL = 1e-9


def flank_torques(magnitudes: np.ndarray, direction: int) -> np.ndarray:
    """The torques [N·m] of flank ``direction`` for ascending torque magnitudes [N·m].

    The one rule of a flank's torque range: the load acts against the motion, so the motor
    torque has the sign of the flank — flank +1 takes ``magnitudes`` as they are, flank −1
    their negatives in reverse (ascending again). :func:`build_table` builds its grids with
    it (so the table the compensator reads and ``te export`` writes spans these ranges) and
    :func:`valid_torque_range` states the model's valid range with it.

    Parameters
    ----------
    magnitudes : numpy.ndarray
        Ascending torque magnitudes [N·m], ≥ 0.
    direction : int
        Flank: +1 or −1 (:func:`check_direction`; anything else is refused).

    Returns
    -------
    numpy.ndarray
        The flank's torques [N·m], ascending.
    """
    return magnitudes if check_direction(direction, "flank_torques") == 1 else -magnitudes[::-1]


def flank_torque_range(torque_min: float, torque_max: float, direction: int) -> tuple[float, float]:
    """Torque range [N·m] of flank ``direction`` for magnitudes ``torque_min`` … ``torque_max``.

    Flank +1: [torque_min, torque_max]; flank −1: [−torque_max, −torque_min]
    (:func:`flank_torques`).

    Parameters
    ----------
    torque_min, torque_max : float
        Smallest and largest torque magnitude [N·m].
    direction : int
        Flank: +1 or −1.

    Returns
    -------
    lo, hi : float
        The flank's smallest and largest motor torque [N·m] (a zero end is +0.0).
    """
    lo, hi = flank_torques(np.array([float(torque_min), float(torque_max)]), direction)
    return float(lo) + 0.0, float(hi) + 0.0  # + 0.0: −0.0 is stated as 0


def valid_torque_range(model: Any, direction: int) -> tuple[float, float] | None:
    """The motor torques [N·m] flank ``direction`` of ``model`` was trained on, or None.

    ``context.valid_range.torque_max`` per flank (:func:`flank_torque_range` from 0): flank +1
    [0, torque_max], flank −1 [−torque_max, 0] — the range of the table :func:`build_table`
    builds by default (the compensator's and ``te export``'s) and the one
    ``TEModel.predict(strict=True)`` accepts. None for a model without a ``torque_max``.

    Parameters
    ----------
    model : TEModel or TrainedTEModel
        Anything with a ``context.valid_range.torque_max``.
    direction : int
        Flank: +1 or −1.

    Returns
    -------
    tuple of float or None
        (lo, hi) [N·m].
    """
    vr = getattr(getattr(model, "context", None), "valid_range", None)
    t_max = getattr(vr, "torque_max", None)
    if t_max is None:
        return None
    return flank_torque_range(0.0, float(t_max), direction)


#: Largest table :func:`build_table` builds (``te export`` writes) [grid points per flank]: 10 M
#: (e.g. 0.1 mm over 10 m × 100 torques); a CNC compensation table holds thousands, the
#: default grid ≈ 0.2 M.
MAX_TABLE_POINTS = 10_000_000


@dataclass(frozen=True)
class GridNames:
    """How :func:`build_table`'s refusals name the request: the function's arguments (the
    default, :data:`API_NAMES`) or a command's options (``te export``). The checks are the
    same for both; only the words differ."""

    #: who refuses (``ParameterError.owner``; ``what`` of the size refusals)
    owner: str = "build_table"
    x_min: str = "x_min"
    x_max: str = "x_max"
    torque_max: str = "torque_max"
    #: what to do about a torque above the model's range
    torque_hint: str = "lower torque_max to at most the model's context.valid_range.torque_max"
    #: what makes the table smaller
    size_hint: str = "raise dx or lower n_torque or torque_max"
    #: memory the caller needs per grid value besides the table [bytes] (``te export``: CSV text)
    extra_bytes_per_value: float = 0.0
    #: the unit of ``x_min``/``x_max`` for a refused position range; when given, the valid range
    #: is stated in m and in mm (a command whose other lengths are in mm, e.g. ``te export``)
    x_unit_note: str = ""
    #: the position step's name and the unit it is stated in
    dx: str = "dx"
    dx_unit: str = "m"
    #: a step coarser than the model resolves (:func:`mesh_step_limit`): an error (``te export``)
    #: or a ``UserWarning`` (the API; a step above one tooth pitch is an error for both)
    coarse_dx_error: bool = False


API_NAMES = GridNames()


def mesh_step_limit(model: Any) -> tuple[float, float] | None:
    """The largest table step [m] that holds the model's tooth meshing, and the tooth pitch [m].

    The model keeps wavelengths down to ``1/cutoff`` (the low-pass at ``cutoff_factor`` × the
    tooth-mesh frequency, 3 in the paper: pitch/3); sampling them needs a step of at most
    half of that (Nyquist), pitch/6 — the bound ``te import`` applies to the recordings.
    None for a model without a ``pipeline`` (nothing known of its resolution).
    """
    pipe = getattr(model, "pipeline", None)
    geom = getattr(pipe, "geometry", None)
    if pipe is None or geom is None:
        return None
    pitch = math.pi * float(geom.d_p) / float(geom.n_t)
    return 0.5 / float(pipe.cutoff), pitch


class TEPredictor(Protocol):
    """Anything that predicts the transmission error of one flank.

    ``predict(x_T [m], torque [N·m], direction ±1) -> TE [m]``, vectorised over
    ``x_T`` and ``torque`` (broadcast).
    """

    def predict(self, x_T: np.ndarray, torque: np.ndarray, direction: int) -> np.ndarray:
        """The transmission error of flank ``direction``.

        Parameters
        ----------
        x_T : numpy.ndarray
            Table (rack) positions [m].
        torque : numpy.ndarray
            Motor torques [N·m], broadcast against ``x_T``.
        direction : int
            Flank: +1 or −1.

        Returns
        -------
        numpy.ndarray
            TE [m].
        """
        ...


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

    Raises
    ------
    DataError
        ``te`` not of shape (2, n_x ≥ 2, n_torque ≥ 1) or not finite, ``dx`` ≤ 0, or a torque
        step ≤ 0 (with more than one torque).
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
        """Grid torques of a flank [N·m].

        Parameters
        ----------
        direction : int
            Flank: +1 or −1 (:func:`check_direction`; anything else is refused).

        Returns
        -------
        numpy.ndarray
            The flank's torque grid [N·m], ascending, ``n_torque`` values.

        Raises
        ------
        ParameterError
            ``direction`` is not +1 or −1 (one line).
        """
        d = _dir_index(direction)
        return self.torque0[d] + self.dtorque[d] * np.arange(self.te.shape[2])

    def predict(self, x_T: np.ndarray, torque: np.ndarray, direction: int) -> np.ndarray:
        """Bilinear interpolation of the table (same protocol as the models) [m].

        Outside the grid the edge value is held (no extrapolation), in position and torque.

        Parameters
        ----------
        x_T : array_like
            Table positions [m].
        torque : array_like
            Motor torque [N·m], broadcast with ``x_T``.
        direction : int
            Flank: +1 or −1 (:func:`check_direction`; anything else is refused).

        Returns
        -------
        numpy.ndarray
            Transmission error [m], of the broadcast shape of ``x_T`` and ``torque``.

        Raises
        ------
        ParameterError
            ``direction`` is not +1 or −1 (one line).
        """
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
        """Gap between the flank curves TE(−1) − TE(+1) at equal torque [m].

        Parameters
        ----------
        x_T : array_like
            Table positions [m].
        torque : float
            Torque magnitude [N·m]: −|torque| on flank −1, +|torque| on flank +1.

        Returns
        -------
        numpy.ndarray
            Backlash [m], of the shape of ``x_T``.
        """
        return self.predict(x_T, -abs(torque), -1) - self.predict(x_T, abs(torque), 1)


def _dir_index(direction: int) -> int:
    """Index of a flank in the table's arrays: 0 for +1, 1 for −1 (:func:`check_direction`)."""
    return 0 if check_direction(direction, "TETable") == 1 else 1


def build_table(
    model: TEPredictor,
    x_min: float,
    x_max: float,
    dx: float,
    torque_max: float,
    n_torque: int,
    torque_min: float = 0.0,
    meta: dict[str, Any] | None = None,
    *,
    names: GridNames = API_NAMES,
) -> TETable:
    """Sample a TE model into a :class:`TETable`.

    The torque grid of flank +1 runs over [torque_min, torque_max], that of flank
    −1 over [−torque_max, −torque_min] (the load acts against the motion, so the
    motor torque has the sign of the flank: :func:`flank_torques`, the rule
    ``TEModel.predict(strict=True)`` checks too, :func:`valid_torque_range`).

    Parameters
    ----------
    model : TEPredictor
        Fitted model with ``predict(x_T, torque, direction)`` [m].
    x_min, x_max : float
        Position range [m]; within :func:`measured_range` of ``model`` (refused otherwise).
    dx : float
        Position step [m]; a grid of more than :data:`MAX_TABLE_POINTS` points per flank or
        beyond the memory budget is refused before anything is allocated.
    torque_max : float
        Largest torque magnitude of the grid [N·m]; at most the model's trained torque range
        ``context.valid_range.torque_max`` when it has one (refused otherwise: the model would
        extrapolate).
    n_torque : int
        Number of torque grid points per flank (≥ 1).
    torque_min : float
        Smallest torque magnitude of the grid [N·m].
    meta : dict, optional
        Provenance stored in the table.
    names : GridNames
        How the refusals name the request (``te export`` passes its options: the command and
        the API share these checks, :func:`check_grid`).

    Returns
    -------
    TETable

    Raises
    ------
    ParameterError
        An empty or non-finite range, positions outside :func:`measured_range`, torques outside
        the model's trained range (one line each).
    ResourceError
        A grid larger than :data:`MAX_TABLE_POINTS` or the memory budget (one line with the size).
    """
    if not (math.isfinite(x_min) and math.isfinite(x_max) and x_max > x_min and dx > 0):
        raise ParameterError(
            "build_table", "x_max", "position range must be non-empty and finite with dx > 0"
        )
    if n_torque < 1 or not (math.isfinite(torque_max) and torque_max >= torque_min):
        raise ParameterError("build_table", "n_torque", "need n_torque >= 1 and torque_max >= torque_min")
    check_grid(model, x_min, x_max, dx, torque_min, torque_max, n_torque, names)
    n_x = table_size(x_min, x_max, dx)
    x = x_min + dx * np.arange(n_x)
    tq = np.linspace(torque_min, torque_max, n_torque)
    step = tq[1] - tq[0] if n_torque > 1 else 1.0
    te = np.empty((2, n_x, n_torque))
    for d, sgn in enumerate(DIRECTIONS):
        grid_t = flank_torques(tq, sgn)
        X, T = np.meshgrid(x, grid_t, indexing="ij")
        te[d] = np.asarray(model.predict(X.ravel(), T.ravel(), sgn), dtype=np.float64).reshape(n_x, n_torque)
    torque0 = np.array([flank_torques(tq, sgn)[0] for sgn in DIRECTIONS])
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

    Parameters
    ----------
    model : TEModel or TrainedTEModel
        Anything with a ``context.valid_range`` and/or a ``geometric_range()``.

    Returns
    -------
    x_min, x_max : float
        The measured position range [m].
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


def check_grid(
    model: Any,
    x_min: float,
    x_max: float,
    dx: float,
    torque_min: float,
    torque_max: float,
    n_torque: int,
    names: GridNames = API_NAMES,
) -> None:
    """The refusals of :func:`build_table` (and so of ``te export``), before anything is allocated:
    positions outside :func:`measured_range`, torques outside the model's trained range
    (``context.valid_range.torque_max``; the model would extrapolate), a grid of more than
    :data:`MAX_TABLE_POINTS` points per flank or beyond the memory budget. One line each,
    worded by ``names``."""
    from drivelash.errors import ResourceError
    from drivelash.io.budget import check_budget

    check_measured(x_min, x_max, measured_range(model), names=names)
    _check_step(model, dx, names)
    vr = getattr(getattr(model, "context", None), "valid_range", None)
    t_lim = getattr(vr, "torque_max", None)
    if t_lim is not None:
        t_max = float(t_lim)
        if torque_max > t_max * (1 + TORQUE_RTOL):
            raise ParameterError(
                names.owner,
                names.torque_max,
                f"{torque_max:g} N·m is above the model's valid torque range 0 ... {t_max:.4g} N·m (its"
                f" training runs); the model would extrapolate — {names.torque_hint}",
            )
        if torque_min < 0:
            raise ParameterError(
                names.owner,
                "torque_min",
                f"{torque_min:g} N·m is below the model's valid torque range 0 ... {t_max:.4g} N·m (its"
                " training runs); the model would extrapolate — torque_min must be >= 0",
            )
    n_x = (x_max - x_min) / dx + 1
    what = f"{names.owner}: {n_x:.4g} positions x {n_torque:.4g} torques x 2 flanks"
    if n_x * n_torque > MAX_TABLE_POINTS:  # no CNC loads more; checked before any size is allocated
        raise ResourceError(
            f"{what} = {2 * n_x * n_torque:.4g} values, more than {2 * MAX_TABLE_POINTS:.4g}"
            f" (≈ {table_bytes(int(n_x), int(n_torque)) / 2**30:.3g} GiB to build); {names.size_hint}"
        )
    extra = names.extra_bytes_per_value * 2 * n_x * n_torque
    check_budget(table_bytes(int(n_x), int(n_torque)) + extra, what=what, option=names.size_hint)


def _check_step(model: Any, dx: float, names: GridNames) -> None:
    """Refuse (or warn about) a position step the model's meshing cannot be held with (finding A12)."""
    lim = mesh_step_limit(model)
    if lim is None:
        return
    limit, pitch = lim
    k = 1e3 if names.dx_unit == "mm" else 1.0
    said = f"{dx * k:g} {names.dx_unit}"
    if dx > pitch * (1 + 1e-9):
        raise ParameterError(
            names.owner,
            names.dx,
            f"{said} is more than one tooth pitch ({pitch * 1e3:.4g} mm): the table cannot hold the"
            f" meshing — the model needs a step <= {limit * 1e3:.3g} mm"
            + (" (a step in mm given in m?)" if names.dx_unit == "m" else ""),
        )
    if dx > limit * (1 + 1e-9):
        msg = (
            f"{said} is coarser than the model resolves: the tooth mesh (pitch {pitch * 1e3:.4g} mm,"
            f" kept down to pitch/{pitch / (2 * limit):.3g}) needs <= {limit * 1e3:.3g} mm; linear"
            " interpolation between the nodes would miss the meshing"
        )
        if names.coarse_dx_error:
            raise ParameterError(names.owner, names.dx, msg)
        import warnings

        warnings.warn(f"{names.owner}: {names.dx}: {msg}", UserWarning, stacklevel=3)


def check_measured(
    a: float, b: float, measured: tuple[float, float], unit: str = "m", names: GridNames | None = None
) -> None:
    """Refuse a range [a, b] [m] that leaves :func:`measured_range`.

    Parameters
    ----------
    a, b : float
        Requested first and last position [m].
    measured : tuple of float
        The model's valid range (x_min, x_max) [m].
    unit : {"m", "mm"}
        Unit the message states the ranges in first.
    names : GridNames, optional
        Wording (default :data:`EXPORT_POSITIONS`, ``te export``'s options). With a
        ``x_unit_note`` the valid range is stated in m and in mm, and the note follows: a
        user who typed mm where m are expected sees both figures.

    Raises
    ------
    ParameterError
        ``[a, b]`` leaves ``measured`` by more than 1 nm: one line naming ``names.x_min`` or
        ``names.x_max``.
    """
    names = EXPORT_POSITIONS if names is None else names
    lo, hi = measured
    tol = 1e-9
    if a < lo - tol or b > hi + tol or a > hi + tol or b < lo - tol:
        fmts = {"m": (1.0, ".6g"), "mm": (1e3, ".3f")}
        f, fmt = fmts[unit]
        valid = f"[{lo * f:{fmt}}, {hi * f:{fmt}}] {unit}"
        note = ""
        if names.x_unit_note:
            other = "mm" if unit == "m" else "m"
            g, gfmt = fmts[other]
            valid += f" = [{lo * g:{gfmt}}, {hi * g:{gfmt}}] {other}"
            note = f"; {names.x_unit_note}"
        raise ParameterError(
            names.owner,
            names.x_min if (a < lo - tol or a > hi + tol) else names.x_max,  # the one outside
            f"[{a * f:{fmt}}, {b * f:{fmt}}] {unit} leaves the model's valid range {valid} "
            f"(where its no-load runs of both directions were measured){note}",
        )


#: what ``te export`` adds to a refused position range: its position options are in metres
#: while its steps (``--dx-mm``, ``--step-mm``) are in millimetres
X_UNIT_NOTE = "--x-min and --x-max are in m (metres; --dx-mm and --step-mm are in mm)"
#: the position options of ``te export`` (:func:`check_measured`'s default wording)
EXPORT_POSITIONS = GridNames(owner="te export", x_min="--x-min", x_max="--x-max", x_unit_note=X_UNIT_NOTE)


def table_size(x_min: float, x_max: float, dx: float) -> int:
    """Grid positions of a table over [x_min, x_max] [m] with step ``dx`` [m].

    Parameters
    ----------
    x_min, x_max : float
        Table span [m].
    dx : float
        Position step [m], > 0.

    Returns
    -------
    int
        Number of grid positions [-]: ⌊(x_max − x_min)/dx + 1e-9⌋ + 1.
    """
    return int(math.floor((x_max - x_min) / dx + 1e-9)) + 1


def table_bytes(n_x: int, n_torque: int) -> float:
    """Peak memory of :func:`build_table` [bytes]: the table plus the per-flank query arrays.

    Parameters
    ----------
    n_x : int
        Grid positions [-].
    n_torque : int
        Grid torques per flank [-].

    Returns
    -------
    float
        Bytes: 8 · n_x · n_torque · 6 (two flanks of table, four query arrays).
    """
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
    """TE [m] at position ``x`` [m] and ``torque`` [N·m] on flank index ``d`` (bilinear, clamped).

    njit-callable: the arrays of a :class:`TETable` (``te``, ``x0``, ``dx``, ``torque0``,
    ``dtorque``) as they are.

    Parameters
    ----------
    te : numpy.ndarray
        TE values, shape (2, n_x, n_torque) [m].
    x0, dx : float
        First grid position and position step [m].
    torque0, dtorque : numpy.ndarray
        First grid torque and torque step per flank, shape (2,) [N·m].
    d : int
        Flank *index*: 0 for flank +1, 1 for flank −1 (not checked: a kernel).
    x : float
        Position [m]; held at the grid's edge outside it.
    torque : float
        Motor torque [N·m]; held at the grid's edge outside it.

    Returns
    -------
    float
        Transmission error [m].
    """
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
