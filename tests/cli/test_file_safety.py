"""File safety of the commands, as a user who distrusts tools with their files finds it.

Each test drives the CLI in-process on a failure a user meets (a full disk, an interrupted
run, a re-run over an earlier output) and asserts the one-line message, exit code 2 and
that the user's files are byte for byte as they were.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

import numpy as np
import pytest
from tests.cli_runner import run_in_process

from drivelash.io import Trace, write_trace


def _tree(d: Path) -> dict[str, bytes]:
    """Every file under ``d`` (hidden ones included) with its content."""
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


def _old_recording(path: Path) -> None:
    t = np.arange(400) * 125e-6
    cols = {"t": t, "theta_m": np.sin(t), "omega_m": np.cos(t), "torque_m": np.cos(3 * t)}
    write_trace(Trace(cols, {"scenario": "old"}), path)


def test_full_disk_while_writing_is_one_line_and_keeps_the_old_file(tmp_path, capsys, monkeypatch):
    """``simulate -o old.csv`` on a full disk: was a traceback (OSError ENOSPC out of the writer)."""
    from drivelash.io.trace import Trace as TraceClass

    target = tmp_path / "old.csv"
    _old_recording(target)
    before = _tree(tmp_path)

    def half_then_full(self, path, *a, **k):  # the writer gets some bytes out, then the disk is full
        Path(path).write_bytes(b"# drivelash.meta {}\nt,theta_m\n0,")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(TraceClass, "to_csv", half_then_full)
    code, _, err = run_in_process(["simulate", "bench-0B", "-o", "old.csv", "--duration", "0.01"], capsys)
    assert code == 2, err
    assert err.strip().splitlines() == [
        "drivelash: error: -o old.csv: cannot write it: No space left on device; "
        "the existing files were left as they were"
    ]
    assert _tree(tmp_path) == before  # the old recording byte for byte, no temporary file left


def test_a_path_component_too_long_is_one_line_for_outputs_and_inputs(tmp_path, capsys, monkeypatch):
    """A directory name of 260 bytes: ``simulate -o LONG/x.csv`` and ``estimate LONG.csv`` ended in
    a traceback (ENAMETOOLONG out of ``Path.exists``, which only hides ENOENT-like errors)."""
    config = Path(__file__).resolve().parents[2] / "examples" / "drive_bench.toml"
    long = "a" * 260
    monkeypatch.chdir(tmp_path)
    code, _, err = run_in_process(
        ["simulate", "bench-0B", "-o", f"{long}/x.csv", "--duration", "0.01"], capsys
    )
    assert code == 2 and err.strip().splitlines() == [
        f"drivelash: error: -o {long}/x.csv: File name too long"
    ]
    code, _, err = run_in_process(["estimate", f"{long}.csv", "-c", str(config)], capsys)
    assert code == 2 and err.strip().splitlines() == [f"drivelash: error: {long}.csv: File name too long"]
    assert os.listdir(tmp_path) == []


def test_the_fleet_report_writer_called_as_a_library_keeps_an_existing_file(tmp_path, monkeypatch):
    """``write_fleet_report(path, …)`` outside a command wrote straight into ``path``: a failed
    write (full disk) left the previous report truncated. Now atomically, as every other
    report writer (``drivelash.report._write``); ``write_iso230_report`` uses the same."""
    from drivelash.report.fleet import write_fleet_report

    target = tmp_path / "fleet.html"
    target.write_text("<html>the report of last week</html>\n", encoding="utf-8")
    real = Path.write_text

    def half_then_full(self, data, *a, **k):
        real(self, data[:10], *a, **k)
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(Path, "write_text", half_then_full)
    with pytest.raises(OSError):
        write_fleet_report(target, "<html>new</html>\n")
    monkeypatch.undo()
    assert target.read_text(encoding="utf-8") == "<html>the report of last week</html>\n"
    assert os.listdir(tmp_path) == ["fleet.html"]
    write_fleet_report(target, "<html>new</html>\n")
    assert target.read_text(encoding="utf-8") == "<html>new</html>\n"


def test_simulate_through_a_symlinked_output_keeps_the_link(tmp_path, capsys):
    """``simulate -o latest.csv`` where latest.csv → runs/old.csv: runs/old.csv gets the new
    recording, latest.csv stays the same link (was: replaced by a regular file, the run's file
    left old). A dangling link is refused in one line (it may point into an unmounted share),
    nothing is created."""
    from drivelash.io import load_trace

    runs = tmp_path / "runs"
    runs.mkdir()
    _old_recording(runs / "old.csv")
    link = tmp_path / "latest.csv"
    link.symlink_to("runs/old.csv")
    code, _, err = run_in_process(["simulate", "bench-0A", "-o", str(link), "--duration", "0.2"], capsys)
    assert code == 0, err
    assert link.is_symlink() and os.readlink(link) == "runs/old.csv"
    assert load_trace(runs / "old.csv").duration == pytest.approx(0.2, abs=1e-3)
    assert sorted(os.listdir(tmp_path)) == ["latest.csv", "runs"] and os.listdir(runs) == ["old.csv"]

    dangling = tmp_path / "gone.csv"
    dangling.symlink_to("elsewhere/x.csv")
    code, _, err = run_in_process(["simulate", "bench-0A", "-o", str(dangling), "--duration", "0.2"], capsys)
    assert code == 2 and err.splitlines() == [
        f"drivelash: error: -o {dangling}: a symbolic link to elsewhere/x.csv, which does not exist;"
        " use --force to replace it or choose another path"
    ], err
    assert dangling.is_symlink() and not (tmp_path / "elsewhere").exists()
