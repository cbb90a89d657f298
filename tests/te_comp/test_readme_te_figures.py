"""README.md quotes every TE figure exactly as :mod:`readme_figures` asserts it (fast).

The slow counterpart measures each figure; this check makes a README edit that is not
carried into the asserted table (or the reverse) fail at once.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from .readme_figures import FIGURES, OTHER_CPU_MEASURED, REFERENCE_CPU_VENDOR, cpu_vendor, on_reference_cpu

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


def test_other_cpu_figures_name_asserted_figures_and_the_readme_says_so():
    """The figures measured on a non-reference CPU (the slow checks' known-miss reason) are figures
    of the table, at least one of them outside its tolerance (else there is no miss to mark), and
    README.md names the CPU dependence with that CPU's measured held-out and 3500–5000 N MAE."""
    assert set(OTHER_CPU_MEASURED) <= set(FIGURES)
    assert any(abs(v - FIGURES[k][0]) > FIGURES[k][1] for k, v in OTHER_CPU_MEASURED.items())
    text = _normalise(README.read_text(encoding="utf-8"))
    for k in ("heldout_mae_um", "extrapolation_mae_um"):
        assert f"{OTHER_CPU_MEASURED[k]:g} µm" in text, k


def test_cpu_vendor_is_read_on_linux():
    """The slow checks' marker depends on the vendor: it must be read, not silently empty."""
    import platform

    if platform.system() != "Linux" or platform.machine() not in ("x86_64", "AMD64"):
        pytest.skip(f"no /proc/cpuinfo vendor on {platform.system()} {platform.machine()}")
    assert cpu_vendor() in ("GenuineIntel", "AuthenticAMD", "HygonGenuine"), cpu_vendor()
    assert on_reference_cpu() == (cpu_vendor() == REFERENCE_CPU_VENDOR)
