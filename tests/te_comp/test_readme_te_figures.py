"""README.md quotes every TE figure exactly as :mod:`readme_figures` asserts it (fast).

The slow counterpart measures each figure; this check makes a README edit that is not
carried into the asserted table (or the reverse) fail at once.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from .readme_figures import FIGURES

README = Path(__file__).resolve().parents[2] / "README.md"


def _normalise(text: str) -> str:
    return re.sub(r"\s+", " ", text)


@pytest.mark.parametrize("name", sorted(FIGURES))
def test_readme_quotes_the_asserted_figure(name):
    _, _, snippet = FIGURES[name]
    assert _normalise(snippet) in _normalise(README.read_text(encoding="utf-8")), snippet


def test_every_quoted_value_appears_in_its_snippet():
    for name, (value, tol, snippet) in FIGURES.items():
        digits = max(0, -int(f"{tol:e}".split("e")[1]) - 1) if tol < 1 else 0
        shown = f"{value:.{digits}f}"
        assert shown in snippet or f"{value:g}" in snippet, (name, shown, snippet)
