"""Backlash estimation: the online law (STSMO perturbation observer, adaptive deadzone law,
excitation monitor) and offline identification (rigid IDIM-LS, two-mass with backlash).

Public names (imported on first use, so importing the package stays cheap):

- online: :func:`estimate_backlash` (the computation of ``drivelash estimate``),
  :class:`BacklashEstimate`, :class:`DeadzoneEstimator` (the kernel wrapper, chunk by
  chunk; ``run`` tunes from the recording as the command does), :class:`EstimatorConfig`,
  :class:`EstimationResult`, :class:`SuperTwistingObserver`;
- offline: :func:`identify_drive` (two-mass or rigid, 95 % intervals),
  :class:`DriveIdentification`, :class:`ParameterEstimate`, :func:`identify_two_mass`,
  :func:`identify_rigid`, :func:`observe_disturbance`.
"""

from __future__ import annotations

from drivelash._lazy import lazy_names

_LAZY: dict[str, str] = {
    "estimate_backlash": "drivelash.estimation.backlash_api",
    "BacklashEstimate": "drivelash.estimation.backlash_api",
    "DeadzoneEstimator": "drivelash.estimation.estimator",
    "EstimatorConfig": "drivelash.estimation.estimator",
    "EstimationResult": "drivelash.estimation.estimator",
    "SuperTwistingObserver": "drivelash.estimation.stsmo",
    "identify_drive": "drivelash.estimation.identify_api",
    "DriveIdentification": "drivelash.estimation.identify_result",
    "ParameterEstimate": "drivelash.estimation.identify_result",
    "identify_two_mass": "drivelash.estimation.identify_two_mass",
    "identify_rigid": "drivelash.estimation.identify",
    "observe_disturbance": "drivelash.estimation.identify",
}

__all__ = sorted(_LAZY, key=str.lower)


__getattr__, __dir__ = lazy_names("drivelash.estimation", _LAZY, globals())
