"""A stop (Ctrl-C / SIGTERM) raised inside library code that comes back as another error is
still an interruption: one line, exit 130 / 143, no traceback (session 32's clean-clone run:
Ctrl-C while numba compiled `quantise_scalar` — numba swallowed the Interrupted and its cache
then raised "RuntimeError: no compiled object yet", printed as a traceback with exit 1; the
timing-dependent case of tests/cli/test_signals.py, here made deterministic).
Negative control: the same error without a stop is a bug and keeps its traceback."""

from __future__ import annotations

import signal
import time

import pytest

import drivelash.cli as cli


def _command_that(stop: int | None):
    def run(*args, **kwargs):
        if stop is not None:  # what _on_signal records when it raises the stop into the command
            cli._Stop.raised_at, cli._Stop.raised_sig = time.monotonic(), stop
        raise RuntimeError("no compiled object yet for <Library 'quantise_scalar'>")

    return lambda: run


@pytest.mark.parametrize(
    ("sig", "code", "word"), [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")]
)
def test_an_error_after_a_stop_is_the_stop(monkeypatch, capsys, sig, code, word):
    monkeypatch.setattr(cli, "_click_command", _command_that(sig))
    with pytest.raises(SystemExit) as exc:
        cli.main(["simulate", "bench-0A", "-o", "x.parquet"])
    assert exc.value.code == code
    err = capsys.readouterr().err
    assert err.splitlines() == [f"drivelash: {word}; no output written"], err


def test_negative_control_the_error_without_a_stop_propagates(monkeypatch):
    monkeypatch.setattr(cli, "_click_command", _command_that(None))
    with pytest.raises(RuntimeError, match="no compiled object yet"):
        cli.main(["simulate", "bench-0A", "-o", "x.parquet"])
