"""What the README and docs/ tell a user to type exists: every ``drivelash …`` command line in
their code spans and blocks names real commands and options, and every ``drivelash.x.y`` name
they cite imports (a renamed option or module must take its documentation along)."""

from __future__ import annotations

import importlib
import re
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = ("README.md", "docs/te-formats.md", "docs/scaling.md")

_BLOCK = re.compile(r"```[a-z]*\n(.*?)```", re.S)
_OPTION = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*")
_NAME = re.compile(r"\bdrivelash(?:\.[A-Za-z_]\w*)+\b(?![/\w-])")


def command_lines(text: str, commands: frozenset[str] = frozenset()) -> list[str]:
    """Every ``drivelash …`` command line in the code spans and code blocks of ``text``.

    Parameters
    ----------
    text : str
        Markdown.
    commands : frozenset of str
        The top-level command names: a span written without the program name (``te export M
        -o X.ini [--axis X1]``, ``estimate --identify``) counts as a command line too.

    Returns
    -------
    list of str
        One entry per span or block line that starts with ``drivelash`` (a block's
        continuation lines joined).
    """
    blocks = _BLOCK.findall(text)
    spans = _BLOCK.sub("", text).split("`")[1::2]
    pieces = [" ".join(s.split()) for s in spans]
    for b in blocks:
        pieces += [" ".join(c.split()) for c in re.split(r"\n(?=drivelash )", b.replace("\\\n", " "))]
    out = [p for p in pieces if re.match(r"drivelash [a-z]", p)]
    return out + [f"drivelash {p}" for p in pieces if p.split(" ")[0] in commands and " " in p]


def problems(line: str, root: Any) -> list[str]:
    """What in one command line the CLI does not have: an unknown subcommand or option.

    Parameters
    ----------
    line : str
        ``drivelash WORDS … [--OPTION …]``.
    root : click.Group
        The ``drivelash`` command.

    Returns
    -------
    list of str
        One entry per problem; empty when the command and all its options exist.
    """
    words = re.findall(r"[^\s/\[\]|]+", line)[1:]
    cmd, path = root, ["drivelash"]
    for w in words:
        subs = getattr(cmd, "commands", None)
        if not subs:
            break
        if w not in subs:
            if re.fullmatch(r"[a-z][a-z0-9-]*", w):
                return [f"{' '.join(path)}: no command {w!r} (in {line!r})"]
            break
        cmd, path = subs[w], [*path, w]
    if getattr(cmd, "commands", None):
        return []  # a group named on its own ("drivelash track status/forecast/report")
    known = {o for p in cmd.params for o in (*p.opts, *getattr(p, "secondary_opts", ()))}
    return [f"{' '.join(path)}: no option {o} (in {line!r})" for o in _OPTION.findall(line) if o not in known]


def _resolve(name: str) -> Any:
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for attr in parts[i:]:
            obj = getattr(obj, attr)
        return obj
    raise ImportError(name)


@pytest.fixture(scope="module")
def root() -> Any:
    from drivelash.cli import _click_command

    return _click_command()


@pytest.mark.parametrize("doc", DOCS)
def test_every_command_and_option_the_docs_name_exists(doc, root):
    lines = command_lines((ROOT / doc).read_text(encoding="utf-8"), frozenset(root.commands))
    assert lines, f"{doc}: no drivelash command line found (the extraction broke)"
    bad = [p for line in lines for p in problems(line, root)]
    assert bad == []


def test_the_command_check_sees_a_wrong_option_and_command(root):
    """Negative control: a renamed option, a misspelt command, an option of another command."""
    text = (
        "`drivelash estimate run.parquet --config c.toml [--jsonn out.json]` and\n"
        "```sh\ndrivelash te fitt CAMP -o M\ndrivelash te export M -o x.ini \\\n    --stride 2\n```\n"
        "`drivelash te update M P -o N [--stage trees|both] [--accept-worse]`, "
        "`te validate M -o D [--campaign C]` and `track forecast AXIS [--csv P]`"
    )
    lines = command_lines(text, frozenset(root.commands))
    assert len(lines) == 6
    found = [p for line in lines for p in problems(line, root)]
    assert [f.split(" (in ")[0] for f in found] == [
        "drivelash estimate: no option --jsonn",
        "drivelash te: no command 'fitt'",
        "drivelash te export: no option --stride",
        "drivelash track forecast: no option --csv",
    ]


@pytest.mark.parametrize("doc", DOCS)
def test_every_drivelash_name_the_docs_cite_imports(doc):
    names = sorted(set(_NAME.findall((ROOT / doc).read_text(encoding="utf-8"))))
    bad = []
    for n in names:
        try:
            _resolve(n)
        except (ImportError, AttributeError) as exc:
            bad.append(f"{n}: {exc}")
    assert bad == []


def test_the_name_check_sees_a_missing_name():
    """Negative control: a name that is not there fails, a format id (``drivelash.te_campaign/1``)
    is not taken for a module."""
    assert _NAME.findall("`drivelash.te.runtime.no_such` and `drivelash.te_campaign/1`") == [
        "drivelash.te.runtime.no_such"
    ]
    with pytest.raises(AttributeError):
        _resolve("drivelash.te.runtime.no_such")
    assert callable(_resolve("drivelash.te.runtime.build_table"))


def test_tour_paths_are_relative_to_the_repository_root(tmp_path, monkeypatch, capsys):
    """README's Tour: its ``examples/…`` paths work from the repository root; from elsewhere the
    relative path is refused in one line naming the file, the full path works."""
    from tests.cli_runner import run_in_process

    assert "The commands below run from the repository root" in (ROOT / "README.md").read_text()
    monkeypatch.chdir(tmp_path)
    code, _, _ = run_in_process(["simulate", "bench-0A", "-o", "run.parquet", "--duration", "4"], capsys)
    assert code == 0
    rel = "examples/drive_bench.toml"
    code, out, err = run_in_process(["estimate", "run.parquet", "--config", rel], capsys)
    assert code == 2 and "Traceback" not in err
    assert "examples/drive_bench.toml: no such configuration file" in err
    assert len(err.strip().splitlines()) == 1
    full = str(ROOT / "examples" / "drive_bench.toml")
    code, out, err = run_in_process(["estimate", "run.parquet", "--config", full], capsys)
    assert code == 0, err
    assert "converged" in out
