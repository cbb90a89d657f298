"""Self-contained HTML: inline CSS, PNG figures embedded as base64, no scripts, no network.

A report is a list of sections; each holds paragraphs, tables and figures. Figures
are rendered with matplotlib's Agg backend to PNG bytes; long reports render them
under a rich progress bar (on stderr, transient).
"""

from __future__ import annotations

import base64
import html
import io
import math
import os
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any

from drivelash.io.outputs import GENERATOR

_CSS = """
body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,sans-serif;margin:2em auto;max-width:1100px;
color:#1d232a;background:#fff;line-height:1.45;padding:0 1em}
h1{font-size:1.6em;border-bottom:2px solid #2a6fb0;padding-bottom:.2em}
h2{font-size:1.25em;margin-top:1.8em;color:#2a6fb0}
table{border-collapse:collapse;margin:.6em 0 1.2em 0;font-size:.92em}
th,td{border:1px solid #c9d3dd;padding:.25em .7em;text-align:right}
th{background:#eef3f8}td:first-child,th:first-child,td.t,th.t{text-align:left}
.nw{white-space:nowrap}
figure{margin:1em 0;text-align:center}figure img{max-width:100%;height:auto;border:1px solid #e3e8ee}
figcaption{font-size:.88em;color:#4b5966;margin-top:.3em}
.verdict-ok{color:#1f7a35;font-weight:600}.verdict-bad{color:#b03a2a;font-weight:600}
.warn{background:#fff6e0;border-left:4px solid #e0a400;padding:.4em .8em;margin:.4em 0}
footer{margin-top:3em;font-size:.8em;color:#7b8894}
"""


@dataclass
class Figure:
    """A figure to render: ``draw(fig)`` fills a matplotlib Figure of ``size`` inches."""

    key: str
    caption: str
    draw: Callable[[Any], None]
    size: tuple[float, float] = (10.0, 4.0)


@dataclass
class Section:
    """A report section: heading, paragraphs (already-escaped HTML allowed via ``raw``), tables, figures.

    Table cells are right-aligned (numbers; the first column left); with ``text_left`` the
    columns that hold text (:func:`_text_columns`: names, kinds, messages, dates) are
    left-aligned too — for tables whose columns are each text or numbers, not key/value
    tables that mix both in one column."""

    title: str
    paragraphs: list[str] = field(default_factory=list)
    tables: list[tuple[str, Sequence[str], Sequence[Sequence[Any]]]] = field(default_factory=list)
    figures: list[Figure] = field(default_factory=list)
    raw: list[str] = field(default_factory=list)
    text_left: bool = False


