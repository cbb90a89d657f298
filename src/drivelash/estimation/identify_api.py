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
        None (default): ``[identification] model`` when the configuration sets it, else chosen
        by the data as ``drivelash identify`` without ``--model`` does: ``"two-mass"`` when
        the recording maps θ_l and the gear ratio is known (``N`` or ``[drivetrain] N``),
        ``"rigid"`` otherwise (:func:`resolve_model`).
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

    Raises
    ------
    ParameterError
        An unknown ``model``, ``columns`` with a Trace (or not a dict), or ``config`` of another
        type.
    ConfigError
        The configuration file cannot be read or is invalid, or ``"two-mass"`` without a gear
        ratio (``N`` or ``[drivetrain] N``).
    DataError
        The recording cannot be read, mapped or validated, lacks a column the model needs, or
        does not determine the model (one line naming the file and the column).
    """
    from drivelash.estimation.backlash_api import with_columns
    from drivelash.estimation.identify_two_mass import as_drive_config

    cfg = as_drive_config(config)
    cfg = with_columns(cfg, columns, data, "identify_drive")
    if model is None:
        model, _ = resolve_model(cfg, None, names=_mapped_names(data, cfg), N=N)
    return identify_checked(data, cfg, model=model, N=N)


def resolve_model(
    cfg: Any, model: str | None, *, names: list[str], N: float | None = None
) -> tuple[str, str]:
    """The model to fit and why: ``model`` (``--model``) when given, else ``[identification]
    model`` when the configuration sets it, else by the data — ``"two-mass"`` when ``names``
    (the recording's Trace columns under the mapping) hold θ_l and the gear ratio is known
    (``N``, else ``[drivetrain] N``), ``"rigid"`` (motor-side IDIM-LS) otherwise.

    The command and :func:`identify_drive` share this rule, so both fit the same model. A
    recording with a load encoder is a two-mass drive to an expert (the rigid fit on one with
    backlash only warns that it fits poorly); one without cannot show the gap.
    """
    if model is not None:
        return model, "--model"
    ident = cfg.identification
    if ident is not None and "model" in ident.model_fields_set:
        return str(ident.model), "[identification] model"
    if N is None and cfg.drivetrain is not None:
        N = cfg.drivetrain.given().get("N")
    if "theta_l" in names and N is not None:
        return "two-mass", f"chosen by the data: theta_l recorded and N = {float(N):g} given"
    if "theta_l" in names:
        return "rigid", "chosen by the data: theta_l recorded but no gear ratio ([drivetrain] N) for two-mass"
    return "rigid", "chosen by the data: no load position theta_l recorded"


def _mapped_names(data: Any, cfg: Any) -> list[str]:
    """The Trace columns ``data`` (a Trace, a DataFrame or a path) has under ``cfg``'s
    ``[columns]`` mapping, without reading its values."""
    import pandas as pd

    if isinstance(data, Trace):
        return list(data.columns)
    cmap = cfg.columns
    if isinstance(data, pd.DataFrame):
        return [cm.column for cm in cmap.values()] if cmap else [str(c) for c in data.columns]
    if isinstance(data, (str, Path)):
        from drivelash.io.stream import mapped_names

        return mapped_names(data, cfg)
    return []


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
