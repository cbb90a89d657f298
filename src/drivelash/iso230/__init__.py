"""ISO 230-2 positioning evaluation: reversal value B beside the estimated backlash.

Pipeline: a measurement (a table of approaches, or a raw time series whose dwells are
found automatically) → :class:`Approaches` → :func:`evaluate` → :class:`Iso230Result`
(every quantity of ISO 230-2:2014 with the uncertainty of B) → :func:`compare` with a
deadzone estimate. Pure numpy/scipy; the chart and the HTML report live in
:mod:`drivelash.report.iso230`.

Example::

    from drivelash.iso230 import read_measurement, evaluate
    m = read_measurement("laser.csv", {"Target": {"column": "P_target", "unit": "mm"},
                                       "Run": {"column": "run"}, "Dir": {"column": "direction"},
                                       "Error": {"column": "x_dev", "unit": "um"}})
    r = evaluate(m.approaches)
    print(r.B, r.u_B, r.B_mean, r.A, r.E, r.M, r.R)
"""

from drivelash.iso230.compare import Comparison, Deadzone, Transmission, compare, read_deadzone
from drivelash.iso230.dwell import Drift, DwellParams, Dwells, detect_dwells, estimate_drift
from drivelash.iso230.evaluate import Approaches, Iso230Result, approaches_from_rows, evaluate
from drivelash.iso230.inputs import Iso230Params, Measurement, read_measurement

__all__ = [
    "Approaches",
    "Comparison",
    "Deadzone",
    "Drift",
    "DwellParams",
    "Dwells",
    "Iso230Params",
    "Iso230Result",
    "Measurement",
    "Transmission",
    "approaches_from_rows",
    "compare",
    "detect_dwells",
    "estimate_drift",
    "evaluate",
    "read_deadzone",
    "read_measurement",
]
