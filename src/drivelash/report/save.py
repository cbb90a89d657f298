"""``save_figure``: write a matplotlib figure with the drivelash signature in its metadata."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from drivelash.io.outputs import PLOT_EXTENSIONS, final_suffix, signature, write_target

#: The metadata key each format carries the signature in (see ``io.outputs.is_own_output``).
_META_KEY = {".png": "Software", ".pdf": "Creator", ".svg": "Creator"}


def save_figure(fig: Any, path: str | Path, *, dpi: int = 110, **kwargs: Any) -> Path:
    """Save ``fig`` to ``path`` (a staging path or a plain one) with our signature.

    The format comes from the final name (so ``Outputs.staging`` paths work); the
    signature ``drivelash <version> <command>`` (:func:`~drivelash.io.outputs.signature`)
    goes into the PNG ``Software`` text chunk, the PDF
    ``Creator`` or the SVG ``dc:creator``, which is how a later run recognises the file
    as its own output.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure (not closed here).
    path : str or Path
        Output path; its final extension must be one of :data:`PLOT_EXTENSIONS`.
    dpi : int
        Resolution of raster output.
    **kwargs
        Passed to :meth:`matplotlib.figure.Figure.savefig`.

    Raises
    ------
    ValueError
        An extension not in :data:`PLOT_EXTENSIONS`.
    """
    p = Path(path)
    ext = final_suffix(p)
    if ext not in PLOT_EXTENSIONS:
        raise ValueError(f"{p}: unsupported plot extension {ext!r} (use {', '.join(PLOT_EXTENSIONS)})")
    meta = {_META_KEY[ext]: signature(p)}
    with write_target(p) as w:
        fig.savefig(w, format=ext[1:], dpi=dpi, metadata=meta, **kwargs)
    return p
