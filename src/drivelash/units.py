"""How a drive train's small displacements are written for a reader: mrad or µm.

The numbers are SI everywhere (rad on a rotary axis, m on a prismatic one, :mod:`drivelash.io.load`);
a message, a terminal summary or a report writes a gap, a δ1, a deflection or an encoder count in
the unit an engineer reads for that axis — mrad for an angle, µm for a length (a linear axis's lost
motion is micrometres: "δ̂ = 0.0 mrad … band 2 mrad" on a carriage in m read as an angle and said
nothing; session 31 tester C, C7, and the online law's own warnings until session 34). One
:class:`GapUnit` per axis kind; :func:`gap_unit` picks it from the recording's ``meta["axis"]``.
It also names the axis's SI units of rate, acceleration, effort, mass and viscous friction —
the reports' one unit table (session 34, tester G, G7: the estimate report drew a linear
axis's δ̂ as "deadzone [mrad]" and its force as "shaft torque [N·m]").

Examples
--------
>>> u = gap_unit("prismatic")
>>> u.f(2.04e-5), u.n(-3e-6, "+.2f"), str(u)
('20.4 µm', '-3.00', 'µm')
>>> gap_unit("rotary").f(1.027, ".1f"), gap_unit(None).small(4.2e-5)
('1027.0 mrad', '0.042')
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

__all__ = ["LENGTH_TO_M", "GapUnit", "MRAD", "MICROMETRE", "gap_unit"]

#: The length units a user writes (a column, a fleet threshold, a laser check, a TE pass), as
#: factors to m — the one table the loader, the fleet file, the store and the TE import share.
LENGTH_TO_M: dict[str, float] = {"m": 1.0, "mm": 1e-3, "um": 1e-6, "µm": 1e-6}


#: a fixed-point format spec with an optional sign: group 1 the sign, group 2 the precision
_FIXED_SPEC = re.compile(r"([+ -]?)\.(\d+)f")


@dataclass(frozen=True)
class GapUnit:
    """A display unit for the small displacements of one axis kind.

    Parameters
    ----------
    symbol : str
        "mrad" or "µm".
    per_si : float
        Display units per SI unit (1e3 per rad, 1e6 per m).
    si : str
        The SI unit of the value ("rad" or "m").
    velocity : str
        The SI unit of its rate ("rad/s" or "m/s").
    torque : str
        The unit of the drive's effort ("N·m" or "N").
    stiffness : str
        The unit of a stiffness acting across the gap ("N·m/rad" or "N/m").
    acceleration : str
        The SI unit of an acceleration ("rad/s²" or "m/s²").
    mass : str
        The unit of an inertia ("kg·m²" or "kg").
    viscous : str
        The unit of a viscous friction coefficient ("N·m·s/rad" or "N·s/m").
    effort : str
        What the drive's effort is called ("torque" or "force").
    """

    symbol: str
    per_si: float
    si: str
    velocity: str
    torque: str
    stiffness: str
    acceleration: str
    mass: str
    viscous: str
    effort: str

    def __str__(self) -> str:
        return self.symbol

    def n(self, x: float, spec: str = ".1f") -> str:
        """``x`` [rad or m] as a number in this unit, formatted with ``spec``.

        A fixed-point ``spec`` (``".1f"``, ``"+.2f"``) that would leave fewer than two significant
        digits of a non-zero value gives two significant digits instead (session 36, tester I's I5:
        a 0.03 mrad δ1 difference printed "+0.0 mrad from δ1 = 0.1 mrad")."""
        v = self.per_si * float(x)
        m = _FIXED_SPEC.fullmatch(spec)
        if m and v != 0.0 and math.isfinite(v) and abs(v) < 10.0 ** (1 - int(m.group(2))):
            return format(v, f"{m.group(1)}.2g")
        return format(v, spec)

    def f(self, x: float, spec: str = ".1f") -> str:
        """``x`` [rad or m] as "number unit" (``spec`` as for :meth:`n`)."""
        return f"{self.n(x, spec)} {self.symbol}"

    def small(self, x: float) -> str:
        """``x`` [rad or m] as a number with one decimal, or 2 significant digits below 1 unit
        (a small angle scale: "±0.0 mrad, more than the 0.0 mrad" said nothing; "±0.5 mrad" for
        0.511 hid a digit: session 36, tester J's J7)."""
        v = self.per_si * float(x)
        return f"{v:.1f}" if abs(v) >= 1.0 or v == 0.0 else f"{v:.2g}"


#: a rotary axis: angles in rad, written in mrad
MRAD = GapUnit("mrad", 1e3, "rad", "rad/s", "N·m", "N·m/rad", "rad/s²", "kg·m²", "N·m·s/rad", "torque")
#: a prismatic axis: lengths in m, written in µm
MICROMETRE = GapUnit("µm", 1e6, "m", "m/s", "N", "N/m", "m/s²", "kg", "N·s/m", "force")


def gap_unit(axis: str | None) -> GapUnit:
    """The display unit of an axis kind (``Trace.meta["axis"]``): µm on a "prismatic" axis, else mrad."""
    return MICROMETRE if axis == "prismatic" else MRAD
