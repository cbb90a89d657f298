"""The in-process CLI runner shows what the console script's user sees, warnings included."""

from __future__ import annotations

import warnings

from cli_runner import run_in_process


def test_a_warning_the_command_emits_is_on_stderr_like_the_console_script(monkeypatch, capsys):
    """A UserWarning lands on stderr (so "stderr is one line" checks see it); a library's
    DeprecationWarning does not (a fresh interpreter ignores it) — negative control."""
    import drivelash.cli as cli

    def command():
        def run(args, prog_name, standalone_mode):
            print("out")
            warnings.warn("a stray warning", UserWarning, stacklevel=1)
            warnings.warn("an old API", DeprecationWarning, stacklevel=1)
            return 0

        return run

    monkeypatch.setattr(cli, "_click_command", command)
    print("printed before the call")
    code, out, err = run_in_process(["anything"], capsys)
    assert code == 0 and out == "out\n"
    assert "UserWarning: a stray warning" in err
    assert "an old API" not in err
