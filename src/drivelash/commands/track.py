"""``drivelash track ingest|status|forecast|report`` and ``drivelash simulate fleet``.

* ``track ingest FLEET.toml [--db URL] [--workers N] [--dask local|ADDRESS]`` — estimate every
  new recording of the fleet and commit it to the history store (progress bar on stderr);
  recordings that fail are stored as failed with their one-line reason, printed, and make
  the exit status 2 once the rest is stored; every later ingest retries them (the summary
  says how many were retried and how many still fail);
* ``track status [--db URL | --fleet FLEET.toml]`` — table of the axes sorted by forecast time
  to threshold, with the active alarms;
* ``track forecast AXIS [--json PATH|-] [--force]`` — one axis's trend, model and forecast;
* ``track report -o fleet.html`` — the self-contained HTML fleet report.

The store is ``--db`` (an SQLAlchemy URL or an SQLite file path); without it, the fleet
file's ``[fleet] db`` (relative to the fleet file) when ``--fleet`` is given, else
``wear.sqlite`` in the current directory.
"""

from __future__ import annotations

import math
import os
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import typer

from drivelash.errors import DrivelashError
from drivelash.units import gap_unit

track_app = typer.Typer(
    help="Wear tracking of backlash across a fleet: ingest, status, forecast, report.",
    no_args_is_help=True,
)


def _store_location(db: str | None, fleet: Path | None) -> tuple[str, Any]:
    """(store URL, the parsed fleet or None): a given fleet file also supplies the thresholds
    the axes are judged by (its current ones, not those stored at the last ingest)."""
    if fleet is not None:
        from drivelash.wear.fleet import load_fleet

        f = load_fleet(fleet)
        return (db or _fleet_db(f)), f
    return (db or "wear.sqlite"), None


def _fleet_db(f: Any) -> str:
    return f.db if "://" in f.db else str((f.path.parent / f.db).resolve())


