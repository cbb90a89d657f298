"""The reversal value of an ISO 230-2 test beside the deadzone estimated from recordings.

The deadzone δ of drivelash is an angle on the load-shaft scale of the drive model
(Δθ = θ_m/N − θ_l, spec 01 §1). At the tool it is a lost motion

    L_δ = k · δ,   k = lead / (2π i_G)   (ball screw, lead per screw revolution)
                   k = r_p / i_G         (rack and pinion, pinion pitch radius r_p)
                   k = 1 / i_G           (rotary axis measured as an angle)
                   k = 1                 (a prismatic estimate: δ already in m at the table)

with i_G the revolutions of the θ_l shaft per screw/pinion revolution (1 when θ_l is the
screw or pinion itself). An estimate made on a prismatic recording (positions in m: a linear
motor, or a ball-screw axis whose drive exports table travel; its JSON says ``"axis":
"prismatic"``) is a length at the table already and is compared as it is; a ``[transmission]``
is then not applied, and a note says so. A pure lost motion L gives x↑ = −L/2, x↓ = +L/2 at every target,
so B_i = −L: the ISO test measures L as −B̄ (mean over targets, unbiased) and as
B = max|B_i| (the standard's axis value, biased upward by the selection of the maximum).
When the control compensates reversal during the test (a backlash compensation value
c), the mechanical lost motion is −B̄ + c.

Agreement is judged with the normalised error of ISO 13528 / ISO/IEC 17043,
E_n = |L_ISO − L_δ| / sqrt(U_ISO² + U_δ²), with expanded uncertainties U = 2u
(≈ 95 %); |E_n| ≤ 1 is agreement. Both u are the statistical parts only.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drivelash.errors import ConfigError, DataError, ParameterError
from drivelash.iso230.evaluate import Iso230Result

__all__ = [
    "Comparison",
    "Deadzone",
    "Transmission",
    "check_compensation",
    "compare",
    "lost_motion",
    "read_deadzone",
]

#: Coverage factor of the expanded uncertainties in E_n.
K_COVERAGE = 2.0

#: Largest plausible ball-screw lead [m] (docs/assumptions.md, "ISO 230-2"): the high-helix
#: screws of the catalogues reach leads of 1–2 shaft diameters, at most a few tens of mm;
#: a lead written in mm (10 for 10 mm per revolution) reads as 10 m.
MAX_LEAD = 0.1

#: Largest plausible pinion pitch radius [m] (docs/assumptions.md): machine-tool racks are
#: module 2–10 with 17–40 teeth, pitch radius ≤ 0.2 m; a radius in mm (42.4) reads as 42.4 m.
MAX_PINION_RADIUS = 1.0

#: Largest plausible reversal compensation of the control (|``[iso230] compensation``|) on a
#: linear axis [m] (docs/assumptions.md): 2× the largest a Heidenhain TNC 426/430 accepts
#: (MP710, ±1 mm), where typical values are 0.01–0.05 mm; a value in µm or mm reads 1e3–1e6×
#: too large.
MAX_COMPENSATION_M = 2e-3

#: The same on a rotary axis [rad]: 1°, the TNC 426/430's limit for a rotary axis
#: (typical rotary tables: 5–60″); a value in arcsec reads ≥ 1 rad.
MAX_COMPENSATION_RAD = math.pi / 180.0


@dataclass(frozen=True)
class Transmission:
    """``[transmission]``: from the deadzone's shaft to the load.

    Parameters
    ----------
    lead : float, optional
        Ball-screw lead, travel per screw revolution [m]; at most :data:`MAX_LEAD`.
    pinion_radius : float, optional
        Pitch radius of the pinion of a rack-and-pinion drive [m]; at most
        :data:`MAX_PINION_RADIUS`.
    i_G : float
        Revolutions of the deadzone's shaft (θ_l of the drive model) per revolution
        of the screw or pinion [-].

    Raises
    ------
    ParameterError
        A field outside its valid range, or a lead or radius too large for a machine-tool
        axis (a value in mm taken as m) — one line naming the class and the field.
    """

    lead: float | None = None
    pinion_radius: float | None = None
    i_G: float = 1.0

    def __post_init__(self) -> None:
        for name in ("lead", "pinion_radius", "i_G"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v > 0):
                raise ParameterError("Transmission", name, f"must be a finite number > 0, got {v!r}")
        for name, bound, what in (
            ("lead", MAX_LEAD, "ball-screw lead"),
            ("pinion_radius", MAX_PINION_RADIUS, "pinion pitch radius"),
        ):
            v = getattr(self, name)
            if v is not None and v > bound:
                raise ParameterError(
                    "Transmission",
                    name,
                    f"{v:g} m is not a plausible {what} (at most {bound:g} m); the value is in m —"
                    f" if {v:g} is in mm, write {v * 1e-3:g}",
                )
        if self.lead is not None and self.pinion_radius is not None:
            raise ParameterError(
                "Transmission", "pinion_radius", "give either lead or pinion_radius, not both"
            )

    def factor(self, unit: str) -> float:
        """Lost motion at the load per rad of deadzone: [m/rad] (linear) or [rad/rad] (rotary).

        Parameters
        ----------
        unit : {"m", "rad"}
            Unit of the ISO test's positions: a linear or a rotary axis.

        Raises
        ------
        ParameterError
            A linear axis without ``lead`` or ``pinion_radius``, or a rotary one with one.
        """
        if unit == "rad":
            if self.lead is not None or self.pinion_radius is not None:
                raise ParameterError("Transmission", "lead", "a rotary axis (angle units) takes only i_G")
            return 1.0 / self.i_G
        if self.lead is not None:
            return self.lead / (2.0 * math.pi * self.i_G)
        if self.pinion_radius is not None:
            return self.pinion_radius / self.i_G
        raise ParameterError(
            "Transmission", "lead", "a linear axis needs lead (ball screw) or pinion_radius (rack and pinion)"
        )


@dataclass(frozen=True)
class Deadzone:
    """An estimated deadzone.

    Parameters
    ----------
    delta : float
        Deadzone δ [rad; m when ``axis`` is "prismatic"].
    u_delta : float or None
        Its standard uncertainty [rad or m]; None when the estimator gave none.
    source : str
        Where it came from (file, or history store and axis).
    time : str, optional
        When the recording was made (ISO 8601), if known.
    note : str, optional
        What the comparison must say about the estimate (e.g. that it did not converge).
    axis : {"rotary", "prismatic"} or None
        The estimate's axis kind (the estimate JSON's ``axis``); None: not stated (a JSON written
        before the key existed, or the history store), read as rotary.
    """

    delta: float
    u_delta: float | None
    source: str
    time: str | None = None
    note: str | None = None
    axis: str | None = None

    @property
    def prismatic(self) -> bool:
        """δ is a length [m] at the table, not an angle."""
        return self.axis == "prismatic"


def read_deadzone(path: str | Path) -> Deadzone:
    """The deadzone of a ``drivelash estimate --json`` file.

    Reads ``delta`` and, when the estimator reports one, its standard uncertainty
    (``delta_std``), in rad — in m when the file's ``axis`` is "prismatic" (a file without
    ``axis``, written before it existed, is a rotary one).

    Parameters
    ----------
    path : str or Path
        The JSON file ``drivelash estimate --json`` wrote.

    Returns
    -------
    Deadzone
        δ and u(δ) [rad or m] (None when the file has none), ``source`` the file, ``axis`` the
        file's (None when it states none).

    Raises
    ------
    DataError
        Missing or unreadable file, not JSON, no finite ``delta`` ≥ 0, a ``delta_std`` that is
        not a finite number ≥ 0, an ``axis`` other than "rotary" or "prismatic", an estimate
        made without sufficient excitation, or one that
        did not converge and states no uncertainty — one line.
    """
    p = Path(path)
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise DataError("no such file", path=str(p)) from None
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise DataError(f"not a drivelash estimate JSON ({type(exc).__name__})", path=str(p)) from None
    if not isinstance(data, dict):
        raise DataError("not a drivelash estimate JSON (top level is not an object)", path=str(p))
    axis = data.get("axis")
    if axis is not None and axis not in ("rotary", "prismatic"):
        raise DataError(f"key 'axis' must be 'rotary' or 'prismatic', got {axis!r}", path=str(p))
    si = "m" if axis == "prismatic" else "rad"
    delta = data.get("delta")
    if isinstance(delta, bool) or not isinstance(delta, int | float) or not math.isfinite(delta) or delta < 0:
        raise DataError(f"key 'delta' must be a finite number >= 0 [{si}], got {delta!r}", path=str(p))
    u = data.get("delta_std")
    if u is not None and (
        isinstance(u, bool) or not isinstance(u, int | float) or not math.isfinite(u) or u < 0
    ):
        raise DataError(f"key 'delta_std' must be a finite number >= 0 [{si}], got {u!r}", path=str(p))
    if data.get("excitation_ok") is False:
        raise DataError(
            f"the estimate was made without sufficient excitation ({data.get('reason', 'no reason given')});"
            " it cannot be compared",
            path=str(p),
        )
    note = None
    if data.get("converged") is False:
        said = [w for w in data.get("warnings") or [] if isinstance(w, str) and not w.startswith("note:")]
        if u is None:
            raise DataError(
                "the estimate did not converge and states no uncertainty"
                + (f" ({said[0]})" if said else "")
                + "; it cannot be compared",
                path=str(p),
            )
        note = unconverged_note(float(u), said[0] if said else None, axis)
    return Deadzone(
        float(delta), None if u is None else float(u), str(p), data.get("recording_time"), note, axis
    )


def unconverged_note(u: float, said: str | None, axis: str | None = None) -> str:
    """The comparison's warning for an estimate the estimator did not call converged, compared
    with its stated standard uncertainty ``u`` [rad, or m on a "prismatic" ``axis``]; ``said``
    its first warning, if any."""
    from drivelash.units import gap_unit

    gu = gap_unit(axis)
    return (
        f"the deadzone estimate did not converge: compared with its stated uncertainty "
        f"(u = {gu.n(u, '.3g')} {gu.symbol})" + (f"; the estimator said: {said}" if said else "")
    )


@dataclass(frozen=True)
class Comparison:
    """B beside the deadzone, in the unit of the ISO test (m or rad at the load).

    Attributes
    ----------
    unit : str
    factor : float
        Lost motion per unit of deadzone [m/rad or rad/rad; 1 m/m for a prismatic estimate].
    compensation : float
        Reversal compensation active in the control during the test [m or rad].
    drift_correction : float
        Change of the lost motion when the drift is removed [m or rad] (0 without a drift
        estimate).
    L_iso, u_L_iso : float
        Lost motion from the ISO test, −B̄ + compensation (+ the drift's share of B̄ when a
        drift was estimated), and its standard uncertainty.
    B, u_B : float
        The axis reversal value B = max|B_i| as measured (with the control's compensation,
        if any, acting) and u(B_k).
    B_interval : tuple of float
        Simultaneous interval of B.
    L_delta, u_L_delta : float or None
        The deadzone at the load, k·δ, and k·u(δ) (None when unknown).
    E_n : float
        Normalised error |L_iso − L_delta| / sqrt(U_iso² + U_δ²), U = 2u.
    agree : bool
        |E_n| ≤ 1.
    deadzone : Deadzone
    notes : tuple of str
        What the comparison did beside the arithmetic (a transmission not applied to a
        prismatic estimate).
    """

    unit: str
    factor: float
    compensation: float
    drift_correction: float
    L_iso: float
    u_L_iso: float
    B: float
    u_B: float
    B_interval: tuple[float, float]
    L_delta: float
    u_L_delta: float | None
    E_n: float
    agree: bool
    deadzone: Deadzone
    notes: tuple[str, ...] = ()

    @property
    def iso_label(self) -> str:
        """What ``L_iso`` is: "−B̄", "−B̄ + compensation", "… (drift removed)"."""
        return (
            "−B̄"
            + (" + compensation" if self.compensation else "")
            + (" (drift removed)" if self.drift_correction else "")
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (SI units)."""
        return {
            "unit": self.unit,
            "factor": self.factor,
            "compensation": self.compensation,
            "drift_correction": self.drift_correction,
            "lost_motion_iso": self.L_iso,
            "u_lost_motion_iso": self.u_L_iso,
            "B": self.B,
            "u_B": self.u_B,
            "B_interval": list(self.B_interval),
            "deadzone_rad": self.deadzone.delta,  # the name kept: m when deadzone_unit says so
            "u_deadzone_rad": self.deadzone.u_delta,
            "deadzone_axis": self.deadzone.axis,
            "deadzone_unit": "m" if self.deadzone.prismatic else "rad",
            "deadzone_at_load": self.L_delta,
            "u_deadzone_at_load": self.u_L_delta,
            "deadzone_source": self.deadzone.source,
            "E_n": self.E_n,
            "agree": self.agree,
        }


