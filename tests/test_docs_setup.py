"""The README's set-up section matches the files that do the set-up: the Python version
(pyproject.toml), the pinned PyTorch (requirements.lock) and every `make` target it names."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")


def make_targets(makefile: str) -> set[str]:
    """Target names defined in ``makefile`` (lines ``name: …``, variables excluded).

    Parameters
    ----------
    makefile : str
        Text of a Makefile.

    Returns
    -------
    set of str
    """
    return set(re.findall(r"(?m)^([a-z][a-z0-9-]*):(?!=)", makefile))


def test_python_version_and_torch_pin_are_those_of_the_project_files():
    py = re.search(r"Python ≥ (\d+\.\d+)", README)
    torch = re.search(r"`torch==([^`]+)`", README)
    assert py and torch, "README no longer states the Python version or the torch pin"
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    assert meta["project"]["requires-python"] == f">={py.group(1)}"
    lock = (ROOT / "requirements.lock").read_text(encoding="utf-8").splitlines()
    assert f"torch=={torch.group(1)}" in lock


def test_every_make_target_the_readme_names_exists():
    named = set(re.findall(r"`?make ([a-z][a-z0-9-]*)", README))
    assert {"demo", "test", "bench", "test-slow", "lint"} <= named  # the extraction still works
    have = make_targets((ROOT / "Makefile").read_text(encoding="utf-8"))
    assert named - have == set()
    # negative control: a variable assignment is not a target, a rule is
    assert make_targets("PY := x\nfoo: bar\n\tcmd\n") == {"foo"}
