"""Every ``--help`` prints the bracketed words its text contains (TOML tables, units).

typer renders help with Rich markup, which took ``[drivetrain]`` or ``[mm]`` for style tags and
dropped them: ``drivelash identify --help`` read "write / TOML" for "write [drivetrain]/[backlash]
TOML", and option help lost its units. ``drivelash.cli`` escapes the markup once.
"""

from __future__ import annotations

import re

import pytest
import typer
from tests.cli_runner import run_in_process

from drivelash.cli import app

TOKEN = re.compile(r"\[[A-Za-z_][^\]\s]*\]")


def _walk(cmd, path=()):
    yield path, cmd
    for name, sub in sorted(getattr(cmd, "commands", {}).items()):
        yield from _walk(sub, (*path, name))


def _tokens(cmd) -> set[str]:
    texts = [cmd.help or ""] + [getattr(p, "help", None) or "" for p in cmd.params]
    return {t for text in texts for t in TOKEN.findall(text)}


CASES = [(path, sorted(_tokens(cmd))) for path, cmd in _walk(typer.main.get_command(app)) if _tokens(cmd)]


def test_some_help_texts_have_bracketed_words():
    """The check below has something to check (identify names its TOML tables)."""
    assert ("identify",) in [path for path, _ in CASES]
    assert len(CASES) >= 5


@pytest.mark.parametrize("path,tokens", CASES, ids=[" ".join(p) for p, _ in CASES])
def test_help_prints_its_bracketed_words(path, tokens, capsys):
    code, out, err = run_in_process([*path, "--help"], capsys)
    assert code == 0, err
    flat = " ".join(out.replace("│", " ").split())
    missing = [t for t in tokens if t not in flat]
    assert not missing, f"drivelash {' '.join(path)} --help lost {missing}"


def test_negative_control_unescaped_rich_help_drops_them():
    """Rendered without the escaping (typer's own runner on the raw app), the words vanish."""
    from typer.testing import CliRunner

    res = CliRunner().invoke(app, ["identify", "--help"], terminal_width=100)
    assert res.exit_code == 0
    assert "[drivetrain]" not in res.output and "write" in res.output