def run_ingest(
    fleet_path: Path,
    db: str | None = None,
    workers: int | None = None,
    dask: str | None = None,
    quiet: bool = False,
) -> Any:
    """Body of ``track ingest`` (callable from Python); returns the :class:`IngestReport`."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, TextColumn, TimeRemainingColumn

    from drivelash._progress import stderr_progress
    from drivelash.wear.fleet import load_fleet
    from drivelash.wear.ingest import DaskRunner, check_files, ingest
    from drivelash.wear.store import Store
    from drivelash.wear.words import count

    fleet = load_fleet(fleet_path)  # every config error before anything is opened
    check_files(fleet)  # and those its files show (a file of two axes, a time format that fits none)
    n = workers if workers is not None else (os.cpu_count() or 1)
    if n < 1:
        raise DrivelashError(f"--workers: must be >= 1, got {n}")
    runner = DaskRunner(dask, n) if dask else None  # unreachable scheduler: nothing written
    try:
        store = Store(db or _fleet_db(fleet))
        console = Console(stderr=True, quiet=quiet)
        with stderr_progress(
            TextColumn("ingest"),
            BarColumn(),
            MofNCompleteColumn(),
            TimeRemainingColumn(),
            console=console,
        ) as bar:
            task = bar.add_task("ingest", total=None)

            def progress(done: int, total: int) -> None:
                bar.update(task, completed=done, total=total)

            def waiting(message: str) -> None:  # another ingest holds the store
                console.print(f"drivelash: {message}", markup=False, highlight=False, soft_wrap=True)

            try:
                rep = ingest(fleet, store, workers=n, dask=runner, progress=progress, on_wait=waiting)
            finally:
                store.close()
    finally:
        if runner is not None:
            runner.close()
    if not quiet:
        for w in rep.warnings:
            typer.echo(f"drivelash: warning: {w}", err=True)
        for w in rep.duplicates:
            typer.echo(f"drivelash: warning: duplicate recording: {w}", err=True)
        for reason in rep.failures:
            typer.echo(f"drivelash: warning: {reason}", err=True)
        c = Console()
        hz = fleet.axes[0].estimate_rate_hz  # fleet-wide ([fleet] estimate_rate_hz)
        rate = "every sample" if hz is None else f"at most {hz:g} Hz: every k-th sample of faster recordings"
        n_new = rep.planned - rep.retried
        new_failed = rep.failed - rep.still_failing  # files read for the first time that failed
        head = (
            f"{count(n_new, 'new recording')} estimated "
            if new_failed == 0
            else f"{count(n_new, 'new recording')}: {n_new - new_failed} estimated, {new_failed} failed "
        )  # a file that only failed is not "estimated" (session 30 tester B, B-10)
        c.print(
            f"[bold]{fleet.name}[/bold]: {head}"
            f"({rate}; {rep.stored} stored in {count(rep.batches, 'transaction')}, {rep.failed} failed), "
            f"{rep.skipped} already in the store"
            + (
                f"; {rep.moved} moved or renamed (not re-estimated"
                + (
                    f"; {rep.renamed_dated} re-dated by the time stamp in the new name)"
                    if rep.renamed_dated
                    else ")"
                )
                if rep.moved
                else ""
            )
            + (f"; {rep.retried} retried, {rep.still_failing} still failing" if rep.retried else "")
            + (f"; {rep.replaced} replaced (content changed)" if rep.replaced else "")
            + (
                f"; {count(rep.rewritten_new, 'file')} rewritten with a new measurement (another "
                "start time: stored as new, the previous one stays in the history)"
                if rep.rewritten_new
                else ""
            )
            + (f" ({rep.redated} re-dated: the time specification changed)" if rep.redated else "")
            + f"; {rep.wall_s:.1f} s -> {store.name}"
        )
    return rep


def _summaries(db: str, fleet: Any = None) -> tuple[Any, list[dict[str, Any]], str | None]:
    """(the open store, the summaries of the axes shown, the note naming the store's axes that
    ``fleet`` leaves out, or None)."""
    from drivelash.wear.alarms import (
        axes_not_in_fleet,
        fleet_axes_not_stored,
        fleet_summary,
        hidden_alarm_count,
        not_in_fleet_note,
        not_stored_note,
    )
    from drivelash.wear.store import Store

    store = Store(db, create=False)
    try:
        with store.guard(_READ_ONLY):
            summ = fleet_summary(store, fleet)
            note = None
            if fleet is not None:
                # both directions: the store's axes the file no longer has, and the file's axes
                # the store does not have yet (a renamed axis is one of each)
                gone = axes_not_in_fleet(store, fleet)
                notes = [
                    not_in_fleet_note(gone, fleet.path.name, hidden_alarm_count(store, gone)),
                    not_stored_note(fleet_axes_not_stored(store, fleet), fleet.path.name),
                ]
                note = ". ".join(n for n in notes if n) or None
            return store, summ, note
    except BaseException:
        store.close()
        raise


#: What a reader (status, forecast, report) that hits a store failure leaves behind.
_READ_ONLY = "nothing was written (a read-only command)"


def run_status(
    db: str, quiet: bool = False, label: str | None = None, fleet: Any = None
) -> list[dict[str, Any]]:
    """Body of ``track status``; returns the axis summaries (sorted by forecast time).

    ``label`` names the store in the title instead of its URL (the demo builds its store in a
    staging directory that is renamed afterwards, so the URL would name a path that is gone);
    ``fleet`` (a parsed fleet) supplies the thresholds the axes are judged by, and only its
    axes are shown (one line names the store's axes it leaves out; their history is kept).
    """
    from rich.console import Console
    from rich.markup import escape

    from drivelash.report.fleet import NOW_LEGEND, any_latest_only, not_excited_line
    from drivelash.wear.alarms import stale_notes

    store, summ, note = _summaries(db, fleet)
    store.close()
    if not quiet:
        c = Console()
        if not c.is_terminal and not os.environ.get("COLUMNS", "").isdigit():
            c = Console(width=200)  # a pipe: the full table, unless COLUMNS says how wide
        if c.width < 1:  # COLUMNS=0 (a serial console's size 0 × 0) printed nothing at all
            c = Console(width=80 if c.is_terminal else 200)
        table, legend = status_table(summ, f"wear status — {label or store.name} (times UTC)", c.width)
        c.print(table)
        if legend is not None:
            c.print(escape(legend), style="dim")
        if any_latest_only(summ):
            c.print(escape(NOW_LEGEND), style="dim")
        why = not_excited_line(summ)
        if why is not None:
            c.print(escape(why))
        if note is not None:
            c.print(f"[yellow]note[/yellow] {escape(note)}")
        for s in summ:
            for n in s.get("notes", []):
                c.print(f"[yellow]note[/yellow] {escape(n)}")
        for s in summ:
            for a in s["alarms"]:
                c.print(f"[red]alarm[/red] {escape(a.kind)}: {escape(a.message)}")
        for name, msg in stale_notes(summ):
            c.print(f"[yellow]stale[/yellow] {escape(name)}: {escape(msg)}")
    return summ


def status_table(summ: list[dict[str, Any]], title: str, width: int) -> tuple[Any, str | None]:
    """The ``track status`` table for a console ``width`` characters wide, and its legend.

    The full table (the report's :data:`~drivelash.report.fleet.OVERVIEW_HEADER` and cells)
    when it fits; else the narrow one (:func:`~drivelash.report.fleet.compact_rows`: short
    headers, the 90 % interval in days around the expected crossing, abbreviated model and
    alarm names; one space between the columns when two do not fit; still too wide, the
    columns of :data:`~drivelash.report.fleet.COMPACT_DROP_ORDER` are left out in turn, never
    the axis and its alarms), whose legend (returned, else None) spells the abbreviations out
    and names the columns left out. Every column but the alarms is ``no_wrap``: an
    axis is one line (only alarm kinds that still do not fit fold onto a second one; each
    alarm is listed in full below the table anyway).

    Parameters
    ----------
    summ : list of dict
        :func:`drivelash.wear.alarms.fleet_summary`.
    title : str
        Table title (plain text).
    width : int
        Console width [characters].

    Returns
    -------
    (rich.table.Table, str or None)
    """
    from rich.cells import cell_len
    from rich.markup import escape
    from rich.table import Table

    from drivelash.report.fleet import (
        COMPACT_DROP_ORDER,
        COMPACT_HEADER,
        compact_legend,
        compact_rows,
        overview_header,
        overview_rows,
    )

    rows = [[str(x) for x in r] for r in overview_rows(summ)]
    header, legend, pad = overview_header(summ), None, (0, 1)

    def columns(h: list[str], rs: list[list[str]]) -> int:  # the cells' width [chars]
        return sum(max(cell_len(x) for x in [hh, *col]) for hh, *col in zip(h, *rs, strict=True))

    if rows and columns(header, rows) + 2 * len(header) > width:  # 2 spaces between and around
        header, rows, legend = COMPACT_HEADER, compact_rows(summ), compact_legend(summ)
        if columns(header, rows) + 2 * (len(header) - 1) > width:
            pad = (0, 1, 0, 0)  # still too wide: one space between the columns
        # still too wide: leave out the least needed columns (never the axis and its alarms),
        # rather than cut every cell to "M0…" (two axes M01/X and M01/Y looked the same)
        hidden: list[str] = []
        for name in COMPACT_DROP_ORDER:
            if columns(header, rows) + len(header) - 1 <= width:
                break
            k = header.index(name)
            header = header[:k] + header[k + 1 :]
            rows = [r[:k] + r[k + 1 :] for r in rows]
            hidden.append(name)
        if hidden:
            legend += f"; not shown at this width: {', '.join(hidden)} (`track forecast AXIS` has them all)"
    table = Table(box=None, padding=pad, pad_edge=legend is None, title=escape(title))
    for i, h in enumerate(header):
        last = i == len(header) - 1
        # escaped: "[mrad]" would be read as rich markup and vanish from the header
        table.add_column(escape(h), no_wrap=not last, overflow="fold" if last else "ellipsis")
    for row, s in zip(rows, summ, strict=True):
        style = "red" if s["crossed"] or s["alarms"] else None
        table.add_row(*(escape(x) for x in row), style=style)
    return table, legend


def _stale(s: dict[str, Any]) -> str | None:
    """The stale-forecast note of ``track status``/``report`` for this axis (None when not stale)."""
    from drivelash.wear.alarms import stale_notes

    notes = stale_notes([s])
    return notes[0][1] if notes else None


def forecast_json(s: dict[str, Any]) -> dict[str, Any]:
    """The JSON document of ``track forecast``."""

    def iso(t: datetime | None) -> str | None:
        # the store keeps naive UTC: say so in the string (ISO 8601 with +00:00)
        if t is None:
            return None
        return (t.astimezone(UTC) if t.tzinfo is not None else t.replace(tzinfo=UTC)).isoformat()

    tr = s["trend"]
    si = gap_unit(s.get("kind")).si  # rad, or m on a linear axis (the *_rad keys keep their names)
    return {
        "axis": s["axis"],
        "time_zone": "UTC",
        "axis_kind": s.get("kind", "rotary"),
        "si_unit": si,
        "threshold_rad": s["threshold_rad"],
        "recordings": s["recordings"],
        "used": s["used"],
        "unexcited": s["unexcited"],
        "unconverged": s["unconverged"],
        "unconverged_used": s["unconverged_used"],
        "failed": s["failed"],
        "outliers": s["outliers"],
        "last_recording": iso(s["last_recording"]),
        "judged_at": iso(s.get("judged_at")),
        "current_rad": s["current_rad"],
        "noise_rad": s["noise_rad"],
        "model": s["model"],
        "params": s["params"],
        "params_units": f"a, J* [{si}]; b, v [{si}/day]; k [1/day]; t in days since t0",
        "t0": iso(tr.t0),
        "aicc": s["aicc"],
        "crossed": s["crossed"],
        "crossing": iso(s["crossing"]),
        "crossing_90": [
            iso(s["crossing_early"]),
            None if s["crossing_late_never"] else iso(s["crossing_late"]),
        ],
        "crossing_90_late_never": s["crossing_late_never"],
        "days_to_threshold": s["days_to_threshold"],
        "stale": _stale(s),
        "unmatched": s.get("unmatched", 0),
        "future": s.get("future", 0),
        "notes": s.get("notes", []),
        "change_points": [{"time": iso(c["time"]), "size_rad": c["size_rad"]} for c in s["change_points"]],
        "alarms": [
            {"kind": a.kind, "message": a.message, "data_time": iso(a.data_time)} for a in s["alarms"]
        ],
        "estimates": [
            {
                "time": iso(r["start_time"]),
                "path": r["path"],
                "status": r["status"],
                "delta_rad": r["delta"],
                "delta_std_rad": r["delta_std"],
                "excitation_ok": r["excitation_ok"],
                "converged": r["converged"],
                "reason": r["reason"],
                "sample_rate_hz": r["sample_rate_hz"],
                "estimate_rate_hz": r["estimate_rate_hz"],
            }
            for r in s["rows"]
        ],
    }


def _read_inputs(db: str, fleet: Any) -> list[Path | None]:
    """The files a report of the store reads: the store's SQLite file and the fleet file (no
    output may be written over them, ``--force`` or not)."""
    from drivelash.wear.store import store_file

    return [store_file(db), None if fleet is None else fleet.path]


def run_forecast(
    axis: str,
    db: str,
    json_out: str | None = None,
    quiet: bool = False,
    fleet: Any = None,
    force: bool = False,
) -> dict[str, Any]:
    """Body of ``track forecast``; returns the JSON document (``fleet``: as in :func:`run_status`;
    an axis of the store that ``fleet`` does not name is a one-line error; ``force``: replace an
    existing ``--json`` file that is not this command's output, as every other command's
    ``--force``)."""
    from drivelash.io.outputs import JSON_EXTENSIONS, Outputs, dumps_json, write_json
    from drivelash.wear.alarms import axis_summary, judged_axes
    from drivelash.wear.store import Store

    with Outputs("track forecast", inputs=_read_inputs(db, fleet), force=force) as out:
        target = (
            out.file(json_out, option="--json", kinds=JSON_EXTENSIONS)
            if json_out not in (None, "-")
            else None
        )
        store = Store(db, create=False)
        try:
            with store.guard(_READ_ONLY):
                if fleet is not None and axis in {x.name for x in fleet.axes}:
                    if axis not in {x["name"] for x in store.axes()}:
                        # a new or renamed axis of the fleet file: "no axis …; did you mean
                        # <its old name>?" read as a typo
                        raise DrivelashError(
                            f"{fleet.path}: axis {axis!r} is in this fleet file but not in the store "
                            f"{store.name} yet: nothing to forecast before the next "
                            "`drivelash track ingest` (a renamed axis starts a new history)"
                        )
                store.axis_id(axis)
                a = next((x for x in judged_axes(store, fleet) if x["name"] == axis), None)
                if a is None:
                    raise DrivelashError(
                        f"{fleet.path}: axis {axis!r} is in the store but not in this fleet file: its "
                        f"history is kept, not shown; without --fleet (--db {store.name}) it is forecast "
                        "with the thresholds stored at its last ingest"
                    )
                s = axis_summary(store, a)
        finally:
            store.close()
        doc = forecast_json(s)
        if target is not None:
            write_json(out.staging(target), doc)
    if json_out == "-":
        typer.echo(dumps_json(doc))
    elif not quiet:
        _print_forecast(s)
    return doc


def _print_forecast(s: dict[str, Any]) -> None:
    from rich.console import Console
    from rich.markup import escape

    from drivelash.wear.words import count, not_excited_reasons

    c = Console()
    u = gap_unit(s.get("kind"))  # mrad, or µm on a linear axis
    mr = lambda x: "–" if x is None or not math.isfinite(x) else u.f(x, ".3f")  # noqa: E731
    day = lambda t: t.strftime("%Y-%m-%d %H:%M UTC") if t is not None else "–"  # noqa: E731
    conv = ""
    if s.get("unconverged"):
        conv = (
            f", {s['unconverged']} excited but not converged ({s['unconverged_used']} of them in the trend, "
            "weighted by their uncertainty)"
        )
    unfitted = s["trend"].unfitted if s.get("trend") is not None else None
    fit = (
        f"{s['used'] - s['outliers']} in the fit ({count(s['outliers'], 'outlier')} left out; "
        if s["model"]
        else f"none fitted: {s.get('min_points', 5)} needed for a trend ("
        if unfitted is None
        else f"none fitted: {unfitted} ("  # the note below says why (F2)
    )  # "3 in the fit … model: none" contradicted itself (session 30 tester B, B-08)
    c.print(
        f"[bold]{s['axis']}[/bold]: {s['used']} of {count(s['recordings'], 'recording')} usable, "
        f"{fit}{s['unexcited']} not excited{conv}, {s['failed']} failed)"
    )
    why = not_excited_reasons(s["rows"])
    if why is not None:
        c.print(f"  not excited: {escape(why)}")
    model = s["model"] or ("none (too few estimates)" if unfitted is None else "none")
    c.print(
        f"  threshold {mr(s['threshold_rad'])}; fitted now {mr(s['current_rad'])} "
        f"(noise {mr(s['noise_rad'])}); model: {model}"
    )
    if s.get("latest_rad") is not None:
        sd = s.get("latest_std")
        pm = f" ± {u.n(sd, '.3f')}" if sd is not None and math.isfinite(sd) else ""
        when = day(s["latest_time"])
        c.print(f"  latest estimate {u.n(s['latest_rad'], '.3f')}{pm} {u} ({when}), no trend yet")
    if s["crossed"]:
        c.print(f"  [red]threshold crossed[/red] (fitted trend reached it {day(s['crossing'])})")
    elif s["crossing"] is not None:
        late = "never" if s["crossing_late_never"] else day(s["crossing_late"])
        c.print(
            f"  forecast crossing {day(s['crossing'])} ({s['days_to_threshold']:.1f} days after the "
            f"last recording), 90 % interval {day(s['crossing_early'])} … {late}"
        )
        stale = _stale(s)
        if stale:  # as status and report say it: the crossing has passed with no data since
            c.print(f"  [yellow]stale[/yellow]: {escape(stale)}")
    elif s["model"] is not None:
        c.print("  no crossing forecast: the trend does not reach the threshold within the look-ahead")
    for cp in s["change_points"]:
        c.print(f"  jump of {u.f(cp['size_rad'], '+.2f')} at {day(cp['time'])}")
    for n in s.get("notes", []):
        c.print(f"  [yellow]note[/yellow] {escape(n)}")
    for a in s["alarms"]:
        c.print(f"  [red]alarm[/red] {escape(a.kind)}: {escape(a.message)}")


def run_report(
    db: str,
    out_path: Path,
    force: bool = False,
    quiet: bool = False,
    label: str | None = None,
    fleet: Any = None,
) -> Path:
    """Body of ``track report``; returns the written path (``label`` as in :func:`run_status`)."""
    from drivelash.io.outputs import HTML_EXTENSIONS, Outputs
    from drivelash.report.fleet import render_fleet_report, write_fleet_report
    from drivelash.wear.words import count

    with Outputs("track report", inputs=_read_inputs(db, fleet), force=force) as out:
        target = out.file(out_path, option="-o", kinds=HTML_EXTENSIONS)
        store, summ, note = _summaries(db, fleet)
        try:
            meas: dict[str, list[dict[str, Any]]] = {}
            with store.guard(_READ_ONLY):
                for m in store.measurements():
                    meas.setdefault(m["axis"], []).append(m)
        finally:
            store.close()
        text = render_fleet_report(
            summ,
            meas,
            title="drivelash fleet wear report",
            store=label or store.name,
            notes=([note] if note else []) + [n for s in summ for n in s.get("notes", [])],
        )
        assert target is not None
        write_fleet_report(out.staging(target), text)
    if not quiet:
        typer.echo(f"wrote {out_path} ({count(len(summ), 'axis', 'axes')})")
        if note is not None:
            typer.echo(f"note: {note}")
    return out_path


def run_simulate_fleet(
    out: Path,
    machines: int,
    axes: int,
    recordings: int,
    seed: int,
    duration: float,
    workers: int,
    force: bool = False,
) -> Any:
    """Body of ``simulate fleet``."""
    from rich.progress import BarColumn, MofNCompleteColumn, TextColumn

    from drivelash._progress import stderr_progress
    from drivelash.io.outputs import Outputs
    from drivelash.sim.fleet import simulate_fleet

    bar = stderr_progress(TextColumn("simulating fleet"), BarColumn(), MofNCompleteColumn())
    with Outputs("simulate fleet", force=force) as o, bar:
        task = bar.add_task("sim", total=machines * axes * recordings)
        target = o.directory(out, option="-o")
        assert target is not None
        plan = simulate_fleet(
            o.staging(target),
            machines,
            axes,
            recordings,
            seed,
            duration=duration,
            workers=workers,
            progress=lambda d, t: bar.update(task, completed=d),
        )
    typer.echo(
        f"{plan.recordings} recordings ({plan.unexcited} unexcited, {plan.corrupt} corrupt) of "
        f"{machines * axes} axes -> {out}; inventory {out / 'fleet.toml'}, truth {out / 'truth.json'}"
    )
    return plan


def register(app: typer.Typer, te_app: typer.Typer) -> None:
    """Add the ``track`` group to the CLI."""
    app.add_typer(track_app, name="track")

    db_help = "Store: SQLAlchemy URL or SQLite file (default: the fleet's [fleet] db, else ./wear.sqlite)."

    @track_app.command("ingest")
    def ingest_cmd(
        fleet: Path = typer.Argument(..., help="The fleet inventory (fleet.toml)."),
        db: str | None = typer.Option(None, "--db", help=db_help),
        workers: int | None = typer.Option(None, "--workers", help="Worker processes (default: CPU count)."),
        dask: str | None = typer.Option(
            None, "--dask", help="Run on Dask: 'local' (a LocalCluster) or a scheduler address."
        ),
    ) -> None:
        """Estimate every new recording of the fleet and store it (idempotent, resumable).

        Recordings that cannot be read are stored as failed with their reason; the exit
        status is then 2 (after everything else is stored).
        """
        from drivelash.wear.words import count

        rep = run_ingest(fleet, db, workers, dask)
        if rep.failed:
            raise DrivelashError(
                f"{rep.failed} of {count(rep.planned, 'recording')} failed "
                "(stored as failed with their reasons above)"
            )

    @track_app.command("status")
    def status_cmd(
        db: str | None = typer.Option(None, "--db", help=db_help),
        fleet: Path | None = typer.Option(
            None, "--fleet", help="Take the store and the current thresholds from this fleet.toml."
        ),
    ) -> None:
        """Table of the axes, soonest forecast threshold crossing first, with active alarms."""
        url, f = _store_location(db, fleet)
        run_status(url, fleet=f)

    @track_app.command("forecast")
    def forecast_cmd(
        axis: str = typer.Argument(..., help="machine/axis"),
        db: str | None = typer.Option(None, "--db", help=db_help),
        fleet: Path | None = typer.Option(
            None, "--fleet", help="Take the store and the current thresholds from this fleet.toml."
        ),
        json_out: str | None = typer.Option(
            None, "--json", help="Write the forecast as JSON here ('-': stdout)."
        ),
        force: bool = typer.Option(
            False, "--force", help="Replace an existing file that is not a drivelash output."
        ),
    ) -> None:
        """Trend, growth model and forecast threshold crossing (90 % interval) of one axis."""
        url, f = _store_location(db, fleet)
        run_forecast(axis, url, json_out, fleet=f, force=force)

    @track_app.command("report")
    def report_cmd(
        out: Path = typer.Option(..., "-o", "--out", help="HTML report to write."),
        db: str | None = typer.Option(None, "--db", help=db_help),
        fleet: Path | None = typer.Option(
            None, "--fleet", help="Take the store and the current thresholds from this fleet.toml."
        ),
        force: bool = typer.Option(
            False, "--force", help="Replace an existing file that is not a drivelash output."
        ),
    ) -> None:
        """Write the self-contained HTML fleet report (overview, alarms, trend per axis)."""
        url, f = _store_location(db, fleet)
        run_report(url, out, force=force, fleet=f)