def check_compensation(compensation: float, unit: str) -> None:
    """Refuse a reversal compensation no control of a machine-tool axis applies (a unit slip).

    Parameters
    ----------
    compensation : float
        ``[iso230] compensation`` [m or rad].
    unit : {"m", "rad"}
        Unit of the ISO test's positions: a linear or a rotary axis.

    Raises
    ------
    ParameterError
        ``|compensation|`` above :data:`MAX_COMPENSATION_M` (linear) or
        :data:`MAX_COMPENSATION_RAD` (rotary); the message names the unit the number was
        likely written in and the value in SI units.
    """
    c = float(compensation)
    if unit == "rad":
        bound, si, bound_txt = MAX_COMPENSATION_RAD, "rad", "1° (0.01745 rad)"
        units = (("°", math.pi / 180.0), ("arcsec", math.pi / 648000.0))
        axis = "rotary"
    else:
        bound, si, bound_txt = MAX_COMPENSATION_M, "m", f"{MAX_COMPENSATION_M * 1e3:g} mm"
        units = (("mm", 1e-3), ("µm", 1e-6))
        axis = "linear"
    if abs(c) <= bound:
        return
    hint = ""
    for name, f in units:  # the unit that makes it a plausible compensation
        if abs(c) * f <= bound:
            hint = f" — if {c:g} is in {name}, write {c * f:.6g}"
            break
    raise ParameterError(
        "Iso230Params",
        "compensation",
        f"{c:g} {si} is not a plausible reversal compensation of a {axis} axis (at most {bound_txt});"
        f" the value is in {si}{hint}",
    )


