"""Result types of offline drive identification (:func:`drivelash.identify_drive`).

One result type for every model (``"two-mass"`` and ``"rigid"``): a table of
:class:`ParameterEstimate` (value, standard error, 95 % interval, or the reason why the
recording cannot determine the parameter), their correlation matrix, the verdict on the
backlash (whether the recording crossed the gap) and plausibility warnings. ``to_config``
gives the ``[drivetrain]`` and ``[backlash]`` tables that ``drivelash estimate`` reads.

Units are SI: J [kg·m²], K_S [N·m/rad], D_S [N·m·s/rad], T_C [N·m], β [N·m·s/rad],
torque offset [N·m], δ and δ1 [rad]. A prismatic (linear) axis keeps the names and carries
kg (J_m, J_l are masses), N/m, N·s/m, N and m (:func:`parameter_units`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drivelash.errors import ParameterError
from drivelash.units import gap_unit

#: Units of the parameters (rotary axes).
UNITS: dict[str, str] = {
    "J_m": "kg·m²",
    "J_l": "kg·m²",
    "N": "-",
    "K_S": "N·m/rad",
    "D_S": "N·m·s/rad",
    "T_Cm": "N·m",
    "T_Cl": "N·m",
    "beta_m": "N·m·s/rad",
    "beta_l": "N·m·s/rad",
    "torque_offset": "N·m",
    "delta": "rad",
    "delta1": "rad",
    "c_lo": "rad",
    "c_hi": "rad",
    "encoder_delay": "s",
}


def parameter_units(axis: str | None) -> dict[str, str]:
    """The unit of each parameter on an axis kind (``Trace.meta["axis"]``): :data:`UNITS` on a
    rotary axis; on a "prismatic" one the same names in kg (J_m, J_l: masses), N/m, N·s/m, N
    and m (:func:`drivelash.units.gap_unit`).

    Examples
    --------
    >>> u = parameter_units("prismatic")
    >>> u["J_m"], u["K_S"], u["beta_l"], u["T_Cm"], u["delta"]
    ('kg', 'N/m', 'N·s/m', 'N', 'm')
    >>> parameter_units("rotary") == UNITS
    True
    """
    g = gap_unit(axis)
    return {
        **UNITS,
        **dict.fromkeys(("J_m", "J_l"), g.mass),
        "K_S": g.stiffness,
        **dict.fromkeys(("D_S", "beta_m", "beta_l"), g.viscous),
        **dict.fromkeys(("T_Cm", "T_Cl", "torque_offset"), g.torque),
        **dict.fromkeys(("delta", "delta1", "c_lo", "c_hi"), g.si),
    }


#: Parameters positive by their physics (inertias, stiffness): a 95 % interval reaching 0 means
#: the recording hardly determines them (:attr:`ParameterEstimate.note`).
POSITIVE = ("J_m", "J_l", "K_S")

#: Two-sided 95 % quantile of the standard normal distribution.
Z95 = 1.959963984540054
#: Trace columns each identification model reads (ω_m, ω_l are differentiated from the
#: positions when absent).
IDENTIFY_NEEDS = {"two-mass": ("theta_m", "theta_l", "torque_m"), "rigid": ("theta_m", "torque_m")}


@dataclass(frozen=True)
class ParameterEstimate:
    """One identified parameter.

    Attributes
    ----------
    name : str
        Symbol (``"K_S"``, ``"delta"``, …).
    value : float
        Estimate in SI units; NaN when the recording cannot determine it.
    std : float
        Standard error (same unit); ``inf`` when not identifiable.
    low, high : float
        95 % confidence interval; may be one-sided (``high = inf``) or unbounded.
    unit : str
        Unit of ``value``.
    identifiable : bool
        False when the data cannot determine the parameter; ``reason`` then says why.
    reason : str
        Empty when identifiable; otherwise one sentence a user can act on.
    """

    name: str
    value: float
    std: float
    low: float
    high: float
    unit: str = ""
    identifiable: bool = True
    reason: str = ""

    @classmethod
    def normal(cls, name: str, value: float, std: float, unit: str | None = None) -> ParameterEstimate:
        """An identified parameter with a symmetric normal 95 % interval value ± 1.96 std.

        Parameters
        ----------
        name : str
            Parameter symbol.
        value : float
            Estimate (SI).
        std : float
            Its standard error (same unit).
        unit : str, optional
            Unit of ``value``; default the symbol's SI unit (``UNITS``).
        """
        return cls(
            name,
            float(value),
            float(std),
            float(value - Z95 * std),
            float(value + Z95 * std),
            UNITS.get(name, "") if unit is None else unit,
        )

    @classmethod
    def unknown(
        cls, name: str, reason: str, low: float = -math.inf, high: float = math.inf, unit: str | None = None
    ) -> ParameterEstimate:
        """A parameter the recording cannot determine (optionally with a bound).

        Parameters
        ----------
        name : str
            Parameter symbol.
        reason : str
            Why the recording cannot determine it (one sentence a user can act on).
        low, high : float
            A bound the data do give (default unbounded).
        unit : str, optional
            Unit of the bounds; default the symbol's SI unit (``UNITS``).
        """
        return cls(
            name,
            float("nan"),
            float("inf"),
            float(low),
            float(high),
            UNITS.get(name, "") if unit is None else unit,
            identifiable=False,
            reason=reason,
        )

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready (non-finite numbers are turned into ``null`` by the JSON writer)."""
        d: dict[str, Any] = {
            "value": self.value,
            "std": self.std,
            "ci95": [self.low, self.high],
            "unit": self.unit,
            "identifiable": self.identifiable,
        }
        if self.reason:
            d["reason"] = self.reason
        elif self.note:
            d["note"] = self.note
        return d

    @property
    def note(self) -> str:
        """What a reader must know beside the number: the reason when not identifiable; for a
        parameter positive by its physics (:data:`POSITIVE`) whose 95 % interval reaches 0, that the
        recording hardly determines it; otherwise empty."""
        if not self.identifiable:
            return self.reason
        if self.name in POSITIVE and self.low <= 0.0:
            return "weakly determined: the 95 % interval reaches 0"
        return ""

    def covers(self, x: float) -> bool:
        """True if ``x`` lies in the 95 % interval.

        Parameters
        ----------
        x : float
            A value in the parameter's unit.
        """
        return self.low <= x <= self.high

    def interval_text(self, digits: int = 5) -> str:
        """The 95 % interval as ``"[low, high]"``, with the digits its width needs.

        At least ``digits`` significant digits (trailing zeros kept, so both bounds show the
        same resolution), more when the interval is narrow against its position: the width
        shows with two significant digits (δ = 1.02699 rad ± 0.05 mrad prints as
        ``[1.026941, 1.027039]``, not ``[1.0269, 1.027]``). A one-sided bound prints ``inf``.

        Parameters
        ----------
        digits : int
            Least number of significant digits.
        """
        lo, hi = self.low, self.high
        if math.isfinite(lo) and math.isfinite(hi) and hi > lo:
            digits = max(digits, math.ceil(math.log10(max(abs(lo), abs(hi)) / (hi - lo))) + 2)
        digits = min(digits, 15)

        def fmt(x: float) -> str:  # trailing zeros kept, a bare trailing point not (-19538, not -19538.)
            return re.sub(r"\.(?=e|$)", "", f"{x:#.{digits}g}")

        return f"[{fmt(lo)}, {fmt(hi)}]"