def png_bytes(fig_spec: Figure, dpi: int = 90) -> bytes:
    """Render one figure to PNG bytes (Agg backend, no display)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure as MplFigure

    fig = MplFigure(figsize=fig_spec.size, dpi=dpi, layout="constrained")
    fig_spec.draw(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, facecolor="white")
    return buf.getvalue()


def common_decimals(values: Sequence[float], max_nd: int = 6) -> int:
    """The fewest decimals (≤ ``max_nd``) that print every value as it rounds to ``max_nd``
    decimals: one column, one number of decimals ("0.0, 52.5, 100.0", not "0, 52.5, 100")."""
    for nd in range(max_nd + 1):
        if all(round(float(v), nd) == round(float(v), max_nd) for v in values):
            return nd
    return max_nd


def significant_decimals(values: Sequence[float], sig: int = 3) -> int:
    """Decimals that give the largest of ``values`` ``sig`` significant digits, for printing
    several values of one quantity alike ("17.0 / −24.2", not "17 / −24.2")."""
    big = max((abs(float(v)) for v in values if math.isfinite(float(v))), default=0.0)
    if big == 0.0:
        return sig - 1
    return max(0, sig - 1 - math.floor(math.log10(big)))


#: A date (and time) in a table cell: kept on one line (browsers break after its hyphens).
_DATE = re.compile(r"\d{4}-\d{2}-\d{2}(?: \d{2}:\d{2})?")


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        if v != v:  # NaN
            return "–"
        return f"{v:.6g}"
    return _DATE.sub(lambda m: f'<span class="nw">{m.group(0)}</span>', html.escape(str(v)))


#: A cell that reads as a number (right-aligned): 12, -0.5, 1.2e-3, 95 %, 1,024, 6/8; "–" is
#: no value and does not decide its column.
_NUMBER = re.compile(r"[-+−]?(\d[\d,]*\.?\d*|\.\d+)([eE][-+]?\d+)?( ?%)?|\d+/\d+|–|")


def _text_columns(rows: Sequence[Sequence[Any]]) -> set[int]:
    """Indices of the columns that read as text (left-aligned): those with a cell that is not a
    number (:data:`_NUMBER`) — names, kinds, messages, dates."""
    out: set[int] = set()
    for r in rows:
        for i, c in enumerate(r):
            if not isinstance(c, (int, float)) and not _NUMBER.fullmatch(str(c).strip()):
                out.add(i)
    return out


def _table(
    caption: str, header: Sequence[str], rows: Sequence[Sequence[Any]], text_left: bool = False
) -> str:
    text = _text_columns(rows) if text_left else set()

    def cell(tag: str, i: int, v: str) -> str:
        return f'<{tag} class="t">{v}</{tag}>' if i in text else f"<{tag}>{v}</{tag}>"

    head = "".join(cell("th", i, html.escape(str(h))) for i, h in enumerate(header))
    body = "".join("<tr>" + "".join(cell("td", i, _fmt(c)) for i, c in enumerate(r)) + "</tr>" for r in rows)
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    return f"<table>{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def generated_at() -> datetime:
    """The time a report states it was generated (UTC): now, or ``SOURCE_DATE_EPOCH``.

    ``SOURCE_DATE_EPOCH`` (reproducible-builds.org: whole seconds since 1970-01-01 UTC) makes
    a report byte-for-byte reproducible — two renders of one result otherwise differ when they
    straddle a minute.

    Returns
    -------
    datetime
        Time zone aware, UTC.

    Raises
    ------
    ParameterError
        ``SOURCE_DATE_EPOCH`` set but not whole seconds (the specification asks tools to fail).
    """
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    if epoch is None:
        return datetime.now(UTC)
    if not epoch.strip().isdigit():
        from drivelash.errors import ParameterError

        raise ParameterError(
            "environment", "SOURCE_DATE_EPOCH", f"must be whole seconds since 1970, got {epoch!r}"
        )
    return datetime.fromtimestamp(int(epoch), UTC)


def render_html(title: str, sections: Sequence[Section], *, progress: bool | None = None) -> str:
    """Assemble the report; renders every figure (progress bar when there are many).

    Parameters
    ----------
    title : str
        Page title and heading.
    sections : sequence of Section
        Content in order.
    progress : bool, optional
        Show a rich progress bar on stderr; default when more than 4 figures.
    """
    figs = [f for s in sections for f in s.figures]
    show = progress if progress is not None else len(figs) > 4
    images: dict[int, str] = {}
    if show:
        from drivelash._progress import stderr_progress

        with stderr_progress() as bar:
            task = bar.add_task("rendering figures", total=len(figs))
            for f in figs:
                images[id(f)] = base64.b64encode(png_bytes(f)).decode("ascii")
                bar.advance(task)
    else:
        for f in figs:
            images[id(f)] = base64.b64encode(png_bytes(f)).decode("ascii")
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f'<meta name="generator" content="{html.escape(GENERATOR)}">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>",
    ]
    for s in sections:
        parts.append(f"<section><h2>{html.escape(s.title)}</h2>")
        parts.extend(f"<p>{html.escape(p)}</p>" for p in s.paragraphs)
        parts.extend(s.raw)
        parts.extend(_table(*t, text_left=s.text_left) for t in s.tables)
        for f in s.figures:
            parts.append(
                f'<figure id="fig-{html.escape(f.key)}"><img class="figure" alt="{html.escape(f.caption)}"'
                f' src="data:image/png;base64,{images[id(f)]}">'
                f"<figcaption>{html.escape(f.caption)}</figcaption></figure>"
            )
        parts.append("</section>")
    stamp = generated_at().strftime("%Y-%m-%d %H:%M UTC")
    parts.append(
        f"<footer>drivelash report, generated {stamp}. Self-contained: no scripts, no network.</footer>"
    )
    parts.append("</body></html>")
    return "\n".join(parts)
