"""ISO 230-2 positioning evaluation: reversal value B beside the estimated backlash.

Pipeline: a measurement (a table of approaches, or a raw time series whose dwells are
found automatically) → :class:`Approaches` → :func:`evaluate` → :class:`Iso230Result`
(every quantity of ISO 230-2:2014 with the uncertainty of B). Pure numpy/scipy; the
chart and the HTML report live in :mod:`drivelash.report.iso230`.
"""

from drivelash.iso230.evaluate import Approaches, Iso230Result, approaches_from_rows, evaluate

__all__ = ["Approaches", "Iso230Result", "approaches_from_rows", "evaluate"]
