"""ISO 230-2:2014 evaluation of a bidirectional positioning test.

Symbols follow the standard (clause 3 of ISO 230-2:2014, clause 2 of the 2006 edition):
target positions P_i (i = 1…m), runs j = 1…n per direction, approach direction ↑
(positive, increasing position) and ↓ (negative), positional deviation
x_ij = P_ij − P_i (actual position reached minus target position).

Per target i and direction::

    x̄_i↑ = (1/n) Σ_j x_ij↑                              mean unidirectional positional deviation
    s_i↑ = sqrt( 1/(n−1) Σ_j (x_ij↑ − x̄_i↑)² )         estimator of the unidirectional standard uncertainty
    R_i↑ = 4 s_i↑                                      unidirectional repeatability (same for ↓)
    B_i  = x̄_i↑ − x̄_i↓                                 reversal value at a position
    R_i  = max(2 s_i↑ + 2 s_i↓ + |B_i|, R_i↑, R_i↓)     bidirectional repeatability at a position
    x̄_i  = (x̄_i↑ + x̄_i↓) / 2                          mean bidirectional positional deviation

Per axis::

    B  = max_i |B_i|                                    reversal value of the axis
    B̄  = (1/m) Σ_i B_i                                  mean reversal value of the axis
    R↑ = max_i R_i↑,  R↓ = max_i R_i↓,  R = max_i R_i
    E↑ = max_i x̄_i↑ − min_i x̄_i↑   (same for ↓)        unidirectional systematic positional deviation
    E  = max_i(x̄_i↑, x̄_i↓) − min_i(x̄_i↑, x̄_i↓)        bidirectional systematic positional deviation
    M  = max_i x̄_i − min_i x̄_i                         range of the mean bidirectional positional deviation
    A↑ = max_i(x̄_i↑ + 2 s_i↑) − min_i(x̄_i↑ − 2 s_i↑)   unidirectional accuracy (same for ↓)
    A  = max_i(x̄_i↑ + 2 s_i↑, x̄_i↓ + 2 s_i↓) − min_i(x̄_i↑ − 2 s_i↑, x̄_i↓ − 2 s_i↓)

Beyond the standard (stated in ``docs/assumptions.md``), the statistical (type A)
uncertainty of the reversal values, from the same runs:

- u(B_i)² = s_i↑²/n + s_i↓²/n with Welch–Satterthwaite degrees of freedom ν_i;
- u(B̄)² = (1/m²) Σ_i u(B_i)²; interval B̄ ± t_ν u(B̄);
- B = max |B_i| is a maximum of noisy values, biased upward when several targets
  share the same reversal. Its interval is built from simultaneous (Šidák) intervals
  of all B_i: if |B_i − β_i| ≤ c_i u(B_i) for all i (probability ≥ 1 − α), then
  max_i |β_i| lies in [max_i(|B_i| − c_i u_i)⁺, max_i(|B_i| + c_i u_i)].

Deviations are in SI units (m for a linear axis, rad for a rotary one); nothing here
depends on the unit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drivelash.errors import NO_LINES, DataError, DataRows, ParameterError

__all__ = ["Approaches", "Iso230Result", "approaches_from_rows", "evaluate"]

#: Direction codes: +1 = ↑ (approach in the positive direction), −1 = ↓.
UP, DOWN = 1, -1

#: ISO 230-2 standard test cycle: five runs in each direction.
STANDARD_RUNS = 5
#: ISO 230-2: at least five target positions (and five per metre of travel up to 2 m).
STANDARD_MIN_TARGETS = 5
#: ISO 230-2 (linear axes up to 2 m): at least this many target positions per metre of travel.
STANDARD_TARGETS_PER_M = 5
#: … applied up to this travel [m] (longer axes: the 2 m figure, 10 targets, is the least asked).
STANDARD_PER_M_UP_TO = 2.0

#: Target positions closer than this fraction of the target range are one target.
TARGET_TOLERANCE = 1e-6

#: Larger magnitudes [m, rad, run numbers] are refused: no machine axis is 1000 km long,
#: and squares of such numbers overflow.
MAX_ABS = 1e6

#: Coverage probability of the intervals of B and B̄.
COVERAGE = 0.95


@dataclass(frozen=True)
class Approaches:
    """Positional deviations x_ij of a bidirectional test, by target, direction and run.

    Parameters
    ----------
    targets : numpy.ndarray
        Target positions P_i, ascending, shape (m,) [m or rad].
    up, down : numpy.ndarray
        Positional deviations x_ij↑ and x_ij↓, shape (m, n), rows in target order,
        columns in run order [m or rad].
    runs_up, runs_down : numpy.ndarray
        Run labels of the columns, shape (m, n) (reporting only).
    unit : str
        ``"m"`` (linear axis) or ``"rad"`` (rotary axis).
    source : str
        Where the data came from (file name), for messages.
    warnings : list of str
        Deviations from the standard's test conditions (too few targets or runs).
    """

    targets: np.ndarray
    up: np.ndarray
    down: np.ndarray
    runs_up: np.ndarray
    runs_down: np.ndarray
    unit: str = "m"
    source: str = ""
    warnings: list[str] = field(default_factory=list)

    @property
    def m(self) -> int:
        """Number of target positions."""
        return int(self.targets.size)

    @property
    def n(self) -> int:
        """Number of runs per direction."""
        return int(self.up.shape[1])


def _fmt_pos(p: float, unit: str) -> str:
    """A target position for a message: mm for linear axes, degrees for rotary ones."""
    if unit == "rad":
        return f"{math.degrees(p):.6g} deg"
    return f"{p * 1e3:.6g} mm"


def cluster_targets(values: np.ndarray, tolerance: float = TARGET_TOLERANCE) -> tuple[np.ndarray, np.ndarray]:
    """Group nearly equal target positions.

    Parameters
    ----------
    values : numpy.ndarray
        Target position of every row [m or rad].
    tolerance : float
        Values closer than ``tolerance`` × (range of the values) belong to one target [-].

    Returns
    -------
    centres : numpy.ndarray
        Mean position of each group, ascending.
    labels : numpy.ndarray
        Group index of every row.
    """
    order = np.argsort(values, kind="stable")
    v = values[order]
    span = float(v[-1] - v[0]) if v.size else 0.0
    tol = tolerance * span if span > 0 else 0.0
    new = np.concatenate(([True], np.diff(v) > tol))
    group_sorted = np.cumsum(new) - 1
    labels = np.empty(values.size, dtype=np.int64)
    labels[order] = group_sorted
    centres = np.array([v[group_sorted == g].mean() for g in range(int(group_sorted[-1]) + 1)])
    return centres, labels


def approaches_from_rows(
    target: np.ndarray,
    run: np.ndarray,
    direction: np.ndarray,
    deviation: np.ndarray,
    *,
    unit: str = "m",
    source: str = "",
    columns: dict[str, str] | None = None,
    target_tolerance: float = TARGET_TOLERANCE,
    rows: DataRows = NO_LINES,
) -> Approaches:
    """Arrange a table of approaches into :class:`Approaches`, validating it.

    Parameters
    ----------
    target : numpy.ndarray
        Target position P_i of each row [m or rad].
    run : numpy.ndarray
        Run number j of each row (integers; any labels, only their grouping matters).
    direction : numpy.ndarray
        +1 for an approach in the positive direction (↑), −1 for the negative (↓).
    deviation : numpy.ndarray
        Positional deviation x_ij = P_ij − P_i of each row [m or rad].
    unit : {"m", "rad"}
        SI unit of ``target`` and ``deviation``: a linear or a rotary axis (convert mm, µm,
        deg or arcsec before).
    source : str
        File name for messages.
    columns : dict, optional
        Source column name of ``"target"``, ``"run"``, ``"direction"``, ``"deviation"``
        for messages.
    target_tolerance : float
        See :func:`cluster_targets`.
    rows : DataRows, optional
        Where the rows are in ``source`` (``MappedTable.rows``), for messages: ``line N`` of a
        text file, else ``data row N (1-based)``.

    Raises
    ------
    ParameterError
        ``unit`` is not ``"m"`` or ``"rad"``.
    DataError
        One line naming the file, the column or target and the problem: a direction
        that is not ±1, a run that is not an integer, a duplicated approach, a target
        approached from one side only, fewer than 2 runs per direction, unequal
        numbers of runs, fewer than 2 targets.
    """
    if unit not in ("m", "rad"):  # the checks below (per-metre rule, report scaling) assume SI (s19 F10)
        raise ParameterError(
            "approaches_from_rows",
            "unit",
            f"must be 'm' or 'rad' (convert the positions to SI first), got {unit!r}",
        )
    cols = {"target": "target", "run": "run", "direction": "direction", "deviation": "deviation"}
    cols.update(columns or {})
    arrays = {
        "target": np.asarray(target, dtype=np.float64),
        "run": np.asarray(run, dtype=np.float64),
        "direction": np.asarray(direction, dtype=np.float64),
        "deviation": np.asarray(deviation, dtype=np.float64),
    }
    sizes = {k: a.size for k, a in arrays.items()}
    if len(set(sizes.values())) != 1:
        raise DataError(f"columns have different lengths {sizes}", path=source)
    if sizes["target"] == 0:
        raise DataError("no approaches (empty table)", path=source)
    for key, a in arrays.items():
        bad = ~np.isfinite(a)
        if bad.any():
            raise DataError(
                "NaN or infinite value", path=source, column=cols[key], row=int(np.argmax(bad)), rows=rows
            )
        big = np.abs(a) > MAX_ABS
        if big.any():
            i = int(np.argmax(big))
            raise DataError(
                f"implausible value {a[i]:.6g} (beyond ±{MAX_ABS:g} m or rad; wrong unit?)",
                path=source,
                column=cols[key],
                row=i,
                rows=rows,
            )
    d = arrays["direction"]
    bad = (d != UP) & (d != DOWN)
    if bad.any():
        i = int(np.argmax(bad))
        raise DataError(
            f"direction must be +1 (positive approach) or -1 (negative approach), got {d[i]:g}",
            path=source,
            column=cols["direction"],
            row=i,
            rows=rows,
        )
    r = arrays["run"]
    bad = r != np.round(r)
    if bad.any():
        i = int(np.argmax(bad))
        raise DataError(
            f"run must be an integer, got {r[i]:g}", path=source, column=cols["run"], row=i, rows=rows
        )

    centres, labels = cluster_targets(arrays["target"], target_tolerance)
    m = centres.size
    if m < 2:
        raise DataError(
            f"only one target position ({_fmt_pos(float(centres[0]), unit)}); ISO 230-2 needs several",
            path=source,
            column=cols["target"],
        )
    # duplicated approach: same target, direction and run twice
    key = np.stack([labels, d.astype(np.int64), r.astype(np.int64)], axis=1)
    _, first, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    if (counts > 1).any():
        k = int(np.flatnonzero(counts > 1)[0])
        dup_rows = np.flatnonzero((key == key[first[k]]).all(axis=1))
        arrow = "+" if key[first[k], 1] == UP else "-"
        raise DataError(
            f"approach to target {_fmt_pos(float(centres[key[first[k], 0]]), unit)} in direction {arrow},"
            f" run {key[first[k], 2]}, appears twice ({rows.where(int(dup_rows[0]))} and"
            f" {rows.where(int(dup_rows[1]))})",
            path=source,
            row=int(dup_rows[1]),
            rows=rows,
        )
    n_up = np.bincount(labels[d == UP], minlength=m)
    n_dn = np.bincount(labels[d == DOWN], minlength=m)
    for i in range(m):
        if n_up[i] == 0 or n_dn[i] == 0:
            missing = "positive (+)" if n_up[i] == 0 else "negative (-)"
            raise DataError(
                f"unequal targets: target {_fmt_pos(float(centres[i]), unit)} has no approach in the"
                f" {missing} direction (every target needs runs in both directions)",
                path=source,
                column=cols["target"],
            )
    n_min = int(min(n_up.min(), n_dn.min()))
    if n_min < 2:
        i = int(np.argmin(np.minimum(n_up, n_dn)))
        arrow = "+" if n_up[i] < 2 else "-"
        raise DataError(
            f"target {_fmt_pos(float(centres[i]), unit)} has {n_min} run in direction {arrow};"
            " ISO 230-2 needs at least 2 runs per direction (standard: 5)",
            path=source,
            column=cols["run"],
        )
    counts_all = np.concatenate([n_up, n_dn])
    if counts_all.min() != counts_all.max():
        if n_up.min() == n_up.max() and n_dn.min() == n_dn.max():
            # one direction has a run fewer at every target (s19 F13: blamed on one target of the
            # other direction before)
            raise DataError(
                f"unequal runs: {int(n_up[0])} run(s) in direction + but {int(n_dn[0])} in direction -"
                " at every target (ISO 230-2 needs the same runs in both directions)",
                path=source,
                column=cols["run"],
            )
        n_ref = int(np.bincount(counts_all).argmax())
        i_bad = int(np.flatnonzero((n_up != n_ref) | (n_dn != n_ref))[0])
        arrow, got = ("+", n_up[i_bad]) if n_up[i_bad] != n_ref else ("-", n_dn[i_bad])
        raise DataError(
            f"unequal runs: target {_fmt_pos(float(centres[i_bad]), unit)} has {got} run(s) in direction"
            f" {arrow}, the other targets {n_ref}",
            path=source,
            column=cols["run"],
        )
    n = int(n_up[0])
    up = np.empty((m, n))
    dn = np.empty((m, n))
    runs_up = np.empty((m, n))
    runs_dn = np.empty((m, n))
    for sign, out, runs in ((UP, up, runs_up), (DOWN, dn, runs_dn)):
        for i in range(m):
            sel = np.flatnonzero((labels == i) & (d == sign))
            sel = sel[np.argsort(r[sel], kind="stable")]
            out[i] = arrays["deviation"][sel]
            runs[i] = r[sel]
    warnings: list[str] = []
    if m < STANDARD_MIN_TARGETS:
        warnings.append(f"{m} target positions; ISO 230-2 asks for at least {STANDARD_MIN_TARGETS}")
    elif unit == "m" and m > 1:
        travel = float(np.max(centres) - np.min(centres))
        need = math.ceil(STANDARD_TARGETS_PER_M * min(travel, STANDARD_PER_M_UP_TO) - 1e-9)
        if m < need:
            warnings.append(
                f"{m} target positions over {1e3 * travel:.0f} mm; ISO 230-2 asks for at least "
                f"{STANDARD_TARGETS_PER_M} per metre on axes up to {STANDARD_PER_M_UP_TO:g} m ({need} here)"
            )
    if n < STANDARD_RUNS:
        warnings.append(f"{n} runs per direction; the ISO 230-2 standard test cycle has {STANDARD_RUNS}")
    return Approaches(centres, up, dn, runs_up, runs_dn, unit=unit, source=source, warnings=warnings)


def _t_quantile(p: float, nu: np.ndarray | float) -> np.ndarray:
    """Student-t quantile, the normal one for infinite degrees of freedom."""
    from scipy import stats

    nu = np.asarray(nu, dtype=np.float64)
    return np.where(np.isfinite(nu), stats.t.ppf(p, np.where(np.isfinite(nu), nu, 1.0)), stats.norm.ppf(p))


@dataclass(frozen=True)
class Iso230Result:
    """ISO 230-2 quantities of one axis; all positions and deviations in ``unit`` (m or rad).

    The definitions are in the module docstring; [unit] below is m (linear axis) or rad
    (rotary axis).

    Attributes
    ----------
    unit : {"m", "rad"}
        SI unit of every position, deviation and uncertainty.
    n : int
        Runs per direction.
    targets : numpy.ndarray
        Target positions P_i, shape (m,) [unit].
    mean_up, mean_down : numpy.ndarray
        Mean unidirectional positional deviations x̄_i↑, x̄_i↓, shape (m,) [unit].
    s_up, s_down : numpy.ndarray
        Unidirectional standard uncertainties s_i↑, s_i↓, shape (m,) [unit].
    R_i_up, R_i_down : numpy.ndarray
        Unidirectional repeatabilities R_i↑ = 4 s_i↑, R_i↓, shape (m,) [unit].
    B_i : numpy.ndarray
        Reversal values x̄_i↑ − x̄_i↓, shape (m,) [unit].
    R_i : numpy.ndarray
        Bidirectional repeatabilities, shape (m,) [unit].
    mean_bi : numpy.ndarray
        Mean bidirectional positional deviations x̄_i, shape (m,) [unit].
    u_B_i : numpy.ndarray
        Standard uncertainties u(B_i), shape (m,) [unit].
    nu_B_i : numpy.ndarray
        Their Welch–Satterthwaite degrees of freedom, shape (m,) [-].
    B : float
        Reversal value of the axis max_i |B_i| [unit].
    B_signed : float
        The B_i of largest magnitude, with its sign [unit].
    B_index : int
        Index of its target in ``targets``.
    B_mean : float
        Mean reversal value B̄ [unit].
    R_up, R_down, R : float
        Unidirectional and bidirectional repeatability of the axis [unit].
    E_up, E_down, E : float
        Unidirectional and bidirectional systematic positional deviation [unit].
    M : float
        Range of the mean bidirectional positional deviation [unit].
    A_up, A_down, A : float
        Unidirectional and bidirectional accuracy [unit].
    u_B : float
        u(B_k) at the target of ``B`` [unit].
    B_interval : tuple of float
        Simultaneous (Šidák) interval of B at ``coverage`` [unit].
    u_B_mean, nu_B_mean : float
        u(B̄) [unit] and its degrees of freedom [-].
    B_mean_interval : tuple of float
        Interval B̄ ± t_ν u(B̄) at ``coverage`` [unit].
    coverage : float
        Coverage probability of the intervals [-].
    approaches : Approaches or None
        The deviations evaluated.
    warnings : list of str
        Departures from the standard's test conditions.
    """

    unit: str
    n: int
    targets: np.ndarray
    mean_up: np.ndarray
    mean_down: np.ndarray
    s_up: np.ndarray
    s_down: np.ndarray
    R_i_up: np.ndarray
    R_i_down: np.ndarray
    B_i: np.ndarray
    R_i: np.ndarray
    mean_bi: np.ndarray
    u_B_i: np.ndarray
    nu_B_i: np.ndarray
    B: float
    B_signed: float
    B_index: int
    B_mean: float
    R_up: float
    R_down: float
    R: float
    E_up: float
    E_down: float
    E: float
    M: float
    A_up: float
    A_down: float
    A: float
    u_B: float
    B_interval: tuple[float, float]
    u_B_mean: float
    nu_B_mean: float
    B_mean_interval: tuple[float, float]
    coverage: float
    approaches: Approaches | None = None
    warnings: list[str] = field(default_factory=list)

    #: Axis quantities in the order of the standard's summary.
    AXIS_KEYS = ("A", "A_up", "A_down", "B", "B_mean", "E", "E_up", "E_down", "M", "R", "R_up", "R_down")
    #: Per-target arrays.
    TARGET_KEYS = (
        "targets",
        "mean_up",
        "mean_down",
        "s_up",
        "s_down",
        "R_i_up",
        "R_i_down",
        "B_i",
        "R_i",
        "mean_bi",
        "u_B_i",
        "nu_B_i",
    )

    @property
    def m(self) -> int:
        """Number of target positions."""
        return int(self.targets.size)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary: axis values, uncertainties and the per-target table (SI units)."""
        out: dict[str, Any] = {
            "standard": "ISO 230-2:2014",
            "unit": self.unit,
            "targets": self.m,
            "runs_per_direction": self.n,
            "axis": {k: float(getattr(self, k)) for k in self.AXIS_KEYS},
            "reversal": {
                "B": self.B,
                "B_signed": self.B_signed,
                "B_target": float(self.targets[self.B_index]),
                "u_B": self.u_B,
                "B_interval": list(self.B_interval),
                "B_mean": self.B_mean,
                "u_B_mean": self.u_B_mean,
                "nu_B_mean": self.nu_B_mean,
                "B_mean_interval": list(self.B_mean_interval),
                "coverage": self.coverage,
            },
            "per_target": {k: np.asarray(getattr(self, k)).tolist() for k in self.TARGET_KEYS},
            "warnings": list(self.warnings),
        }
        return out


