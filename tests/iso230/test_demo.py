"""The demo step and the example configuration it uses."""

from __future__ import annotations

import json

from rich.console import Console

from drivelash.iso230.demo import DEMO_RUNS, DEMO_TARGETS, demo_iso230


def test_demo_step_writes_json_and_report(tmp_path):
    console = Console(record=True, width=300)
    demo_iso230(tmp_path, console)
    s = json.loads((tmp_path / "iso230.json").read_text())
    assert s["dwells"]["count"] == 2 * DEMO_TARGETS * DEMO_RUNS
    assert (tmp_path / "iso230.html").read_text().count("data:image/png;base64,") == 4
    assert "dwells found" in console.export_text()
