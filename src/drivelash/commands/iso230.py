"""``drivelash iso230``: ISO 230-2 evaluation of a positioning test, B beside the deadzone.

``iso230 MEASUREMENT [--config AXIS.toml] [--estimate EST.json] [--json out.json]
[--report iso.html] [--db URL --axis ID [--time T]]``
reads a table of approaches or a raw time series (dwells found
automatically), evaluates every ISO 230-2:2014 quantity with the uncertainty of the
reversal value, and — with ``--estimate`` and a ``[transmission]`` — puts B beside the
deadzone estimated from a drive recording (or the estimate of the same axis in the wear
history); with ``--db``/``--axis`` the check is stored in that history as a second source
of the axis (:mod:`drivelash.iso230.history`). Outputs go through
:class:`drivelash.io.outputs.Outputs`: validated first, written together at the end.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer

from drivelash.commands import print_warnings


def run_iso230(
    measurement: Path,
    config: Path | None = None,
    *,
    estimate: Path | None = None,
    json_out: Path | None = None,
    report: Path | None = None,
    db: str | None = None,
    axis: str | None = None,
    time: str | None = None,
    force: bool = False,
    quiet: bool = False,
) -> dict[str, Any]:
    """Body of ``drivelash iso230`` (callable from Python; returns the JSON summary)."""
    from drivelash.errors import ConfigError, DrivelashError, ParameterError
    from drivelash.io.outputs import HTML_EXTENSIONS, JSON_EXTENSIONS, Outputs, write_json
    from drivelash.iso230 import evaluate
    from drivelash.iso230.compare import check_compensation, compare, lost_motion, read_deadzone
    from drivelash.iso230.config import load_iso230_config
    from drivelash.iso230.history import axis_factor, check_time, deadzone_from_store, store_check
    from drivelash.iso230.inputs import read_measurement

    if (db is None) != (axis is None):
        raise DrivelashError("--db and --axis go together: the history store and the axis (machine/axis)")
    store = None
    store_path = None
    if db is not None:
        from drivelash.wear.store import store_file

        store_path = store_file(db)  # the history store: no output may be written over it
    with Outputs("iso230", inputs=[measurement, config, estimate, store_path], force=force) as out:
        j = out.file(json_out, option="--json", kinds=JSON_EXTENSIONS)
        r = out.file(report, option="--report", kinds=HTML_EXTENSIONS)
        cfg = load_iso230_config(config)
        deadzone = read_deadzone(estimate) if estimate is not None else None
        if not measurement.is_file():
            from drivelash.io import read_raw

            read_raw(measurement)  # the reader's one-line error (missing file, directory, …)
        when, when_how = check_time(measurement, time)
        try:
            factor = None
            notes: list[str] = []
            if db is not None and axis is not None:
                from drivelash.wear.store import Store

                store = Store(db, create=False)
                factor = axis_factor(store, axis)
                if deadzone is None:
                    deadzone = deadzone_from_store(store, axis, when)
                    if deadzone is None:
                        notes.append(f"no excited estimate of axis {axis} in {store.name}: B is not compared")
            if (
                deadzone is not None
                and not deadzone.prismatic
                and cfg.transmission is None
                and factor is None
            ):
                raise ConfigError(
                    f"{cfg.source}: comparing with the deadzone needs a [transmission] table (lead or"
                    " pinion_radius, and i_G) or an axis transmission in the history store"
                )
            meas = read_measurement(measurement, cfg.mapping, params=cfg.iso230, dwell=cfg.dwell)
            cov = cfg.iso230.coverage
            res = evaluate(meas.approaches, coverage=cov)
            try:  # the axis's unit is known only now: a compensation written in µm or mm
                check_compensation(cfg.iso230.compensation, res.unit)
            except ParameterError as exc:
                raise ConfigError(
                    f"{cfg.source}: table [iso230], key 'compensation': {exc.problem}"
                ) from None
            axis_res = evaluate(meas.approaches_axis, coverage=cov) if meas.approaches_axis else None
            corrected = evaluate(meas.drift.corrected, coverage=cov) if meas.drift else None
            comparison = None
            if deadzone is not None:
                comparison = compare(
                    res,
                    deadzone,
                    cfg.transmission,
                    cfg.iso230.compensation,
                    drift=meas.drift,
                    corrected=corrected,
                    factor=factor if res.unit == "m" else None,
                )
            summary: dict[str, Any] = {
                "measurement": str(measurement),
                "config": None if config is None else str(config),
                "input": meas.kind,
                "time": when.isoformat(timespec="seconds"),
                "time_from": when_how,
                **res.to_dict(),
            }
            if deadzone is not None and deadzone.note:
                notes.append(deadzone.note)
            if comparison is not None:
                notes.extend(comparison.notes)
            warnings = list(meas.warnings) + notes
            if meas.drift is not None:
                dr = meas.drift
                summary["drift"] = {
                    "rate": dr.rate,
                    "u_rate": dr.u_rate,
                    "bias_B_mean": dr.bias_B_mean,
                    "u_bias_B_mean": dr.u_bias,
                }
                if abs(dr.bias_B_mean) > res.u_B_mean:
                    warnings.append(drift_warning(dr, res))
            summary["warnings"] = warnings
            if axis_res is not None:
                summary["reference_vs_axis_encoder"] = {
                    "B": axis_res.B,
                    "B_mean": axis_res.B_mean,
                    "u_B_mean": axis_res.u_B_mean,
                }
            if meas.dwells is not None:
                summary["dwells"] = meas.dwells.to_dict()
            if comparison is not None:
                summary["deadzone_comparison"] = comparison.to_dict()
            L, u_L, dcorr = lost_motion(res, cfg.iso230.compensation, meas.drift, corrected)
            summary["lost_motion"] = {
                "value": L,
                "u": u_L,
                "compensation": cfg.iso230.compensation,
                "drift_correction": dcorr,
            }
            if store is not None and axis is not None:
                rot = cfg.transmission.factor("rad") if (res.unit == "rad" and cfg.transmission) else None
                target: Any = store
                if res.unit == "m" and factor is None:
                    tr_mm, why = _config_transmission_mm(cfg)
                    if tr_mm is not None:
                        target = _WithTransmission(store, tr_mm)
                    else:
                        warnings.append(
                            f"the check is stored in m only and cannot be shown as a deadzone (rad) beside "
                            f"the estimates: axis {axis} has no transmission in {store.name} and {why} — add "
                            f"'transmission = <mm of load travel per rad>' to its [[axis]] in fleet.toml "
                            "(then `drivelash track ingest`) or a [transmission] table to the iso230 config"
                        )
                mid = store_check(
                    target,
                    axis,
                    measurement,
                    when,
                    res,
                    L,
                    u_L,
                    rotary_factor=rot,
                    extra={"compensation": cfg.iso230.compensation, "drift_correction": dcorr},
                )
                summary["history"] = {"store": store.name, "axis": axis, "measurement_id": mid, "value": L}
            if j is not None:
                write_json(out.staging(j), summary)
            if r is not None:
                from drivelash.report.iso230 import write_iso230_report

                # every warning the terminal and the JSON give (deadzone, drift, history), not
                # only the reader's
                write_iso230_report(
                    out.staging(r), res, meas, comparison, axis_result=axis_res, warnings=warnings
                )
        finally:
            if store is not None:
                store.close()
    if not quiet:
        print_warnings({"warnings": summary["warnings"]})
        _print_summary(res, comparison)
        if "history" in summary:
            h = summary["history"]
            typer.echo(f"stored as measurement {h['measurement_id']} of axis {h['axis']} in {h['store']}")
    return summary


def _config_transmission_mm(cfg: Any) -> tuple[float | None, str]:
    """(mm of load travel per rad from the iso230 config's [transmission], or None and why not)."""
    from drivelash.errors import DrivelashError

    if cfg.transmission is None:
        return None, f"{cfg.source} has no [transmission] table"
    try:
        return float(cfg.transmission.factor("m")) * 1e3, ""
    except DrivelashError as exc:
        return None, f"{cfg.source}: [transmission] does not give one ({str(exc).splitlines()[0]})"


class _WithTransmission:
    """The store, with the iso230 config's transmission for the check's conversion to rad
    (used only when the axis has none in the store)."""

    def __init__(self, store: Any, mm_per_rad: float) -> None:
        self._store, self._tr = store, mm_per_rad

    def add_measurement(self, *args: Any, **kw: Any) -> int:
        return self._store.add_measurement(*args, transmission_mm_per_rad=self._tr, **kw)


def drift_warning(dr: Any, res: Any) -> str:
    """One line: the reference drifted enough to shift B̄ by more than its uncertainty."""
    from drivelash.report.iso230 import display_units

    _, _, dl, df = display_units(res.unit)
    return (
        f"the reference drifted {dr.rate * df * 3600:.3g} ± {dr.u_rate * df * 3600:.2g} {dl}/h"
        " during the test;"
        f" it shifts B̄ by {dr.bias_B_mean * df:.3g} {dl}, more than u(B̄) = {res.u_B_mean * df:.3g} {dl}"
        " (ISO values are not corrected; the deadzone comparison is)"
    )


def _print_summary(res: Any, comparison: Any | None) -> None:
    from rich.console import Console
    from rich.markup import escape

    from drivelash.report.iso230 import display_units  # no matplotlib import at module level

    _, _, dl, df = display_units(res.unit)
    c = Console()
    c.print(f"[bold]ISO 230-2[/bold]: {res.m} targets × {res.n} runs per direction  {escape(f'[{dl}]')}")
    c.print(f"  A = {res.A * df:.3f}   (A↑ {res.A_up * df:.3f}, A↓ {res.A_down * df:.3f})")
    lo, hi = res.B_interval
    c.print(
        f"  B = {res.B * df:.3f} ± {res.u_B * df:.3f}  [{lo * df:.3f}, {hi * df:.3f}]   "
        f"B̄ = {res.B_mean * df:.3f} ± {res.u_B_mean * df:.3f}"
    )
    c.print(
        f"  E = {res.E * df:.3f}   (E↑ {res.E_up * df:.3f}, E↓ {res.E_down * df:.3f})   M = {res.M * df:.3f}"
    )
    c.print(f"  R = {res.R * df:.3f}   (R↑ {res.R_up * df:.3f}, R↓ {res.R_down * df:.3f})")
    if comparison is not None:
        cm = comparison
        u = "–" if cm.u_L_delta is None else f"{cm.u_L_delta * df:.3f}"
        verdict = "[green]agree[/green]" if cm.agree else "[red]disagree[/red]"
        c.print(
            f"  lost motion: ISO {cm.iso_label} = {cm.L_iso * df:.3f} ± {cm.u_L_iso * df:.3f},"
            f" deadzone at the load {cm.L_delta * df:.3f} ± {u}  → E_n = {cm.E_n:.2f} {verdict}"
        )


def register(app: typer.Typer, te_app: typer.Typer) -> None:
    """Add ``iso230`` to the CLI."""

    @app.command()
    def iso230(
        measurement: Path = typer.Argument(
            ..., help="Table of approaches or raw time series (CSV, Parquet, HDF5, MAT)."
        ),
        config: Path | None = typer.Option(
            None, "--config", "-c", help="TOML: [columns], [sampling], [iso230], [dwell], [transmission]."
        ),
        estimate: Path | None = typer.Option(
            None, "--estimate", help="JSON of `drivelash estimate`: put B beside this deadzone."
        ),
        json_out: Path | None = typer.Option(None, "--json", help="Write the JSON summary here."),
        report: Path | None = typer.Option(
            None, "--report", help="Write the self-contained HTML report here."
        ),
        db: str | None = typer.Option(
            None, "--db", help="Wear history store (SQLite path or SQLAlchemy URL): store the check there."
        ),
        axis: str | None = typer.Option(None, "--axis", help="The axis in the store (machine/axis)."),
        time: str | None = typer.Option(
            None, "--time", help="When the check was made (ISO 8601; default: the file's modification time)."
        ),
        force: bool = typer.Option(
            False, "--force", help="Replace existing files that are not drivelash outputs."
        ),
    ) -> None:
        """ISO 230-2 positioning evaluation: A, B, E, M, R; B beside the estimated deadzone."""
        run_iso230(
            measurement,
            config,
            estimate=estimate,
            json_out=json_out,
            report=report,
            db=db,
            axis=axis,
            time=time,
            force=force,
        )