def lost_motion(
    result: Iso230Result,
    compensation: float = 0.0,
    drift: Any | None = None,
    corrected: Iso230Result | None = None,
) -> tuple[float, float, float]:
    """The lost motion an ISO test measured, its standard uncertainty and the drift's part.

    L = −B̄ + compensation; with a drift estimate, −B̄ of the drift-corrected deviations
    (``corrected`` = ``evaluate(drift.corrected)``) and the uncertainty of the drift's
    share added in quadrature [m or rad].

    Returns
    -------
    L, u_L, drift_correction : float

    Raises
    ------
    ParameterError
        An implausible ``compensation`` (:func:`check_compensation`).
    """
    check_compensation(compensation, result.unit)
    L = -result.B_mean + compensation
    u = result.u_B_mean
    if drift is not None and math.isfinite(drift.u_bias):
        if corrected is None:
            raise ValueError("lost_motion: drift given without the evaluation of drift.corrected")
        L_c = -corrected.B_mean + compensation
        return L_c, math.hypot(corrected.u_B_mean, drift.u_bias), L_c - L
    return L, u, 0.0


def compare(
    result: Iso230Result,
    deadzone: Deadzone,
    transmission: Transmission | None,
    compensation: float = 0.0,
    drift: Any | None = None,
    corrected: Iso230Result | None = None,
    *,
    factor: float | None = None,
) -> Comparison:
    """Put the ISO reversal value and the estimated deadzone in one unit, with uncertainties.

    Parameters
    ----------
    result : Iso230Result
    deadzone : Deadzone
    transmission : Transmission or None
        From the deadzone's shaft to the load; None to use ``factor``. Not applied to a
        prismatic ``deadzone`` (δ in m at the table: compared as it is, with a note).
    compensation : float
        Reversal (backlash) compensation active in the control during the test [m or rad].
    drift : Drift, optional
        Drift of the reference found in a time series
        (:func:`drivelash.iso230.dwell.estimate_drift`); see :func:`lost_motion`.
    corrected : Iso230Result, optional
        ``evaluate(drift.corrected)``; required with ``drift``.
    factor : float, optional
        Lost motion per rad of deadzone [m/rad or rad/rad] when no ``transmission`` is given
        (e.g. the axis's transmission in the wear history); not applied to a prismatic
        ``deadzone``.

    Raises
    ------
    ConfigError
        The transmission does not fit the axis (missing lead/radius on a linear axis); a
        prismatic deadzone (m) beside an ISO test of a rotary axis (rad).
    ParameterError
        An implausible ``compensation`` (:func:`check_compensation`).
    """
    notes: tuple[str, ...] = ()
    if deadzone.prismatic:
        if result.unit != "m":
            raise ConfigError(
                f"the deadzone estimate ({deadzone.source}) is of a prismatic axis (δ in m) and the ISO"
                f" test of a rotary one ({result.unit}): they cannot be compared"
            )
        k = 1.0
        given = (
            "[transmission]"
            if transmission is not None
            else ("the axis transmission of the history store" if factor is not None and factor > 0 else None)
        )
        if given is not None:
            notes = (
                f"the deadzone estimate is of a prismatic axis (δ̂ in m at the table): compared as it is,"
                f" {given} not applied",
            )
    elif transmission is not None:
        try:
            k = transmission.factor(result.unit)
        except ParameterError as exc:
            raise ConfigError(f"table [transmission], key '{exc.field}': {exc.problem}") from None
    elif factor is not None and factor > 0:
        k = float(factor)
    else:
        raise ConfigError(
            "table [transmission]: needed to convert the deadzone to the load (lead or pinion_radius)"
        )
    L_iso, u_iso, dcorr = lost_motion(result, compensation, drift, corrected)
    L_d = k * deadzone.delta
    u_d = None if deadzone.u_delta is None else k * deadzone.u_delta
    U = K_COVERAGE * math.hypot(u_iso, u_d or 0.0)
    E_n = abs(L_iso - L_d) / U if U > 0 else math.inf
    return Comparison(
        unit=result.unit,
        factor=k,
        compensation=compensation,
        drift_correction=dcorr,
        L_iso=L_iso,
        u_L_iso=u_iso,
        B=result.B,
        u_B=result.u_B,
        B_interval=result.B_interval,
        L_delta=L_d,
        u_L_delta=u_d,
        E_n=E_n,
        agree=E_n <= 1.0,
        deadzone=deadzone,
        notes=notes,
    )
