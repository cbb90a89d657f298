"""Plausibility of a transmission-error campaign, before anything is fitted.

Real recordings fail in a few typical ways, each of which a model would learn as
"transmission error" without a word: the motor encoder counts against the linear
scale, a wrong gearbox ratio or unit, two position zeros that differ (or differ from
run to run), passes that cover only part of the travel, one training load only, a
torque column in the wrong unit or sign, a sample rate too low for the tooth mesh.
:func:`check_runs` measures each of them per run and per direction and returns a
:class:`PlausibilityReport`: gross problems are **errors** (the campaign is refused),
doubtful ones **warnings**; every finding is one line naming the file and the problem.

Every threshold is a module constant; the reasons are in docs/assumptions.md
("TE campaign plausibility").
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drivelash.errors import DataError
from drivelash.te.learn.preprocess import LOAD_TRIM, direction_key
from drivelash.te.runtime.cnc import TE_LIMIT
from drivelash.units import LENGTH_TO_M

__all__ = [
    "Finding",
    "PlausibilityReport",
    "RunRecord",
    "check_campaign",
    "check_runs",
    "record_of",
]

#: Ratio k = Δx_T / Δx_M of scale to motor travel: error beyond this deviation from 1 (1 %).
RATIO_ERROR = 1e-2
#: Warning beyond this deviation (1 mm per metre: far above any rack's pitch error).
RATIO_WARN = 1e-3
#: |median TE| of a run (and |TE| anywhere on a geometric run): error beyond [m] (the two position
#: zeros differ) — the limit ``te export`` puts on the no-load TE of every table it writes
#: (:data:`drivelash.te.runtime.cnc.TE_LIMIT`, 1 mm), so that a campaign it would refuse is not
#: imported and trained first (finding TH14: 5 mm here, a 2 mm offset was imported, fitted and
#: refused at the last step by the .ini/.COM export while the .csv table was written).
ZERO_ERROR = TE_LIMIT
#: |median TE| of a run: warning beyond [m].
ZERO_WARN = 0.5e-3
#: Runs share a position zero (the zero advice, :func:`_zero_advice`): the runs' median TE,
#: sorted, split where two neighbours lie more than this apart [m] — one partition of the runs,
#: clustered once; a group spanning more than it has no common zero (drifting zeros). 0.5 mm, the
#: mixed-zero limit (``MIXED_ERROR``): runs at one zero differ by the backlash (±b/2 between the
#: directions) and the deflection under load, well under it (seed-0 campaign: 65 µm).
ZERO_SHARE = 0.5e-3
#: Travel [m] a pass may go back against its main motion before it counts as reversing inside
#: the run (out and back in one file, finding D4: blamed on the torque sign). Half a tooth pitch
#: of the example axes (9.4 … 10 mm): far above a settling overshoot (µm) or scale noise, far
#: below any pass (≥ 100 mm); a leg that long holds the other flank's TE under this run's label.
REVERSAL_MIN = 5e-3
#: Machine frame of the linear scale, in multiples of ``[geometry] travel``: machine coordinates
#: (the positions of the CNC tables) lie within ±travel of the machine zero, which is on or near
#: the travel. A campaign whose every x_T lies beyond FRAME_WARN × travel + FRAME_SLACK from zero
#: is warned, beyond FRAME_ERROR × travel + FRAME_SLACK refused (finding D1: an offset of 3.82 m
#: on x_T put a 1.2 m axis's campaign at 3.87 … 4.27 m, accepted). FRAME_SLACK is the travel
#: check's 10 mm.
FRAME_WARN = 1.0
FRAME_ERROR = 2.0
FRAME_SLACK = 0.01
#: Constant part of the campaign's TE (mean over the directions of the median TE of their
#: no-load runs, else of their lowest-load runs): warning beyond [m]. It goes as a constant into
#: the absolute CNC tables (te export), so an arbitrary zero between raw motor counts and the
#: scale would shift the whole axis (finding D10: −460 µm passed silently under the 0.5 mm run
#: limit). The seed-0 quick campaign's constant part is −10 µm (run medians −37 … +16 µm:
#: backlash ±b/2 and deflection cancel between the directions); a rack's cumulative pitch error
#: over a pass is tens of µm.
CONSTANT_TE_WARN = 50e-6
#: Spread [m] of the runs' median TE beyond which, with every run starting within one motor
#: revolution (θ_M at the first samples within 2π) while the scale puts the starts more than a
#: revolution apart, the motor position is single-turn or reset per run (finding D6: a wrapping
#: single-turn count gave +71.97 … +384.03 mm, and the per-run zero advice chased run by run).
#: 5 mm (the zero error's limit until TH14): a homing offset is common to all runs (spread 0), a
#: multi-turn zero differing between runs is "mixed zeros" (MIXED_ERROR, 0.5 mm).
SINGLE_TURN_SPREAD = 5e-3
#: A ``[geometry] contact_ratio`` override more than this relative deviation from the tooth
#: geometry's own ε = ε_α + ε_β is warned (finding D11: 9.0 accepted for a geometry giving 3.05;
#: ε sets the width of the network's bump features). Profile shift and tip relief move ε by a few
#: tenths (the example axes: 2.68, 3.05); the existing tests' data-sheet overrides lie 18 % and
#: 31 % off (2.2 for 2.68, 2.1 for 3.05) — a warning, not an error, for that reason.
CONTACT_RATIO_TOL = 0.3
#: The no-load TE's strongest spatial line with a period in [PITCH_BAND[0], PITCH_BAND[1]] × the
#: stated tooth pitch π m_n/cos β is compared with that pitch: a line more than PITCH_TOL off it
#: (and off its harmonics p/2, p/3) that stands PITCH_PROMINENCE × above the band's median and at
#: least 1/PITCH_LINE_RATIO × above the stated pitch's own line is warned (finding D11: m_n 1.5 mm
#: × 48 teeth stated, 5 mm pitch, the recordings mesh at 10.00 mm). The spectral resolution over a
#: pass of ≥ PITCH_MIN_PITCHES pitches is ≤ 1/20 of the period, half the tolerance; a wrong tooth
#: count with the same d_p shifts the pitch by n_t/n_t' (factor 2 for a swapped pair).
PITCH_BAND = (0.75, 4.0)
PITCH_TOL = 0.1
PITCH_PROMINENCE = 10.0
PITCH_LINE_RATIO = 0.5
PITCH_MIN_PITCHES = 20
#: Offset of one run's TE from the other runs of its direction (load trend removed): error [m].
MIXED_ERROR = 0.5e-3
#: … warning [m].
MIXED_WARN = 0.1e-3
#: Offset of a run's median TE from the median of at least two other runs of its direction at
#: the same load (repeats, e.g. at other velocities): error beyond max(MIXED_SAME_ERROR,
#: MIXED_SAME_SCATTER × their spread), warning beyond max(MIXED_SAME_WARN, that) [m]. In the seed-0
#: campaign equal-load runs agree to 0.35 µm; 20 µm is the whole load-dependent TE it learns
#: (0 → 5000 N: 21 µm), so a zero offset that size would be learnt as load effect.
MIXED_SAME_ERROR = 20e-6
MIXED_SAME_WARN = 5e-6
MIXED_SAME_SCATTER = 10.0
#: The mixed-zero checks compare runs over common positions (:func:`_levels`): TE means per bin of
#: MIXED_BIN [m] of x_T, the median of the differences over at least MIXED_MIN_COMMON common bins.
#: 2 mm: a fifth of the shortest tooth pitch of the example axes (6.3 … 10 mm), so the mesh ripple
#: common to two runs cancels bin by bin; 10 bins (20 mm, two pitches) are the least overlap whose
#: median is not one tooth's.
MIXED_BIN = 2e-3
MIXED_MIN_COMMON = 10
#: Share of the recorded travel a geometric or load pass must cover (warning below).
COVERAGE_WARN = 0.5
#: A load pass reaching further than this [m] beyond its direction's no-load runs is warned:
#: TE_geo is not known there, ``te fit`` uses the load pass only where it is (1 mm, as te update).
GEO_SPAN_TOL = 1e-3
#: Sample spacing over position, in cut-off wavelengths of the low-pass (3 × tooth mesh):
#: error above 1/2 (Nyquist), warning above 1/10.
SPACING_ERROR = 0.5
SPACING_WARN = 0.1
#: Torque growth with load, relative to the rigid-lever value r_eff = d_p/(2 i_PG):
#: warning outside [lo, hi] (efficiency of gearbox and mesh between 50 % and 100 %+).
TORQUE_SLOPE_RANGE = (0.5, 2.0)
#: Torque against the stated loads, one rule (runs of one direction at comparable velocity,
#: geometric runs as 0 N with every velocity; two runs at equal load only when their own velocities
#: are comparable): the higher-load run's mean motor torque d·T must exceed the lower-load run's by
#: at least TORQUE_ORDER_LEVER × r_eff × ΔF − TORQUE_ORDER_NOISE, and runs at equal load must agree
#: within TORQUE_ORDER_NOISE; otherwise an error. The lever term is a quarter of the torque the load
#: difference should add (r_eff·ΔF/η, η ≤ 1); the noise term [N·m] is twice the spread of the mean
#: torque of equal-load runs across 20–100 mm/s in the seed-0 campaign (0.23 N·m, viscous friction;
#: within one velocity it is < 0.01 N·m). It used to demand only that the order not be reversed
#: (−¼ lever), so a 2500 N pass listed as the geometric run (the same torque as the 2500 N runs) or
#: labelled 0 N passed (findings TH1, TH2: +10.3 µm in the exported BACKLASH column).
TORQUE_ORDER_LEVER = 0.25
TORQUE_ORDER_NOISE = 0.5
#: Torque growth with the stated loads (least squares over a direction's load runs) more than this
#: factor off the lever r_eff (above TORQUE_SLOPE_GROSS × or below 1/TORQUE_SLOPE_GROSS ×) is an
#: error naming a unit slip of the loads or the torque (finding TH8: loads in kN, 1000 × the lever,
#: were a warning blaming the torque constant, and the 5000 N passes counted as 5 N training
#: loads). r_eff/η with any gear efficiency η ≥ 0.1 stays inside; η > 1 is impossible.
TORQUE_SLOPE_GROSS = 10.0
#: Runs of one velocity group: measured velocities within this ratio of the group's slowest.
VELOCITY_GROUP = 1.1
#: Relative deviation of a run's measured velocity from its listed velocity (warning).
VELOCITY_WARN = 0.1
#: Further errors named (file and check) after the first one in the one-line refusal.
MORE_LISTED = 4
#: Shortest motion of a run that is judged at all [m].
MIN_MOTION = 5e-3
#: Fastest plausible constant-velocity pass of a rack-and-pinion axis [m/s] and highest plausible
#: sample rate of a drive/CNC trace [Hz]: beyond either the time unit is wrong (finding A10: time
#: in s declared as ms made a 10 mm/s pass "10 m/s sampled at 1 MHz"). Rack drives reach a few
#: m/s in rapid traverse, TE passes are far slower; drive oscilloscopes sample at ≤ 32 kHz.
MAX_PASS_SPEED = 5.0
MAX_SAMPLE_RATE = 100e3
#: Unit slips recognised in the ratio k (factor → description).
_UNIT_SLIPS = (
    (1e3, "x_T looks like millimetres read as metres (declare unit 'mm')"),
    (1e6, "x_T looks like micrometres read as metres (declare unit 'um')"),
    (1e-3, "x_T looks like metres declared as millimetres (check the unit)"),
    (1e-6, "x_T looks like metres declared as micrometres (check the unit)"),
)


@dataclass(frozen=True)
class RunRecord:
    """One run as the checks see it (SI columns).

    Attributes
    ----------
    label : str
        File named in messages.
    kind : str
        ``geometric``, ``load`` or ``sine``.
    direction : int
        +1, −1 (0 for sine).
    load : float
        Process load [N].
    velocity : float or None
        Listed travel speed [m/s] (None: not listed).
    t, x_T, theta_m, torque_m : numpy.ndarray
        Time [s], table position [m], motor angle [rad], motor torque [N·m].
    """

    label: str
    kind: str
    direction: int
    load: float
    velocity: float | None
    t: np.ndarray
    x_T: np.ndarray
    theta_m: np.ndarray
    torque_m: np.ndarray


@dataclass(frozen=True)
class Finding:
    """One plausibility finding: ``level`` is ``"error"`` or ``"warning"``."""

    level: str
    check: str
    file: str
    message: str

    def line(self) -> str:
        """``FILE: problem`` (one line)."""
        return f"{self.file}: {self.message}"


@dataclass
class PlausibilityReport:
    """Findings and the measured figures of every check.

    Attributes
    ----------
    findings : list of Finding
        Errors and warnings, in the order of the checks.
    runs : list of dict
        Per run: ratio k, median TE [m], covered range [m], sample spacing [m], measured
        velocity [m/s], mean torque [N·m].
    directions : dict
        Per direction (``"pos"``/``"neg"``): training loads [N], torque slope [N·m/N],
        covered range [m].
    constant_te : float or None
        Constant part of the TE [m] (:func:`_constant_part`).
    valid_range : tuple of float or None
        Positions [m] covered by the geometric runs of both directions where the load passes
        were recorded too (where a model of this campaign is valid; :func:`_measured_under_load`).
    """

    findings: list[Finding] = field(default_factory=list)
    runs: list[dict[str, Any]] = field(default_factory=list)
    directions: dict[str, dict[str, Any]] = field(default_factory=dict)
    valid_range: tuple[float, float] | None = None
    constant_te: float | None = None

    @property
    def errors(self) -> list[Finding]:
        """The errors."""
        return [f for f in self.findings if f.level == "error"]

    @property
    def warnings(self) -> list[Finding]:
        """The warnings."""
        return [f for f in self.findings if f.level == "warning"]

    def raise_errors(self) -> None:
        """Raise the first error as a one-line :class:`~drivelash.errors.DataError` (the others follow)."""
        errs = self.errors
        if errs:
            rest = [f"{Path(f.file).name}: {f.check}" for f in errs[1:]]
            shown = ", ".join(rest[:MORE_LISTED]) + (", …" if len(rest) > MORE_LISTED else "")
            more = f" (and {len(rest)} more error(s): {shown})" if rest else ""
            raise DataError(f"implausible campaign: {errs[0].message}{more}", path=errs[0].file)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (stored in an imported campaign's manifest)."""
        return {
            "errors": [f.line() for f in self.errors],
            "warnings": [f.line() for f in self.warnings],
            "runs": self.runs,
            "directions": self.directions,
            "valid_range": list(self.valid_range) if self.valid_range else None,
            "constant_te_m": self.constant_te,
        }


