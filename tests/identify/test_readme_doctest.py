"""The README's Python examples run as doctests (issue 11 item 6): if the README says it, it runs."""

from __future__ import annotations

import doctest
import os

from identify.helpers import REPO


def test_readme_python_examples(monkeypatch):
    monkeypatch.chdir(REPO)  # the examples use repository-relative paths (examples/…)
    res = doctest.testfile(
        str(REPO / "README.md"),
        module_relative=False,
        optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE,
        verbose=False,
    )
    assert res.attempted >= 6, res  # negative control: the examples were found and run
    assert res.failed == 0, res
    assert os.getcwd() == str(REPO)
