"""Notebook API of offline identification: :func:`identify_drive`.

Accepts a :class:`~drivelash.io.trace.Trace`, a :class:`pandas.DataFrame` or a path and
returns the same :class:`~drivelash.estimation.identify_result.DriveIdentification` (same
numbers) as ``drivelash identify TRACE --config DRIVE.toml --model …``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from drivelash.estimation.identify_result import DriveIdentification

Model = Literal["two-mass", "rigid"]


def identify_drive(
    data: Any,
    config: Any = None,
    *,
    model: Model = "two-mass",
    columns: Any = None,
    N: float | None = None,
) -> DriveIdentification:
    """Identify the drive-train parameters of one recording, with 95 % intervals.

    Parameters
    ----------
    data : Trace, pandas.DataFrame, str or Path
        The recording. A DataFrame is mapped with ``columns`` (or the configuration's
        ``[columns]`` table) and validated like a file; a path is read with
        :func:`drivelash.io.load_trace`.
    config : DriveConfig, str or Path, optional
        Configuration: ``[columns]``/``[sampling]`` for the mapping, ``[drivetrain] N``
        (gear ratio, required for ``"two-mass"`` unless ``N`` is given) and
        ``[identification]`` options.
    model : {"two-mass", "rigid"}
        ``"two-mass"``: J_m, J_l, K_S, D_S, Coulomb and viscous friction on both sides, a
        torque offset, δ and δ1 (needs θ_m, θ_l, torque_m and preferably ω_m, ω_l).
        ``"rigid"``: the motor-side IDIM-LS of :mod:`drivelash.estimation.identify`.
    columns : dict, optional
        Column mapping for a DataFrame: source name → trace column name or a
        ``{"column": …, "unit": …}`` table as in ``[columns]``.
    N : float, optional
        Gear ratio θ_m/θ_l [-]; overrides ``[drivetrain] N``.

    Returns
    -------
    DriveIdentification
        Parameters with standard errors and 95 % intervals (or the reason they are not
        identifiable), correlation matrix, backlash verdict, plausibility warnings;
        ``to_config()`` gives the ``[drivetrain]``/``[backlash]`` tables of ``estimate``.
    """
    from drivelash.estimation.identify_two_mass import identify_from_config

    return identify_from_config(data, config, model=model, columns=columns, N=N)


def _as_path(x: Any) -> Path | None:
    return Path(x) if isinstance(x, (str, Path)) else None