#: Longest reason a :class:`DriveIdentification` repr prints for one parameter or the backlash
#: verdict [characters] (the whole text stays on the object): one line of a wide notebook cell.
REPR_REASON_CHARS = 100


@dataclass(repr=False)
class DriveIdentification:
    """Result of :func:`drivelash.identify_drive`.

    Attributes
    ----------
    model : {"two-mass", "rigid"}
        Model identified.
    parameters : dict of str to ParameterEstimate
        Every parameter in report order (two-mass: J_m, J_l, K_S, D_S, T_Cm, beta_m, T_Cl,
        beta_l, torque_offset, delta, delta1; N is given, not identified).
    names : tuple of str
        Names of the rows/columns of ``correlation`` (the identified parameters).
    correlation : numpy.ndarray
        Correlation matrix of the identified parameters [-].
    N : float
        Gear ratio used (given) [-].
    backlash_visible : bool
        Whether the recording crosses the gap so that δ can be determined.
    reason : str
        Plain-language verdict on the backlash (both contacts seen, or why not).
    warnings : list of str
        Plausibility findings, one line each (e.g. a negative inertia and its likely cause).
    fit : dict
        Fit statistics: residual RMS per equation, relative errors, rows, covariance method.
    method : str
        One line naming the method.
    signals : dict of str to numpy.ndarray
        Decimated signals for the report (time, measured and predicted accelerations,
        Δθ, shaft torque).
    source : object or None
        Rigid model: the IDIM-LS result it was built from (what the rigid report draws).
    axis : {"rotary", "prismatic"}
        The recording's axis kind (``Trace.meta["axis"]``): on a prismatic axis J_m, J_l are
        masses [kg], K_S [N/m], D_S and β [N·s/m], T_C and the offset [N], δ, δ1 [m]
        (:func:`parameter_units`) under the same names.
    """

    model: str
    parameters: dict[str, ParameterEstimate]
    names: tuple[str, ...]
    correlation: np.ndarray
    N: float = 1.0
    backlash_visible: bool = False
    reason: str = ""
    warnings: list[str] = field(default_factory=list)
    fit: dict[str, Any] = field(default_factory=dict)
    method: str = ""
    signals: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    source: Any = field(default=None, repr=False, compare=False)
    axis: str = "rotary"

    def __getitem__(self, name: str) -> ParameterEstimate:
        return self.parameters[name]

    def __repr__(self) -> str:
        """A table a notebook can read: model, N, the verdicts, one line per parameter (value,
        unit, 95 % interval, or why not determined) — not the ``fit`` dictionary, the correlation
        matrix and every field (the dataclass repr was one line of ~6.5 kB; session 34, tester G,
        G12). ``fit``, ``correlation`` and ``warnings`` stay on the object."""
        head = (
            f"DriveIdentification(model={self.model!r}, N={self.N:g}, plausible={self.plausible},"
            f" backlash_visible={self.backlash_visible}, warnings={len(self.warnings)}"
        )

        def short(text: str) -> str:
            return text if len(text) <= REPR_REASON_CHARS else text[: REPR_REASON_CHARS - 1] + "…"

        rows = [
            f"  {name} = {p.value:.6g} {p.unit}  95 % {p.interval_text()}".rstrip()
            if p.identifiable
            else f"  {name} = –  ({short(p.reason)})"
            for name, p in self.parameters.items()
        ]
        verdict = short(self.verdict)
        return "\n".join([head, *rows, f"  {verdict})" if verdict else "  )"])

    def value(self, name: str) -> float:
        """Value of parameter ``name`` (NaN when not identifiable).

        Parameters
        ----------
        name : str
            Parameter symbol (``"K_S"``, ``"delta"``, …); its unit is ``self[name].unit``.
        """
        return self.parameters[name].value

    @property
    def plausible(self) -> bool:
        """False when a plausibility check failed (see ``warnings``)."""
        return not self.fit.get("implausible", False)

    @property
    def verdict(self) -> str:
        """The backlash verdict as one line: ``"backlash: <reason>"``, or the reason itself where it
        already starts with "backlash" ("backlash not determined: …", "backlash below what …")."""
        return self.reason if self.reason.lower().startswith("backlash") else f"backlash: {self.reason}"

    def to_config(self) -> dict[str, dict[str, float]]:
        """The ``[drivetrain]`` and ``[backlash]`` tables ``drivelash estimate`` reads.

        Only identifiable values are written. Friction coefficients and D_S whose estimate
        is negative but whose interval reaches 0 are written as 0 (the parameter classes
        require ≥ 0). ``[backlash]`` carries δ1 (and δ for reference) only when the
        recording determined them — never a negative δ (a gap is never negative; δ1 is then the
        position of contacts that coincide, not of a gap's flank).
        """
        dt: dict[str, float] = {"N": float(self.N)}
        for k in ("J_m", "J_l", "K_S", "D_S", "T_Cm", "T_Cl", "beta_m", "beta_l"):
            p = self.parameters.get(k)
            if p is None or not p.identifiable or not math.isfinite(p.value):
                continue
            v = p.value
            if k in ("D_S", "T_Cm", "T_Cl", "beta_m", "beta_l") and v < 0 <= p.high:
                v = 0.0
            dt[k] = float(v)
        out: dict[str, dict[str, float]] = {"drivetrain": dt}
        d1 = self.parameters.get("delta1")
        d = self.parameters.get("delta")
        negative_gap = d is not None and d.identifiable and not d.value >= 0.0
        if d1 is not None and d1.identifiable and math.isfinite(d1.value) and not negative_gap:
            bl = {"delta1": float(d1.value)}
            if d is not None and d.identifiable and math.isfinite(d.value):
                bl["delta"] = float(d.value)
            out["backlash"] = bl
        return out

    def to_toml(
        self, comments: list[str] | None = None, tables: dict[str, dict[str, float]] | None = None
    ) -> str:
        """``to_config()`` (or ``tables``) as TOML text with ``#`` comment lines (intervals, verdict).

        Parameters
        ----------
        comments : list of str, optional
            Lines written as ``#`` comments above the tables.
        tables : dict, optional
            The tables to write instead of :meth:`to_config` (``{table: {key: value}}``, SI).
        """
        import tomli_w

        head = list(comments or [])
        if self.axis == "prismatic":
            u = parameter_units(self.axis)
            head.append(
                "linear (prismatic) axis: the keys keep their rotary names — J_m, J_l are masses "
                f"[{u['J_m']}], K_S [{u['K_S']}], D_S, beta_m, beta_l [{u['D_S']}], "
                f"T_Cm, T_Cl, torque_offset [{u['T_Cm']}], delta, delta1 [{u['delta']}]"
            )
        tables = self.to_config() if tables is None else tables
        written = {k: v for t in tables.values() for k, v in t.items()}
        for p in self.parameters.values():
            if p.identifiable:
                w = written.get(p.name)
                small = ""  # a gap on a linear axis also in µm (the value stays SI: m)
                if self.axis == "prismatic" and p.unit == "m":
                    small = f" ({gap_unit(self.axis).f(p.value, '.5g')})"
                head.append(
                    f"{p.name} = {p.value:.6g} {p.unit}{small}, 95 % CI {p.interval_text(6)}"
                    + (f" — {p.note}" if p.note else "")
                    + (
                        f" — written as {w:.6g}: below 0, which the drive-train parameters do not "
                        "allow, with its 95 % interval reaching 0"
                        if w is not None and w != p.value
                        else ""
                    )
                )
            else:
                head.append(f"{p.name}: not identified ({p.reason})")
        head.append(self.verdict)
        head += [f"warning: {w}" for w in self.warnings]
        text = "".join(f"# {c}\n" for c in head)
        return text + tomli_w.dumps({k: {kk: float(vv) for kk, vv in v.items()} for k, v in tables.items()})

    def drivetrain_params(self, base: Any = None) -> Any:
        """:class:`~drivelash.params.DrivetrainParams` from the identified values.

        Parameters
        ----------
        base : DrivetrainParams or dict, optional
            Values for fields the recording did not determine (e.g. a configuration).

        Raises
        ------
        ParameterError
            A field the recording did not determine and ``base`` does not give (naming it and why).
        """
        from dataclasses import asdict, is_dataclass

        from drivelash.params import DrivetrainParams

        vals: dict[str, float] = {}
        if base is not None:
            vals.update(asdict(base) if is_dataclass(base) else dict(base))
        vals.update(self.to_config()["drivetrain"])
        keep = {f for f in DrivetrainParams.__dataclass_fields__}
        for k in ("J_m", "J_l", "K_S"):
            q = self.parameters.get(k)
            if vals.get(k) is None and q is not None and not q.identifiable:
                raise ParameterError("identification", k, f"{q.reason}; give it in base=")
        return DrivetrainParams(**{k: v for k, v in vals.items() if k in keep and v is not None})

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary (no arrays except the small correlation matrix): plain JSON types,
        a non-finite number (an open interval's ∞, an undetermined value) is None, as the
        command's JSON writes it (:func:`drivelash.io.outputs.jsonable`)."""
        from drivelash.io.outputs import jsonable

        return jsonable(
            {
                "model": self.model,
                "axis": self.axis,
                "method": self.method,
                "N": self.N,
                "parameters": {k: p.as_dict() for k, p in self.parameters.items()},
                "correlation": {"names": list(self.names), "matrix": np.asarray(self.correlation).tolist()},
                "backlash_visible": self.backlash_visible,
                "backlash_reason": self.reason,
                "plausible": self.plausible,
                "warnings": list(self.warnings),
                "fit": self.fit,
            }
        )
