"""Notebook API of offline identification: :func:`identify_drive`.

Accepts a :class:`~drivelash.io.trace.Trace`, a :class:`pandas.DataFrame` or a path and
returns the same :class:`~drivelash.estimation.identify_result.DriveIdentification` (same
numbers) as ``drivelash identify TRACE --config DRIVE.toml --model …``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from drivelash.estimation.identify_result import DriveIdentification
from drivelash.io.trace import Trace

Model = Literal["two-mass", "rigid"]


def identify_drive(
    data: Any,
    config: Any = None,
    *,
    model: Model | None = None,
    columns: Any = None,
    N: float | None = None,
) -> DriveIdentification:
    """Identify the drive-train parameters of one recording, with 95 % intervals.

    Parameters
    ----------
    data : Trace, pandas.DataFrame, str or Path
        The recording. A DataFrame is mapped with ``columns`` (or the configuration's
        ``[columns]`` table) and validated like a file; a path is read with
        :func:`drivelash.io.load_trace`. A Trace is already mapped to SI: ``columns`` is
        refused with it.
    config : DriveConfig, str or Path, optional
        Configuration: ``[columns]``/``[sampling]`` for the mapping, ``[drivetrain] N``
        (gear ratio, required for ``"two-mass"`` unless ``N`` is given) and
        ``[identification]`` options.
    model : {"two-mass", "rigid"}, optional
        ``"two-mass"``: J_m, J_l, K_S, D_S, Coulomb and viscous friction on both sides, a
        torque offset, δ and δ1 (needs θ_m, θ_l, torque_m and preferably ω_m, ω_l).
        ``"rigid"``: the motor-side IDIM-LS of :mod:`drivelash.estimation.identify`.
        None (default): ``[identification] model`` when the configuration sets it — as
        ``drivelash identify`` without ``--model`` — else ``"two-mass"`` (the API's default;
        the command's is ``"rigid"``).
    columns : dict, optional
        Column mapping for a DataFrame or a file, replacing the configuration's ``[columns]``
        only (its ``[sampling]`` is kept): *source column → Trace column*, each value the Trace
        column's name (values in its SI unit) or a ``{"column": …, "unit": …}`` table as in
        ``[columns]``.
    N : float, optional
        Gear ratio θ_m/θ_l [-]; overrides ``[drivetrain] N``.

    Returns
    -------
    DriveIdentification
        Parameters with standard errors and 95 % intervals (or the reason they are not
        identifiable), correlation matrix, backlash verdict, plausibility warnings;
        ``to_config()`` gives the ``[drivetrain]``/``[backlash]`` tables of ``estimate``.
    """
    from drivelash.estimation.backlash_api import with_columns
    from drivelash.estimation.identify_two_mass import as_drive_config

    cfg = as_drive_config(config)
    if model is None:
        model = resolve_model(cfg, None, fallback="two-mass")
    cfg = with_columns(cfg, columns, data, "identify_drive")
    return identify_checked(data, cfg, model=model, N=N)


def resolve_model(cfg: Any, model: str | None, *, fallback: str) -> str:
    """The model to fit: ``model`` (``--model``) when given, else ``[identification] model``
    when the configuration sets it, else ``fallback`` (the command: ``"rigid"``; the API:
    ``"two-mass"``)."""
    if model is not None:
        return model
    ident = cfg.identification
    if ident is not None and "model" in ident.model_fields_set:
        return str(ident.model)
    return fallback


def identify_checked(data: Any, cfg: Any, *, model: str, N: float | None = None) -> DriveIdentification:
    """:func:`~drivelash.estimation.identify_two_mass.identify_from_config`, with the reason
    when the velocities are absent and the positions cannot stand in for them.

    Without ``omega_m`` the two-mass fit differentiates θ_m; a coarse encoder sampled fast gives a
    velocity of 0 or ±one count per sample, no window then counts as moving, and the fit's
    "recording stands still" would hide the cause: that is reported as the missing column.
    """
    from drivelash.errors import DataError
    from drivelash.estimation.identify_result import IDENTIFY_NEEDS
    from drivelash.estimation.identify_two_mass import as_trace, identify_from_config

    need = IDENTIFY_NEEDS.get(model)
    trace = as_trace(data, cfg, list(need), "identify_drive") if need is not None else data
    try:
        return identify_from_config(trace, cfg, model=model, N=N)
    except DataError as exc:
        no_velocity = isinstance(trace, Trace) and "omega_m" not in trace
        if exc.column is not None or not no_velocity or "moving windows" not in str(exc):
            raise
        raise DataError(
            "missing required column: without it the fit differentiates theta_m, and that velocity "
            "shows no window in motion (e.g. a coarse encoder sampled fast); map the recorded motor "
            "velocity in [columns]",
            path=trace.meta.get("source", "<DataFrame>"),
            column="omega_m",
        ) from None


def _as_path(x: Any) -> Path | None:
    return Path(x) if isinstance(x, (str, Path)) else None