def _moving(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Samples where the table moves (speed above 20 % of the run's 95th-percentile speed)."""
    v = np.gradient(x, t) if x.size > 2 else np.zeros_like(x)
    ref = float(np.percentile(np.abs(v), 95)) if v.size else 0.0
    return np.abs(v) > 0.2 * ref if ref > 0 else np.zeros(x.size, bool)


def _position_gap(x: np.ndarray, t: np.ndarray, mv: np.ndarray, limit: float) -> tuple[int, float] | None:
    """The first step of x_T beyond ``limit`` [m] between two samples while moving, as (index of
    the sample before it, |step| [m]); None if there is none."""
    if x.size < 2:
        return None
    step = np.abs(np.diff(x))
    moving = mv[:-1] | mv[1:]
    big = np.flatnonzero(moving & (step > limit))
    if big.size == 0:
        return None
    i = int(big[0])
    return i, float(step[i])


def _ratio(x_T: np.ndarray, x_M: np.ndarray) -> float:
    """Least-squares slope k of x_T over x_M (both centred): Δx_T ≈ k Δx_M."""
    a = x_M - x_M.mean()
    b = x_T - x_T.mean()
    den = float(np.dot(a, a))
    return float(np.dot(a, b) / den) if den > 0 else float("nan")


def _sign_advice(column: str, scales: dict[str, float] | None) -> str:
    """How to flip the sign of ``column`` given the ``scale`` its [columns] mapping already has."""
    scale = (scales or {}).get(column)
    if scale is None or scale == 1.0:
        return f"set scale = -1 on the {column} column in [columns]"
    if scale < 0:
        return (
            f"its [columns] mapping already has scale = {scale:g}, which flips it: set scale = {-scale:g}"
            f" on the {column} column"
        )
    return f"set scale = {-scale:g} (now {scale:g}) on the {column} column in [columns]"


#: Length units a [columns] mapping of x_T may declare, in metres (for :func:`_declared_slip`).
_LENGTH_UNITS = {**LENGTH_TO_M, "nm": 1e-9}


def _declared_slip(k: float, declared: tuple[str, str] | None) -> str | None:
    """The unit slip behind a ratio ``k`` given the declared ``(file column, unit)`` of x_T, or None.

    The file holds x_T in a unit ``1/k`` times the declared one: e.g. k = 1000 under ``unit =
    "mm"`` is micrometres (finding A3: the advice was "declare unit 'mm'", the unit declared).
    """
    if declared is None:
        return None
    column, unit = declared
    scale = _LENGTH_UNITS.get(unit)
    if scale is None:
        return None
    for name, s in _LENGTH_UNITS.items():
        if name != "µm" and name != unit and abs(scale / s / k - 1.0) < 0.05:
            return (
                f"x_T is {k:.4g}× the motor travel: column {column!r} looks like {name} declared as"
                f" {unit} (set unit = {name!r} in [columns.{column}])"
            )
    return None


def _ratio_message(
    k: float,
    label_theta: str = "theta_m",
    scales: dict[str, float] | None = None,
    x_unit: tuple[str, str] | None = None,
    scale_odd: bool = False,
) -> str:
    if not math.isfinite(k):
        return "the motor angle does not move: check the theta_m column"
    if abs(k + 1.0) < 0.05:
        if scale_odd:  # the motor agrees with the listed direction: the scale counts the other way
            return (
                f"TE slope {1 - k:+.3f} m/m: the linear scale counts against the motor and the listed"
                f" direction (scale sign) — {_sign_advice('x_T', scales)}"
            )
        return (
            f"TE slope {1 - k:+.3f} m/m: the motor encoder counts against the linear scale"
            f" (encoder sign) — {_sign_advice(label_theta, scales)}"
        )
    slip = _declared_slip(k, x_unit)
    if slip is not None:
        return f"TE slope {1 - k:+.4g} m/m: {slip}"
    for factor, text in _UNIT_SLIPS:
        if abs(k / factor - 1.0) < 0.05:
            return f"TE slope {1 - k:+.4g} m/m: {text}"
    return (
        f"TE slope {1 - k:+.4g} m/m: the linear scale moves {k:.6g}× the motor travel θ_M·d_p/(2 i_PG)"
        " — check i_PG, m_n, n_t, helix_angle in [geometry] and counts_per_rev/unit in [columns]"
    )


def _reversal(x: np.ndarray) -> tuple[float, tuple[float, float]] | None:
    """Where a pass turns back: (x_T at the turn, (first, last x_T)) [m] when it travels more than
    :data:`REVERSAL_MIN` out from its start and back again towards it; None for one direction."""
    if x.size < 3:
        return None
    a, b = float(x[0]), float(x[-1])
    i_hi, i_lo = int(np.argmax(x)), int(np.argmin(x))
    for i in (i_hi, i_lo):
        turn = float(x[i])
        if min(abs(turn - a), abs(turn - b)) > REVERSAL_MIN:
            return turn, (a, b)
    return None


def _in_frame(lo: float, hi: float, travel: float, factor: float) -> bool:
    """Whether some of [lo, hi] [m] lies within ``factor`` × travel + FRAME_SLACK of zero."""
    lim = factor * travel + FRAME_SLACK
    return hi >= -lim and lo <= lim


def _zero_message(
    med: float,
    r_eff: float,
    x_range: tuple[float, float],
    travel: float | None,
    offsets: dict[str, float] | None,
    peak: float | None = None,
    zero: float | None = None,
    basis: str = "",
) -> str:
    """The advice for two position zeros that differ by the run's median TE ``med`` [m].

    The linear scale reads the machine coordinates the CNC tables are positioned in, so the
    motor column is the one to shift: θ_M + zero/r_eff [rad] makes TE = x_T − θ_M r_eff lose
    ``zero`` (finding D1: the advice on x_T moved the scale, i.e. the tables, by metres). Only when
    the scale itself lies outside the axis's frame (beyond travel from zero) and shifting it by
    −zero brings it in is the x_T column named. ``zero`` [m] is the zero the runs share
    (:func:`_zero_advice`; default ``med``), ``basis`` what it rests on (appended to the advice).
    """
    zero = med if zero is None else zero
    offsets = offsets or {}
    lo, hi = x_range
    head = f"{_zero_said(med, peak)}: the linear scale and the motor position have different zeros"
    if (
        travel is not None
        and not _in_frame(lo, hi, travel, FRAME_WARN)
        and _in_frame(lo - zero, hi - zero, travel, FRAME_WARN)
    ):
        now = offsets.get("x_T", 0.0)
        was = f" (now {now:g})" if now else ""
        return (
            f"{head}, and x_T lies at {lo:.4g} … {hi:.4g} m, beyond the travel ({travel:g} m) of any"
            f" machine frame — the scale's zero is off: set offset = {now - zero:.6g} (m){was} on the x_T"
            f" column in [columns] or home both{basis}"
        )
    now = offsets.get("theta_m", 0.0)
    was = f" (now {now:g})" if now else ""
    return (
        f"{head} — the scale gives the machine coordinates of the tables: set offset ="
        f" {now + zero / r_eff:.6f} (rad){was} on the theta_m column in [columns] (the motor encoder's"
        f" zero to the scale's) or home both{basis}"
    )


def _zero_said(med: float, peak: float | None) -> str:
    """``TE is +2.025 mm (limit 1 mm, te export's for a no-load TE)``: a run's TE against the zero
    limit. A median within the limit whose run reaches beyond it (``peak`` [m]) is named by the
    peak: "TE is +0.990 mm (limit 1 mm)" read as a contradiction (session 34 last read)."""
    said = (
        f"TE reaches {peak * 1e3:.3f} mm (median {med * 1e3:+.3f} mm"
        if peak is not None and abs(med) <= ZERO_ERROR < peak
        else f"TE is {med * 1e3:+.3f} mm ("
    )
    sep = "; " if said.endswith("mm") else ""
    return f"{said}{sep}limit {ZERO_ERROR * 1e3:g} mm, te export's for a no-load TE)"


def _te_level(items: Sequence[tuple[RunRecord, float]]) -> tuple[float, list[int]] | None:
    """The constant part of the TE from runs and their median TE [m]: per direction the median of
    its geometric runs (else of its lowest-load runs), the mean over the directions — the
    backlash ±b/2 cancels between them. Returns it and the directions it rests on; None without a
    geometric or load run of either direction. One rule for the zero advice and the constant part."""
    levels, dirs = [], []
    for d in (1, -1):
        rr = [(r, m) for r, m in items if r.direction == d and r.kind in ("geometric", "load")]
        if not rr:
            continue
        geo = [m for r, m in rr if r.kind == "geometric"]
        if not geo:
            low = min(r.load for r, _ in rr)
            geo = [m for r, m in rr if r.load == low]
        levels.append(float(np.median(geo)))
        dirs.append(d)
    return (float(np.mean(levels)), dirs) if levels else None


def _zero_groups(seen: Sequence[tuple[RunRecord, float]]) -> list[list[tuple[RunRecord, float]]]:
    """The runs' position zeros clustered once: ``seen`` (run, median TE [m]) sorted by median TE
    and split where two neighbours lie more than :data:`ZERO_SHARE` apart — a partition, every
    run in one group."""
    groups: list[list[tuple[RunRecord, float]]] = []
    for item in sorted(seen, key=lambda it: it[1]):
        if groups and item[1] - groups[-1][-1][1] <= ZERO_SHARE:
            groups[-1].append(item)
        else:
            groups.append([item])
    return groups


def _listed(items: Sequence[tuple[RunRecord, float]]) -> str:
    """``run03.csv, run07.csv``: the runs' file names, at most :data:`MORE_LISTED` of them."""
    names = [Path(r.label).name for r, _ in items]
    return ", ".join(names[:MORE_LISTED]) + (", …" if len(names) > MORE_LISTED else "")


def _te_range(items: Sequence[tuple[RunRecord, float]]) -> str:
    """``median TE +1.980 … +2.029 mm`` of the runs."""
    meds = [m for _, m in items]
    return f"median TE {min(meds) * 1e3:+.3f} … {max(meds) * 1e3:+.3f} mm"


def _zero_advice(
    rep: PlausibilityReport,
    errors: Sequence[tuple[int, RunRecord, float, tuple[float, float], float]],
    seen: Sequence[tuple[RunRecord, float]],
    r_eff: float,
    travel: float | None,
    offsets: dict[str, float] | None,
) -> None:
    """The messages of the zero errors, once every run's median TE is known.

    An offset in ``[columns]`` applies to every file, so it is advised only for a zero most runs
    share (session 36, tester H, TH13 b: one run of ten homed 2 mm off got "set offset = 0.763463
    (rad) on the theta_m column", which would have moved the nine others 2 mm off; tester J, J1:
    two runs of ten got it from their own group, and drifting zeros got four different offsets
    from overlapping groups). The runs' zeros are clustered once (:func:`_zero_groups`, a
    partition at :data:`ZERO_SHARE`), and a run beyond the limit is judged by its group:

    * the group spans more than :data:`ZERO_SHARE`: drifting zeros, no common zero, no offset;
    * it is the only run that reached the check: its own median, said to rest on this run alone;
    * the group holds more than half of the runs: the offset of its zero (:func:`_te_level`),
      named with their number and TE range, and the runs at another zero named;
    * otherwise mixed zeros, no offset — the group's runs named: home and record them again.

    Every run of a group gets the same advice (one offset value).

    Parameters
    ----------
    rep : PlausibilityReport
        Its zero findings (indices in ``errors``) are rewritten.
    errors : sequence
        Per zero error: finding index, run, median TE [m], x_T range [m], |TE| peak [m].
    seen : sequence of (RunRecord, float)
        Every run that reached the zero check and its median TE [m].
    r_eff, travel, offsets
        As for :func:`_zero_message`.
    """
    groups = _zero_groups(seen)
    n = len(seen)
    for k, r, med, x_range, peak in errors:
        cluster = next(g for g in groups if any(o is r for o, _ in g))
        group = [(o, m) for o, m in seen if any(o is x for x, _ in cluster)]  # in the runs' order
        rest = [(o, m) for o, m in seen if not any(o is x for x, _ in cluster)]
        said = _zero_said(med, peak)
        meds = [m for _, m in group]
        if max(meds) - min(meds) > ZERO_SHARE:
            who = f"all {n} runs" if not rest else f"{len(group)} runs ({_listed(group)})"
            msg = (
                f"{said}: the zeros of {who} drift ({_te_range(group)}, no gap over {ZERO_SHARE * 1e3:g} mm"
                f" between neighbours, {(max(meds) - min(meds)) * 1e3:.3f} mm end to end): no common zero"
                " (an encoder or scale slipping, homed in between?) — an offset in [columns] applies to"
                " every file and none fits these runs: home both and record them again"
            )
        elif n == 1:
            basis = " (from this run alone: no other run confirms the zero)"
            msg = _zero_message(med, r_eff, x_range, travel, offsets, peak, med, basis)
        elif 2 * len(group) > n:
            level = _te_level(group)
            zero = level[0] if level is not None else float(np.median(meds))
            basis = (
                f" (the zero of the {len(group)} runs that share it, {_te_range(group)}"
                + (
                    f"; the {len(rest)} other run(s) ({_listed(rest)}) sit at another zero: home and"
                    " record them again, or leave them out of [[runs]]"
                    if rest
                    else ""
                )
                + ")"
            )
            msg = _zero_message(med, r_eff, x_range, travel, offsets, peak, zero, basis)
        elif len(group) == 1:
            msg = (
                f"{said}: this run's zero differs from the {len(rest)} other run(s) ({_te_range(rest)}):"
                " mixed position zeros (homed in between?) — an offset in [columns] applies to every"
                " file: home and record this run again, or leave it out of [[runs]]"
            )
        else:
            msg = (
                f"{said}: this run's zero is shared by {len(group)} of the {n} runs ({_listed(group)};"
                f" {_te_range(group)}), the {len(rest)} other run(s) sit at another zero"
                f" ({_te_range(rest)}): mixed position zeros (homed in between?) — an offset in"
                " [columns] applies to every file: home and record these runs again, or leave them out"
                " of [[runs]]"
            )
        f = rep.findings[k]
        rep.findings[k] = Finding(f.level, f.check, f.file, msg)


def _contact_ratio(geometry: Any, source: str, add: Any) -> None:
    """A ``contact_ratio`` override beyond :data:`CONTACT_RATIO_TOL` of the geometry's ε_α + ε_β."""
    eps = getattr(geometry, "contact_ratio", None)
    if eps is None:
        return
    own = float(geometry.epsilon_alpha + geometry.epsilon_beta)
    if abs(eps / own - 1.0) > CONTACT_RATIO_TOL:
        add(
            "warning",
            "geometry",
            source,
            f"[geometry] contact_ratio = {eps:g}, the tooth geometry gives ε = {own:.3g} (ε_α"
            f" {geometry.epsilon_alpha:.3g} + ε_β {geometry.epsilon_beta:.3g} with face_width"
            f" {geometry.face_width:g} m): more than {CONTACT_RATIO_TOL:.0%} off — check the value"
            " (it sets the width of the tooth-mesh features)",
        )


def mesh_line(x: np.ndarray, te: np.ndarray, tooth_pitch: float) -> tuple[float, float, float, float] | None:
    """The strongest spatial line of a no-load TE near the tooth pitch.

    Parameters
    ----------
    x, te : numpy.ndarray
        Table position and TE [m] of one pass (any order).
    tooth_pitch : float
        Stated tooth pitch p [m].

    Returns
    -------
    (period, amplitude, median, at_pitch) or None
        Period [m] of the strongest line with a period in :data:`PITCH_BAND` × p, its amplitude,
        the band's median amplitude and the largest amplitude within :data:`PITCH_TOL` of p
        (same arbitrary unit); None for a pass shorter than :data:`PITCH_MIN_PITCHES` pitches.
    """
    o = np.argsort(x)
    xs, ys = x[o], te[o]
    span = float(xs[-1] - xs[0]) if xs.size else 0.0
    if span < PITCH_MIN_PITCHES * tooth_pitch:
        return None
    dx = tooth_pitch / 40.0
    grid = np.arange(xs[0], xs[-1], dx)
    y = np.interp(grid, xs, ys)
    u = (grid - grid.mean()) / span
    y = y - np.polyval(np.polyfit(u, y, 3), u)
    amp = np.abs(np.fft.rfft(y * np.hanning(y.size)))
    period = 1.0 / np.maximum(np.fft.rfftfreq(y.size, dx), 1e-300)
    band = (period >= PITCH_BAND[0] * tooth_pitch) & (period <= PITCH_BAND[1] * tooth_pitch)
    if band.sum() < 3:
        return None
    i = int(np.flatnonzero(band)[np.argmax(amp[band])])
    near = np.abs(period / tooth_pitch - 1.0) <= PITCH_TOL
    at_p = float(amp[near].max()) if near.any() else 0.0
    return float(period[i]), float(amp[i]), float(np.median(amp[band])), at_p


def _mesh_period(
    judged: Sequence[tuple[RunRecord, Any]], r_eff: float, tooth_pitch: float, source: str, add: Any
) -> None:
    """The no-load TE's tooth-mesh line against the stated tooth pitch (:data:`PITCH_TOL`)."""
    for r, _ in judged:
        if r.kind != "geometric":
            continue
        x = np.asarray(r.x_T, dtype=np.float64)
        mv = _moving(x, np.asarray(r.t, dtype=np.float64))
        te = x - np.asarray(r.theta_m, dtype=np.float64) * r_eff
        line = mesh_line(x[mv], te[mv], tooth_pitch)
        if line is None:
            continue
        per, amp, med, at_p = line
        harmonic = any(abs(per * k / tooth_pitch - 1.0) <= PITCH_TOL for k in (1, 2, 3))
        if not harmonic and amp >= PITCH_PROMINENCE * med and at_p <= PITCH_LINE_RATIO * amp:
            add(
                "warning",
                "pitch",
                r.label,
                f"the no-load TE's tooth-mesh line is at {per * 1e3:.2f} mm, the [geometry] gives a tooth"
                f" pitch π m_n/cos β of {tooth_pitch * 1e3:.2f} mm: check m_n and n_t (the low-pass and"
                " the mesh features use the stated pitch)",
            )
        return  # one geometric run is enough


def _single_turn(
    starts: Sequence[tuple[float, float, float]], r_eff: float, rep: PlausibilityReport, source: str
) -> None:
    """A single-turn (or per-run reset) motor position: its zero differs from run to run.

    Every run starts within one motor revolution (the first θ_M [rad] within 2π) while the scale
    puts the starts more than one revolution (2π r_eff [m]) apart, and the runs' median TE spread
    beyond :data:`SINGLE_TURN_SPREAD`: no offset on any column fixes it (finding D6). The runs'
    zero findings are replaced, in place of the first, by one error without offset advice.

    Parameters
    ----------
    starts : sequence of (float, float, float)
        Per judged run: θ_M [rad] and x_T [m] at the first sample, median TE [m].
    r_eff : float
        Kinematic ratio d_p/(2 i_PG) [m/rad].
    rep : PlausibilityReport
        Its findings are edited.
    source : str
        File named by the error (the axis file).
    """
    if len(starts) < 2:
        return
    th0, x0, med = (np.array(v) for v in zip(*starts, strict=True))
    rev = 2.0 * math.pi
    if not (np.ptp(th0) < rev and np.ptp(x0) > rev * r_eff and np.ptp(med) > SINGLE_TURN_SPREAD):
        return
    at = [i for i, f in enumerate(rep.findings) if f.check == "zero"]
    pos = at[0] if at else len(rep.findings)
    rep.findings[:] = [f for f in rep.findings if f.check != "zero"]
    rep.findings.insert(
        min(pos, len(rep.findings)),
        Finding(
            "error",
            "zero",
            source,
            f"TE is {med.min() * 1e3:+.3f} … {med.max() * 1e3:+.3f} mm, a different zero in every run: the"
            f" motor position starts within one revolution in every run (theta_m {th0.min():.3f} …"
            f" {th0.max():.3f} rad) while x_T starts at {x0.min() * 1e3:.1f} … {x0.max() * 1e3:.1f} mm —"
            " the motor position is single-turn / reset per run: record the multi-turn (absolute)"
            " position (no offset can fix it)",
        ),
    )


def _frame(
    per_run: Sequence[dict[str, Any]],
    travel: float | None,
    offsets: dict[str, float] | None,
    source: str,
    add: Any,
) -> None:
    """x_T of every run beyond the axis's machine frame (±travel around zero): warning beyond
    FRAME_WARN × travel, error beyond FRAME_ERROR × travel (+ FRAME_SLACK each)."""
    spans = [i["range_m"] for i in per_run if "range_m" in i]
    if travel is None or not spans:
        return
    lo, hi = min(a for a, _ in spans), max(b for _, b in spans)
    if _in_frame(lo, hi, travel, FRAME_WARN):
        return
    x_off = (offsets or {}).get("x_T", 0.0)
    why = (
        f"the offset = {x_off:g} (m) on the x_T column in [columns] moved it there — the scale gives"
        " the machine coordinates of the tables: shift the motor column (theta_m) instead"
        if abs(x_off) > FRAME_SLACK
        else "the scale's zero or unit is off (the CNC tables are positioned in the scale's coordinates)"
    )
    err = not _in_frame(lo, hi, travel, FRAME_ERROR)
    add(
        "error" if err else "warning",
        "frame",
        source,
        f"x_T lies at {lo:.4g} … {hi:.4g} m, beyond the [geometry] travel of {travel:g} m from the machine"
        f" zero everywhere: {why}",
    )


def check_runs(
    runs: Sequence[RunRecord],
    r_eff: float,
    tooth_pitch: float,
    travel: float | None = None,
    max_load: float = math.inf,
    cutoff_factor: float = 3.0,
    source: str = "campaign",
    column_scales: dict[str, float] | None = None,
    x_unit: tuple[str, str] | None = None,
    for_score: bool = False,
    column_offsets: dict[str, float] | None = None,
    n_t: int | None = None,
    trim: float = LOAD_TRIM,
    geometry: Any = None,
) -> PlausibilityReport:
    """Run every plausibility check on a campaign's runs.

    Parameters
    ----------
    runs : sequence of RunRecord
        The runs (any kinds).
    r_eff : float
        Kinematic ratio d_p/(2 i_PG) [m/rad] of the axis description.
    tooth_pitch : float
        Travel per tooth π d_p/n_t [m].
    travel : float, optional
        Travel of the axis description [m].
    max_load : float
        Largest training load [N]: loads above it are not counted as training loads.
    cutoff_factor : float
        Low-pass cut-off of the preprocessing, in tooth-mesh spatial frequencies.
    source : str
        File named by campaign-level findings (the axis file or the manifest).
    column_scales : dict, optional
        ``scale`` of the [columns] mapping per trace column (``theta_m``, ``torque_m``), so
        that sign advice accounts for a sign already flipped there.
    x_unit : tuple of str, optional
        ``(file column, declared unit)`` of the x_T mapping, so that a unit slip is named
        against the unit declared (e.g. µm under ``unit = "mm"``).
    column_offsets : dict, optional
        ``offset`` of the [columns] mapping per trace column (``x_T`` [m], ``theta_m`` [rad]):
        zero advice states the total offset to set, and an x_T offset that moves the campaign out
        of the axis's frame is named (:func:`_frame`).
    for_score : bool
        Passes recorded to be scored (``te score``), not fitted: a direction without a geometric
        run, or with fewer than 2 training loads, is a warning instead of an error (nothing is
        learnt from them; ``te fit`` checks the campaign again and refuses it).
    n_t : int, optional
        Pinion teeth: with ``tooth_pitch`` the pinion circumference n_t·p [m]. Load passes
        that leave less than one revolution to train on narrow the valid range to what they
        leave (:func:`_measured_under_load`); without ``n_t`` that check is skipped.
    trim : float
        Travel [m] ``te fit`` drops at both ends of each load run (:data:`LOAD_TRIM`).
    geometry : RackGeometry, optional
        The axis's geometry: a ``contact_ratio`` override far from its own ε is warned
        (:func:`_contact_ratio`).

    Returns
    -------
    PlausibilityReport
    """
    rep = PlausibilityReport()

    def add(level: str, check: str, file: str, msg: str) -> None:
        rep.findings.append(Finding(level, check, file, msg))

    _duplicates(runs, add)
    _contact_ratio(geometry, source, add)
    lam_c = tooth_pitch / cutoff_factor  # shortest wavelength the model keeps [m]
    per_run: list[dict[str, Any]] = []
    starts: list[tuple[float, float, float]] = []  # (θ_M, x_T at the first sample, median TE) per run
    zero_seen: list[tuple[RunRecord, float]] = []  # every run that reached the zero check: median TE
    zero_errors: list[tuple[int, RunRecord, float, tuple[float, float], float]] = []
    for r in runs:
        x, th, tq, t = (np.asarray(a, dtype=np.float64) for a in (r.x_T, r.theta_m, r.torque_m, r.t))
        x_M = th * r_eff
        mv = _moving(x, t)
        span = float(np.ptp(x[mv])) if mv.any() else 0.0
        info: dict[str, Any] = {"file": r.label, "kind": r.kind, "direction": r.direction, "load": r.load}
        per_run.append(info)
        if span < MIN_MOTION:
            add(
                "error",
                "motion",
                r.label,
                f"the table moves only {span * 1e3:.2f} mm: not a pass (x_T column?)",
            )
            continue
        rev = _reversal(x) if r.kind != "sine" else None
        if rev is not None:
            k_rev = _ratio(x[mv], x_M[mv])
            if math.isfinite(k_rev) and k_rev > 0 and abs(k_rev - 1.0) > RATIO_ERROR:
                # x_T a unit's factor off the motor: the "turn" is the end-of-pass overshoot (µm)
                # magnified — the ratio check below names the unit (finding TH6: µm declared as
                # mm made a 6.5 µm overshoot a 6.5 mm "reversal": "split the file")
                rev = None
        if rev is not None:
            x_turn, ends = rev
            add(
                "error",
                "reversal",
                r.label,
                f"the run reverses at {x_turn * 1e3:.1f} mm (x_T {ends[0] * 1e3:.1f} → {x_turn * 1e3:.1f} →"
                f" {ends[1] * 1e3:.1f} mm): one pass per run — split the file into one run per direction"
                " in [[runs]]",
            )
            info["gross"] = True
            continue
        k = _ratio(x[mv], x_M[mv])
        te = x - x_M
        med = float(np.median(te[mv]))
        T_s = float(np.median(np.diff(t)))
        v_meas = float(np.median(np.abs(np.gradient(x, t)[mv])))
        spacing = v_meas * T_s
        lo, hi = (float(x[mv].min()), float(x[mv].max()))
        info.update(
            {
                "ratio": k,
                "te_median_m": med,
                "range_m": [lo, hi],
                "sample_rate_hz": 1.0 / T_s,
                "spacing_m": spacing,
                "velocity_measured": v_meas,
                "torque_mean": float(np.mean(tq[mv])),
            }
        )
        # 1. encoder sign, ratio and position units
        if not (math.isfinite(k) and abs(k - 1.0) <= RATIO_ERROR):
            # which of the two counts the other way: the one that disagrees with the listed direction
            moved_m = float(np.median(np.gradient(x_M, t)[mv]))
            odd = r.direction != 0 and r.kind != "sine" and np.sign(moved_m) == r.direction
            add(
                "error",
                "ratio",
                r.label,
                _ratio_message(k, scales=column_scales, x_unit=x_unit, scale_odd=bool(odd)),
            )
            info["gross"] = True
            continue
        if abs(k - 1.0) > RATIO_WARN:
            add(
                "warning",
                "ratio",
                r.label,
                f"TE slope {1 - k:+.2e} m/m is large for a rack (pitch errors are ~1e-5 m/m):"
                " check i_PG and the pinion data in [geometry]",
            )
        # 2. the two position zeros
        starts.append((float(th[0]), float(x[0]), med))
        zero_seen.append((r, med))
        peak = float(np.max(np.abs(te[mv]))) if r.kind == "geometric" else abs(med)
        if abs(med) > ZERO_ERROR or peak > ZERO_ERROR:
            zero_errors.append((len(rep.findings), r, med, (lo, hi), peak))
            add("error", "zero", r.label, "")  # the advice once every run is read: _zero_advice
            info["gross"] = True
            continue
        if abs(med) > ZERO_WARN:
            add(
                "warning",
                "zero",
                r.label,
                f"TE is {med * 1e3:+.3f} mm on average: are both positions homed? (te export refuses a"
                f" no-load TE beyond {ZERO_ERROR * 1e3:g} mm)",
            )
        # 2b. the time unit (after the ratio: x_T agrees with the motor, so a speed beyond a rack
        # pass comes from the time column; the sample rate scales with it too)
        if v_meas > MAX_PASS_SPEED or 1.0 / T_s > MAX_SAMPLE_RATE:
            add(
                "error",
                "time",
                r.label,
                f"moves at {v_meas:.4g} m/s sampled at {1 / T_s:.4g} Hz: not a rack-and-pinion pass"
                f" (limits {MAX_PASS_SPEED:g} m/s, {MAX_SAMPLE_RATE / 1e3:g} kHz) — check the unit of the"
                " time column (time in s declared as ms gives 1000× both)",
            )
            info["gross"] = True
            continue
        # 3. sample rate against the tooth mesh
        need_mm = SPACING_ERROR * lam_c * 1e3
        rate_ok = v_meas / (SPACING_WARN * lam_c)
        if spacing > SPACING_ERROR * lam_c:
            add(
                "error",
                "sampling",
                r.label,
                f"{1 / T_s:.4g} Hz at {v_meas * 1e3:.4g} mm/s puts {spacing * 1e3:.3g} mm between samples;"
                f" the tooth mesh (pitch {tooth_pitch * 1e3:.4g} mm) needs <= {need_mm:.3g} mm"
                f" (>= {v_meas / (SPACING_ERROR * lam_c):.0f} Hz at this speed); record at"
                f" >= {rate_ok:.0f} Hz to avoid the coarse-sampling warning too",
            )
        elif spacing > SPACING_WARN * lam_c:
            add(
                "warning",
                "sampling",
                r.label,
                f"{spacing * 1e3:.3g} mm between samples is coarse for the tooth mesh"
                f" (recommended <= {SPACING_WARN * lam_c * 1e3:.3g} mm, >= {rate_ok:.0f} Hz)",
            )
        # 3b. one step: samples lost with uniform time stamps (a renumbered trace) leave a jump of
        # x_T the grid would bridge with a straight line (finding A15); the median above misses it
        if spacing <= SPACING_ERROR * lam_c:
            gap = _position_gap(x, t, mv, SPACING_ERROR * lam_c)
            if gap is not None:
                i, dx_gap = gap
                add(
                    "error",
                    "gap",
                    r.label,
                    f"x_T jumps by {dx_gap * 1e3:.4g} mm between samples {i} and {i + 1} (t = {t[i]:.6g} s;"
                    f" median step {spacing * 1e3:.3g} mm): samples lost? The tooth mesh (pitch"
                    f" {tooth_pitch * 1e3:.4g} mm) needs <= {need_mm:.3g} mm between samples — cut the"
                    " pass at the gap or record it again",
                )
                info["gross"] = True
                continue
        # 4. listed direction against the motion the scale recorded
        if r.direction != 0 and r.kind != "sine":
            moved = float(np.median(np.gradient(x, t)[mv]))
            if np.sign(moved) != r.direction:
                head = (
                    f"the table moves in direction {int(np.sign(moved)):+d} (x_T from {x[mv][0] * 1e3:.1f} to"
                    f" {x[mv][-1] * 1e3:.1f} mm), the run is listed as direction {r.direction:+d}"
                )
                tq_mean = info["torque_mean"]
                if np.sign(tq_mean) == r.direction and abs(tq_mean) > TORQUE_ORDER_NOISE:
                    # the motor pushed the way the list says: the rows, not the label, are reversed
                    # (finding TH7: "fix 'direction'", then "set scale = -1 on torque_m" for all files)
                    why = (
                        f", and its mean motor torque {tq_mean:+.3g} N·m drives direction {r.direction:+d} as"
                        " listed: the rows look reversed in time (a trace exported newest first?) or the"
                        " position columns belong to another pass — check this file, not 'direction'"
                    )
                else:
                    why = ": fix 'direction' of this run in [[runs]]"
                add("error", "direction", r.label, head + why)
                info["gross"] = True
                continue
        # 5. listed velocity
        if r.velocity and r.kind != "sine" and abs(v_meas / r.velocity - 1.0) > VELOCITY_WARN:
            add(
                "warning",
                "velocity",
                r.label,
                f"moves at {v_meas * 1e3:.4g} mm/s, listed as {r.velocity * 1e3:.4g} mm/s",
            )
        # 6. torque sign on loaded passes
        if (
            r.kind == "load"
            and r.load > 0
            and r.direction != 0
            and np.sign(info["torque_mean"]) != r.direction
        ):
            add(
                "error",
                "torque",
                r.label,
                f"mean motor torque {info['torque_mean']:+.3g} N·m opposes the motion"
                f" (direction {r.direction:+d}) under load: torque sign —"
                f" {_sign_advice('torque_m', column_scales)}",
            )
    rep.runs = per_run
    _zero_advice(rep, zero_errors, zero_seen, r_eff, travel, column_offsets)
    _minority(rep, per_run)
    _single_turn(starts, r_eff, rep, source)
    _frame(per_run, travel, column_offsets, source, add)
    judged = [(r, i) for r, i in zip(runs, per_run, strict=True) if "ratio" in i and not i.get("gross")]
    if not judged:
        if not rep.errors:
            add("error", "runs", source, "no run with usable motion")
        return rep
    x_lo = min(i["range_m"][0] for _, i in judged)
    x_hi = max(i["range_m"][1] for _, i in judged)
    recorded = x_hi - x_lo
    if travel is not None and recorded > travel + 0.01:
        add(
            "error",
            "travel",
            source,
            f"the runs span {recorded:.4g} m but [geometry] travel is {travel:.4g} m (position unit?)",
        )
    # 6. coverage of each pass
    for r, i in judged:
        if r.kind in ("geometric", "load"):
            frac = (i["range_m"][1] - i["range_m"][0]) / recorded if recorded > 0 else 1.0
            if frac < COVERAGE_WARN:
                add(
                    "warning",
                    "coverage",
                    r.label,
                    f"covers {i['range_m'][1] - i['range_m'][0]:.3f} m of the {recorded:.3f} m recorded"
                    f" ({frac:.0%}): the model is valid only where every direction is covered",
                )
    # 7. per direction: zero consistency, training loads, torque growth
    geo_ranges: dict[int, tuple[float, float]] = {}
    for d in (1, -1):
        key = "pos" if d > 0 else "neg"
        rr = [(r, i) for r, i in judged if r.direction == d and r.kind in ("geometric", "load")]
        geo = [i for r, i in rr if r.kind == "geometric"]
        loads = sorted({r.load for r, _ in rr if r.kind == "load"})
        train = [f for f in loads if f <= max_load + 1e-9]
        ds: dict[str, Any] = {"loads": loads, "training_loads": train}
        rep.directions[key] = ds
        fit_only = "warning" if for_score else "error"  # what only a fit needs
        if for_score and not rr:
            # te score pairs passes by direction, velocity and load: one direction is scored alone
            add("warning", "runs", source, f"no pass in direction {d:+d}: only the other direction is scored")
            continue
        if not geo:
            add(fit_only, "runs", source, f"no geometric (no-load) run in direction {d:+d}")
        else:
            geo_ranges[d] = (max(i["range_m"][0] for i in geo), min(i["range_m"][1] for i in geo))
            _beyond_no_load(rr, geo_ranges[d], d, add)
        if not loads:
            add(fit_only, "runs", source, f"no load run in direction {d:+d}")
        elif len(train) < 2:
            add(
                fit_only,
                "loads",
                source,
                f"only {len(train)} training load(s) ({', '.join(f'{f:g} N' for f in train) or 'none'}"
                f" up to {max_load:g} N) in direction {d:+d}: the load dependence cannot be learnt;"
                " record at least 2 loads (3 or more recommended)",
            )
        elif len(train) == 2:
            add("warning", "loads", source, f"2 training loads in direction {d:+d}; 3 or more recommended")
        if len(rr) >= 2:
            _mixed_zeros(rr, add, r_eff)
        lr = [(r.load, i["torque_mean"] * d) for r, i in rr if r.kind == "load"]
        gross = False
        if len({f for f, _ in lr}) >= 2:
            f_arr, q_arr = np.array(lr).T
            slope = float(np.polyfit(f_arr, q_arr, 1)[0])
            ds["torque_per_N"] = slope
            ds["torque_range"] = [float(q_arr.min()), float(q_arr.max())]
            lo_s, hi_s = TORQUE_SLOPE_RANGE
            if slope <= 0:
                add(
                    "error",
                    "torque",
                    source,
                    f"direction {d:+d}: the motor torque does not grow with the load"
                    f" ({slope * 1e3:+.3g} N·m/kN): wrong torque column or load labels",
                )
            elif not 1 / TORQUE_SLOPE_GROSS <= slope / r_eff <= TORQUE_SLOPE_GROSS:
                gross = True  # the pairs' lever band means nothing at a unit's factor off
                add("error", "torque", source, _unit_slip_message(slope, r_eff, d, lr))
            elif not lo_s <= slope / r_eff <= hi_s:
                add(
                    "warning",
                    "torque",
                    source,
                    f"direction {d:+d}: the torque grows {slope * 1e3:.3g} N·m per kN of load, the lever"
                    f" d_p/(2 i_PG) gives {r_eff * 1e3:.3g}: torque constant or unit of torque_m?",
                )
        if not gross:
            ds["torque_order_tolerance_Nm"] = _torque_order(rr, r_eff, d, add)
    _constant_part(judged, r_eff, rep, source, add)
    _mesh_period(judged, r_eff, tooth_pitch, source, add)
    if 1 in geo_ranges and -1 in geo_ranges:
        lo = max(geo_ranges[1][0], geo_ranges[-1][0])
        hi = min(geo_ranges[1][1], geo_ranges[-1][1])
        if hi > lo:
            # passes to score train nothing: where loads were recorded does not bound a model
            rep.valid_range = (
                (lo, hi)
                if for_score
                else _measured_under_load(
                    judged, (lo, hi), max_load, tooth_pitch, n_t, trim, rep.directions, add, source
                )
            )
        else:
            add("error", "coverage", source, "the geometric runs of the two directions do not overlap")
    return rep


def _minority(rep: PlausibilityReport, per_run: Sequence[dict[str, Any]]) -> None:
    """A unit or sign finding on fewer than half of the runs it was judged on: the [columns] mapping
    fits the others, so the advice to change it (shared by every file) gets the note that it
    would change them too (findings TH6, TH7: one file in µm told "set unit = 'um'", one pass
    reversed in time told "set scale = -1 on the torque_m column" — advice that breaks the other
    19 files if followed)."""
    judged = {"ratio": sum("ratio" in i for i in per_run)}
    judged["torque"] = sum(
        "ratio" in i and i["kind"] == "load" and i["load"] > 0 and i["direction"] != 0 for i in per_run
    )
    for check, n_all in judged.items():
        bad = [
            k
            for k, f in enumerate(rep.findings)
            if f.level == "error" and f.check == check and f.file in {i["file"] for i in per_run}
        ]
        # an encoder or scale counting the other way (k ≈ −1) keeps its one line (the README's
        # example): a drive's sign parameter is set once for every recording
        k_of = {i["file"]: i.get("ratio", math.nan) for i in per_run}
        ratio_run = [k for k in bad if check == "ratio"]
        if ratio_run:
            n_bad = len(ratio_run)
            bad = [k for k in bad if k_of.get(rep.findings[k].file, math.nan) > 0]
            if len(bad) < n_bad:  # sign errors among them: no note
                bad = []
        if not bad or 2 * len(bad) >= n_all:
            continue
        for k in bad:
            f = rep.findings[k]
            rep.findings[k] = Finding(
                f.level,
                f.check,
                f.file,
                f"{f.message} — but only {len(bad)} of {n_all} runs disagree: if the others are right,"
                " this file was recorded or exported differently (reversed in time, another unit or"
                " channel): re-export it like them, since [columns] applies to every file",
            )


def _constant_part(
    judged: Sequence[tuple[RunRecord, Any]], r_eff: float, rep: PlausibilityReport, source: str, add: Any
) -> None:
    """The constant part of the TE (:data:`CONSTANT_TE_WARN`), stored in ``rep.constant_te``.

    From both directions the backlash ±b/2 cancels and the warning advises the theta_m offset;
    from one direction alone (passes recorded to be scored) it holds that direction's b/2, so the
    warning says what it rests on and gives no offset (session 36, TH13 b: the offset advised
    from one pass as if the campaign had established it)."""
    level = _te_level([(r, i["te_median_m"]) for r, i in judged])
    if level is None:
        return
    c, dirs = level
    rep.constant_te = c
    if abs(c) <= CONSTANT_TE_WARN:
        return
    if len(dirs) == 2:
        add(
            "warning",
            "zero",
            source,
            f"the TE's constant part is {c * 1e6:+.1f} um (mean of both directions' no-load TE): it goes"
            " into the absolute CNC tables as a constant — if the motor encoder's zero is arbitrary (raw"
            f" counts), add {c / r_eff:+.6f} rad to the offset of the theta_m column in [columns] or home"
            " both",
        )
        return
    d = dirs[0]
    used = [r.label for r, _ in judged if r.direction == d and r.kind in ("geometric", "load")]
    runs = f"1 run, {Path(used[0]).name}" if len(used) == 1 else f"{len(used)} runs"
    add(
        "warning",
        "zero",
        source,
        f"the TE's constant part is {c * 1e6:+.1f} um from direction {d:+d} alone ({runs}): it holds"
        " half the backlash, which only the other direction cancels — record a pass in direction"
        f" {-d:+d} before offsetting the theta_m column (the CNC tables take the constant part as it is)",
    )


def _measured_under_load(
    judged: Sequence[tuple[RunRecord, Any]],
    span: tuple[float, float],
    max_load: float,
    tooth_pitch: float,
    n_t: int | None,
    trim: float,
    directions: dict[str, dict[str, Any]],
    add: Any,
    source: str,
) -> tuple[float, float] | None:
    """The valid range: ``span`` (the no-load runs' overlap) where the load behaviour was measured.

    Per direction, the longest stretch of ``span`` that at least two training loads (≤
    ``max_load``) cover, within :data:`GEO_SPAN_TOL` — the load dependence needs two loads.
    If it leaves ``te fit`` (which trims ``trim`` off each end of a load run) less than one
    pinion revolution n_t·p, some pinion teeth never mesh in the training rows: stage 1's
    weights for their features are untrained, and its prediction where they mesh is not
    known (finding A9's residue: 140 mm of rows on a 266.7 mm pinion, 0.047 µm MAE on them,
    0.70–1.15 µm over the rest of the travel, 0.7–1.2 times the load term itself; 340 mm of
    rows: 0.08 µm over the rest). The range then narrows to the rows. A narrowed range is a
    warning naming it; nothing left is an error. With fewer than two training loads (step 7
    reports it) a direction does not narrow the range.
    """
    g_lo, g_hi = span
    lo, hi = span
    for d in (1, -1):
        ends: dict[float, list[float]] = {}
        for r, i in judged:
            if r.kind == "load" and r.direction == d and r.load <= max_load + 1e-9:
                a, b = i["range_m"]
                e = ends.setdefault(r.load, [a, b])
                e[0], e[1] = min(e[0], a), max(e[1], b)
        if len(ends) < 2:
            continue
        stretches = _covered_twice(ends.values(), g_lo, g_hi)
        if not stretches:
            add(
                "error",
                "coverage",
                source,
                f"direction {d:+d}: no position where two training loads were recorded",
            )
            return None
        c_lo, c_hi = max(stretches, key=lambda s: s[1] - s[0])
        directions[direction_key(d)]["load_range"] = [c_lo, c_hi]
        note = ""
        if (c_lo, c_hi) != (g_lo, g_hi):
            note = (
                f"direction {d:+d}: two or more training loads were recorded over {c_lo * 1e3:.1f} …"
                f" {c_hi * 1e3:.1f} mm only, of the {g_lo * 1e3:.1f} … {g_hi * 1e3:.1f} mm the no-load runs"
                " cover: the load behaviour elsewhere is not measured, so the model's valid range ends"
                " there (record the load passes over the whole travel)"
            )
        circ = n_t * tooth_pitch if n_t else 0.0
        if n_t and c_hi - c_lo - 2 * trim < circ:
            r_lo, r_hi = c_lo + trim, c_hi - trim
            if not r_hi > r_lo:
                add(
                    "error",
                    "coverage",
                    source,
                    f"direction {d:+d}: two or more training loads were recorded over {c_lo * 1e3:.1f} …"
                    f" {c_hi * 1e3:.1f} mm only, nothing is left to train on once te fit trims"
                    f" {trim * 1e3:g} mm off each end",
                )
                return None
            unseen = max(1, n_t - math.ceil((r_hi - r_lo) / tooth_pitch))  # tooth pitches not passed
            note = (
                f"direction {d:+d}: the load passes leave {(r_hi - r_lo) * 1e3:.1f} mm to train on"
                f" ({trim * 1e3:g} mm trimmed off each end of {c_lo * 1e3:.1f} … {c_hi * 1e3:.1f} mm), less"
                f" than one pinion revolution ({circ * 1e3:.1f} mm): about {unseen} of the {n_t} pinion"
                " teeth never mesh in them and the model does not know them, so its valid range is"
                f" narrowed to the trained {r_lo * 1e3:.1f} … {r_hi * 1e3:.1f} mm (record load passes over at"
                f" least {(circ + 2 * trim) * 1e3:.0f} mm)"
            )
            c_lo, c_hi = r_lo, r_hi
        if note:
            add("warning", "coverage", source, note)
        lo, hi = max(lo, c_lo), min(hi, c_hi)
        if not hi > lo:
            add(
                "error",
                "coverage",
                source,
                "the load passes of the two directions leave no common position to train on",
            )
            return None
    return lo, hi


def _covered_twice(ends: Iterable[Sequence[float]], lo: float, hi: float) -> list[tuple[float, float]]:
    """Stretches of [lo, hi] [m] inside at least two of the intervals ``ends``; an interval end
    within :data:`GEO_SPAN_TOL` of ``lo``/``hi`` counts as reaching it."""
    events = sorted([(a, 1) for a, _ in ends] + [(b, -1) for _, b in ends], key=lambda e: (e[0], -e[1]))
    out, n, start = [], 0, 0.0
    for x, step in events:
        n += step
        if step > 0 and n == 2:
            start = x
        elif step < 0 and n == 1:
            out.append((start, x))
    snapped = [(lo if a <= lo + GEO_SPAN_TOL else a, hi if b >= hi - GEO_SPAN_TOL else b) for a, b in out]
    return [(max(a, lo), min(b, hi)) for a, b in snapped if min(b, hi) > max(a, lo)]


def _beyond_no_load(rr: Sequence[tuple[RunRecord, Any]], span: tuple[float, float], d: int, add: Any) -> None:
    """Warn for each load pass reaching more than :data:`GEO_SPAN_TOL` beyond the no-load runs of its
    direction, naming the uncovered positions (finding A9: such parts were trained on with TE_geo
    held flat, and spoilt the model inside its valid range)."""
    glo, ghi = span
    for r, i in rr:
        if r.kind != "load":
            continue
        a, b = i["range_m"]
        parts = [(a, glo)] if a < glo - GEO_SPAN_TOL else []
        parts += [(ghi, b)] if b > ghi + GEO_SPAN_TOL else []
        if parts:
            where = " and ".join(f"{u * 1e3:.1f} ... {v * 1e3:.1f} mm" for u, v in parts)
            add(
                "warning",
                "coverage",
                r.label,
                f"travels {a * 1e3:.1f} ... {b * 1e3:.1f} mm, the no-load run(s) of direction {d:+d} only"
                f" {glo * 1e3:.1f} ... {ghi * 1e3:.1f} mm: TE_geo is not known at {where}, so te fit"
                " leaves that part out (record the no-load runs over the whole travel)",
            )


def _run_name(r: RunRecord) -> str:
    what = f"{r.kind}, direction {r.direction:+d}"
    return f"{what}, {r.load:g} N" if r.kind != "sine" else what


def _duplicates(runs: Sequence[RunRecord], add: Any) -> None:
    """The same file (or byte-identical samples) listed for two runs is an error naming both."""
    import hashlib

    seen: dict[Any, tuple[int, RunRecord]] = {}
    for n, r in enumerate(runs):
        h = hashlib.sha256()
        for a in (r.t, r.x_T, r.theta_m, r.torque_m):
            h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
        for key in (("path", r.label), ("data", h.hexdigest())):
            if key in seen:
                m, q = seen[key]
                same = "listed" if key[0] == "path" else f"holds the same samples as {q.label}, listed"
                add(
                    "error",
                    "duplicate",
                    r.label,
                    f"{same} for two runs: run {m + 1} ({_run_name(q)}) and run {n + 1} ({_run_name(r)});"
                    " one recording is one pass — fix the file names in [[runs]]",
                )
                break
            seen[key] = (n, r)


def _velocity_groups(rr: list[tuple[RunRecord, dict[str, Any]]]) -> list[list[tuple[RunRecord, dict]]]:
    """Load runs grouped by measured velocity (within :data:`VELOCITY_GROUP` of the group's slowest)."""
    load = sorted((p for p in rr if p[0].kind == "load"), key=lambda p: p[1]["velocity_measured"])
    groups: list[list[tuple[RunRecord, dict]]] = []
    for p in load:
        if groups and p[1]["velocity_measured"] <= VELOCITY_GROUP * groups[-1][0][1]["velocity_measured"]:
            groups[-1].append(p)
        else:
            groups.append([p])
    return groups


def _torque_order(rr: Iterable[tuple[RunRecord, dict[str, Any]]], r_eff: float, d: int, add: Any) -> float:
    """Mean motor torques that contradict the stated loads: one rule for swapped labels, a loaded
    'geometric' run and a single mislabelled load (findings TH1, TH2).

    Pairs of runs of direction ``d`` at comparable velocity (geometric runs count as 0 N at every
    velocity; a pair at equal load only when their own velocities are comparable too): the
    higher-load run's torque d·T must exceed the lower-load run's by at least
    TORQUE_ORDER_LEVER·r_eff·ΔF − TORQUE_ORDER_NOISE, and two runs at equal load must agree within
    TORQUE_ORDER_NOISE. The worst pair first, each run named in at most one finding: a reversed
    order (swapped labels) names the higher-load run, any other pair the run in more such pairs,
    then the one farther from the direction's torque line. Returns the noise term [N·m].
    """
    rr = list(rr)
    if len(rr) < 2:
        return TORQUE_ORDER_NOISE
    geo = [p for p in rr if p[0].kind == "geometric"]
    bad: dict[tuple[str, str], tuple[float, Any, Any]] = {}
    for group in _velocity_groups(rr) or [[]]:
        runs = group + geo
        for i, (ra, ia) in enumerate(runs):
            for rb, ib in runs[i + 1 :]:
                (lo, il), (hi, ih) = sorted(((ra, ia), (rb, ib)), key=lambda p: p[0].load)
                dF = hi.load - lo.load
                diff = d * ih["torque_mean"] - d * il["torque_mean"]
                if dF > 0:
                    miss = TORQUE_ORDER_LEVER * r_eff * dF - TORQUE_ORDER_NOISE - diff
                else:
                    va, vb = ia["velocity_measured"], ib["velocity_measured"]
                    if max(va, vb) > VELOCITY_GROUP * min(va, vb):
                        continue  # friction grows with speed: equal loads compare at one speed only
                    miss = abs(diff) - TORQUE_ORDER_NOISE
                if miss > 0:
                    key = (lo.label, hi.label)
                    if key not in bad or bad[key][0] < miss:
                        bad[key] = (miss, (lo, il), (hi, ih))
    count: dict[str, int] = {}
    for lo_label, hi_label in bad:
        count[lo_label] = count.get(lo_label, 0) + 1
        count[hi_label] = count.get(hi_label, 0) + 1
    # the run to name (unless the order is reversed): in more bad pairs; then the one farther from
    # the direction's torque line (Theil–Sen over the stated loads, robust to the odd run)
    F = np.array([r.load for r, _ in rr])
    q = np.array([d * i["torque_mean"] for _, i in rr])
    if np.ptp(F) > 0:
        from scipy.stats import theilslopes

        slope = float(theilslopes(q, F)[0])
        off = np.abs(q - slope * F - np.median(q - slope * F))  # scipy's own intercept is not robust
    else:
        off = np.abs(q - np.median(q))
    score = {r.label: (count.get(r.label, 0), float(e), r.load) for (r, _), e in zip(rr, off, strict=True)}
    named: set[str] = set()
    for _, (lo, il), (hi, ih) in sorted(bad.values(), key=lambda b: -b[0]):
        if lo.label in named or hi.label in named:
            continue
        named.update((lo.label, hi.label))
        if hi.load > lo.load and d * ih["torque_mean"] < d * il["torque_mean"] - TORQUE_ORDER_NOISE:
            (r, i), o = (hi, ih), (lo, il)  # reversed: swapped labels, the higher stated load named
        else:
            (r, i), o = max(((lo, il), (hi, ih)), ((hi, ih), (lo, il)), key=lambda p: score[p[0][0].label])
        zero = [d * j["torque_mean"] for p, j in rr if p.load == 0 and p.label != r.label]
        q0 = float(np.median(zero)) if zero else None
        add("error", "torque-load", r.label, _torque_load_message((r, i), o, r_eff, d, q0))
    return TORQUE_ORDER_NOISE


def _unit_slip_message(slope: float, r_eff: float, d: int, lr: Sequence[tuple[float, float]]) -> str:
    """The one line for a torque growth a unit's factor off the lever (:data:`TORQUE_SLOPE_GROSS`)."""
    k = slope / r_eff
    head = (
        f"direction {d:+d}: the motor torque grows {slope * 1e3:.4g} N·m per kN of the stated loads"
        f" ({', '.join(f'{f:g}' for f in sorted({f for f, _ in lr}))} N), {k:.4g}× the lever d_p/(2 i_PG)"
        f" ({r_eff * 1e3:.3g} N·m/kN)"
    )
    if abs(math.log10(k / 1e3)) < math.log10(2):
        why = (
            "the loads look like kN given as N (state load in N in [[runs]]; max load and the training"
            " loads are counted in N), or torque_m is 1000× too large (a current in mA declared as unit ="
            ' "A", or its torque_constant)'
        )
    elif abs(math.log10(k * 1e3)) < math.log10(2):
        why = (
            "the loads look like N given as kN ×1000 or torque_m is 1000× too small (a current in A"
            ' declared as unit = "mA", or its torque_constant)'
        )
    else:
        why = "no gear efficiency explains it: the unit of the loads in [[runs]] (N) or of torque_m"
    return f"{head}: {why}"


def _torque_load_message(
    run: tuple[RunRecord, Any], other: tuple[RunRecord, Any], r_eff: float, d: int, q0: float | None
) -> str:
    """The one line of :func:`_torque_order` for ``run`` (the one named), against ``other``; ``q0``
    is the median d·T [N·m] of the direction's other 0 N runs (None: there is none)."""
    (r, i), (o, j) = run, other
    tr, to = i["torque_mean"], j["torque_mean"]
    if r.load > o.load and d * tr < d * to - TORQUE_ORDER_NOISE:  # the order itself is reversed
        return (
            f"mean motor torque {tr:+.3g} N·m at the stated {r.load:g} N ({r.kind}) is below the"
            f" {to:+.3g} N·m of {o.label} at {o.load:g} N ({o.kind}), direction {d:+d}: the torque"
            " contradicts the load labels (swapped loads or files in [[runs]]?)"
        )
    if r.kind == "geometric":
        what = "a loaded pass listed as the geometric (no-load) run? (file of the geometric run in [[runs]])"
    else:
        what = "the load label contradicts the torque (wrong load or file in [[runs]]?)"
    at = ""
    if q0 is not None:  # the load the lever gives for this torque above the no-load runs' friction
        at = f" the lever d_p/(2 i_PG) puts it at about {(d * tr - q0) / r_eff:.0f} N (η = 1) —"
    return (
        f"mean motor torque {tr:+.3g} N·m at the stated {r.load:g} N ({r.kind}), {to:+.3g} N·m at"
        f" {o.load:g} N ({o.kind}) in {o.label}, direction {d:+d}:{at} {what}"
    )


def _profile(r: RunRecord, r_eff: float) -> tuple[np.ndarray, np.ndarray]:
    """Mean TE [m] of the moving part of ``r`` per :data:`MIXED_BIN` of x_T, as (bin index, mean)."""
    x, t = np.asarray(r.x_T, dtype=np.float64), np.asarray(r.t, dtype=np.float64)
    mv = _moving(x, t)
    te = x[mv] - np.asarray(r.theta_m, dtype=np.float64)[mv] * r_eff
    b = np.floor(x[mv] / MIXED_BIN).astype(np.int64)
    idx, inv = np.unique(b, return_inverse=True)
    return idx, np.bincount(inv, weights=te) / np.bincount(inv)


def _levels(rr: Sequence[tuple[RunRecord, dict[str, Any]]], r_eff: float) -> np.ndarray:
    """Each run's TE level [m] on the positions of the direction's longest run (the reference).

    The reference's level is its median TE; another run's is the reference's plus the median,
    over the positions both cover (:data:`MIXED_BIN` bins, at least :data:`MIXED_MIN_COMMON`), of
    its TE minus the reference's. A run's own median over a part of the travel holds the TE's
    variation along it (drift, runout) — finding TH4: a pass stopped after 100 of 400 mm showed
    "+24.4 um from the 2 other runs" of a 100 µm drift and was refused as mixed zeros. Without
    enough common positions a run keeps its own median.
    """
    spans = [i["range_m"][1] - i["range_m"][0] for _, i in rr]
    ref = int(np.argmax(spans))
    pr = _profile(rr[ref][0], r_eff)
    out = []
    for n, (r, i) in enumerate(rr):
        if n == ref:
            out.append(float(i["te_median_m"]))
            continue
        idx, mean = _profile(r, r_eff)
        _, a, b = np.intersect1d(idx, pr[0], assume_unique=True, return_indices=True)
        if a.size < MIXED_MIN_COMMON:
            out.append(float(i["te_median_m"]))
        else:
            out.append(float(rr[ref][1]["te_median_m"]) + float(np.median(mean[a] - pr[1][b])))
    return np.array(out)


def _mixed_zeros(rr: Iterable[tuple[RunRecord, dict[str, Any]]], add: Any, r_eff: float) -> None:
    """Offsets of single runs against the others of a direction (load trend removed, Theil–Sen),
    compared over common positions (:func:`_levels`)."""
    from scipy.stats import theilslopes

    rr = list(rr)
    F = np.array([r.load for r, _ in rr])
    m = _levels(rr, r_eff)
    if np.ptp(F) > 0 and len(rr) >= 3:
        slope, icpt, _, _ = theilslopes(m, F)
        res = m - (icpt + slope * F)
    else:
        res = m - np.median(m)
    for n, ((r, _), e) in enumerate(zip(rr, res, strict=True)):
        same = [m[k] for k in range(len(rr)) if k != n and abs(F[k] - r.load) <= 1e-6]
        if len(same) >= 2:  # repeats at this load: compare with them, not with the load trend
            off = float(m[n] - np.median(same))
            spread = MIXED_SAME_SCATTER * float(np.ptp(same))  # others that disagree: no verdict on this one
            limit = max(MIXED_SAME_ERROR, spread)
            if abs(off) > limit:
                add(
                    "error",
                    "mixed-zero",
                    r.label,
                    f"TE offset {off * 1e6:+.1f} um from the {len(same)} other runs of direction"
                    f" {r.direction:+d} at {r.load:g} N (they agree within {np.ptp(same) * 1e6:.2f} um;"
                    f" limit {limit * 1e6:.0f} um): mixed position zeros between runs (homed in between?)",
                )
            elif abs(off) > max(MIXED_SAME_WARN, spread):
                add(
                    "warning",
                    "mixed-zero",
                    r.label,
                    f"TE offset {off * 1e6:+.1f} um from the {len(same)} other runs of direction"
                    f" {r.direction:+d} at {r.load:g} N",
                )
            continue
        if abs(e) > MIXED_ERROR:
            add(
                "error",
                "mixed-zero",
                r.label,
                f"TE offset {e * 1e3:+.3f} mm from the other runs of direction {r.direction:+d}:"
                " mixed position zeros between runs (homed in between?)",
            )
        elif abs(e) > MIXED_WARN:
            add(
                "warning",
                "mixed-zero",
                r.label,
                f"TE offset {e * 1e3:+.3f} mm from the other runs of direction {r.direction:+d}",
            )


def record_of(
    label: str, kind: str, direction: int, load: float, velocity: float | None, trace: Any
) -> RunRecord:
    """A :class:`RunRecord` from a :class:`~drivelash.io.trace.Trace` (columns t, x_T, theta_m, torque_m)."""
    return RunRecord(label, kind, int(direction), float(load), velocity, trace["t"], trace["x_T"],
                     trace["theta_m"], trace["torque_m"])  # fmt: skip


def check_campaign(campaign: Any, max_load: float = math.inf) -> PlausibilityReport:
    """:func:`check_runs` on every run of a loaded campaign (:func:`~drivelash.te.protocol.load_campaign`)."""
    bench = campaign.bench
    recs = [record_of(str(r.path), r.kind, r.direction, r.load, r.velocity, r.trace()) for r in campaign.runs]
    return check_runs(
        recs, bench.r_eff, bench.tooth_pitch, bench.travel, max_load, source=str(campaign.manifest_path),
        n_t=bench.n_t, geometry=bench,
    )  # fmt: skip