def evaluate(ap: Approaches, coverage: float = COVERAGE) -> Iso230Result:
    """Every ISO 230-2 quantity of an axis, with the uncertainty of B and B̄.

    Parameters
    ----------
    ap : Approaches
        Positional deviations by target, direction and run (at least 2 targets and
        2 runs per direction; :func:`approaches_from_rows` checks this).
    coverage : float
        Coverage probability of the intervals of B and B̄ [-].

    Returns
    -------
    Iso230Result

    Raises
    ------
    DataError
        Fewer than 2 targets or 2 runs per direction.
    """
    up, dn = ap.up, ap.down
    m, n_up = up.shape
    n_dn = dn.shape[1]
    if m < 2 or n_up < 2 or n_dn < 2:
        raise DataError(f"need at least 2 targets and 2 runs per direction, got {m} × {n_up}/{n_dn}")
    mean_up = up.mean(axis=1)
    mean_dn = dn.mean(axis=1)
    s_up = up.std(axis=1, ddof=1)
    s_dn = dn.std(axis=1, ddof=1)
    R_i_up = 4.0 * s_up
    R_i_dn = 4.0 * s_dn
    B_i = mean_up - mean_dn
    R_i = np.maximum.reduce([2.0 * s_up + 2.0 * s_dn + np.abs(B_i), R_i_up, R_i_dn])
    mean_bi = 0.5 * (mean_up + mean_dn)
    k = int(np.argmax(np.abs(B_i)))
    both = np.concatenate([mean_up, mean_dn])

    # type-A uncertainty of the reversal values (Welch–Satterthwaite)
    var_up = s_up**2 / n_up
    var_dn = s_dn**2 / n_dn
    u2 = var_up + var_dn
    u_B_i = np.sqrt(u2)
    den = var_up**2 / (n_up - 1) + var_dn**2 / (n_dn - 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        nu_B_i = np.where(den > 0, u2**2 / np.where(den > 0, den, 1.0), np.inf)
    alpha = 1.0 - coverage
    alpha_each = 1.0 - coverage ** (1.0 / m)  # Šidák: all m intervals hold with probability `coverage`
    c_each = _t_quantile(1.0 - alpha_each / 2.0, nu_B_i)
    lo_i = np.maximum(np.abs(B_i) - c_each * u_B_i, 0.0)
    hi_i = np.abs(B_i) + c_each * u_B_i
    u_mean = float(math.sqrt(u2.sum()) / m)
    den_mean = float(den.sum())
    nu_mean = float(u2.sum() ** 2 / den_mean) if den_mean > 0 else math.inf
    c_mean = float(_t_quantile(1.0 - alpha / 2.0, nu_mean))
    B_mean = float(B_i.mean())

    return Iso230Result(
        unit=ap.unit,
        n=n_up,
        targets=ap.targets,
        mean_up=mean_up,
        mean_down=mean_dn,
        s_up=s_up,
        s_down=s_dn,
        R_i_up=R_i_up,
        R_i_down=R_i_dn,
        B_i=B_i,
        R_i=R_i,
        mean_bi=mean_bi,
        u_B_i=u_B_i,
        nu_B_i=nu_B_i,
        B=float(np.abs(B_i).max()),
        B_signed=float(B_i[k]),
        B_index=k,
        B_mean=B_mean,
        R_up=float(R_i_up.max()),
        R_down=float(R_i_dn.max()),
        R=float(R_i.max()),
        E_up=float(mean_up.max() - mean_up.min()),
        E_down=float(mean_dn.max() - mean_dn.min()),
        E=float(both.max() - both.min()),
        M=float(mean_bi.max() - mean_bi.min()),
        A_up=float((mean_up + 2.0 * s_up).max() - (mean_up - 2.0 * s_up).min()),
        A_down=float((mean_dn + 2.0 * s_dn).max() - (mean_dn - 2.0 * s_dn).min()),
        A=float(
            np.concatenate([mean_up + 2.0 * s_up, mean_dn + 2.0 * s_dn]).max()
            - np.concatenate([mean_up - 2.0 * s_up, mean_dn - 2.0 * s_dn]).min()
        ),
        u_B=float(u_B_i[k]),
        B_interval=(float(lo_i.max()), float(hi_i.max())),
        u_B_mean=u_mean,
        nu_B_mean=nu_mean,
        B_mean_interval=(B_mean - c_mean * u_mean, B_mean + c_mean * u_mean),
        coverage=coverage,
        approaches=ap,
        warnings=list(ap.warnings),
    )
