"""``te export --x-min`` typed in mm is named as ``--x-min`` with the valid range (finding A6).

Before (session 20, tester A): ``--x-min 60`` gave "te export.--x-max: range [60000, 445] mm is
empty" — the other option named, no valid range, no m/mm hint — because the empty-range check
ran before the valid-range check, which also only compared x_min with the lower end.
"""

from __future__ import annotations

import pytest

from cli_runner import run_in_process
from drivelash.te.runtime.persist import save_model


@pytest.fixture(scope="module")
def model_dir(small_trained, tmp_path_factory):
    return save_model(small_trained, tmp_path_factory.mktemp("xr") / "m")  # valid 0 ... 0.3 m


@pytest.mark.parametrize("suffix", [".ini", ".csv"])
@pytest.mark.parametrize(
    ("args", "option"), [(["--x-min", "60"], "--x-min"), (["--x-max", "250"], "--x-max")]
)
def test_a_position_in_mm_names_its_option_and_the_valid_range(
    model_dir, tmp_path, capsys, suffix, args, option
):
    out = tmp_path / f"t{suffix}"
    code, _, err = run_in_process(["te", "export", str(model_dir), "-o", str(out), *args], capsys)
    line = err.strip()
    assert code == 2 and not out.exists() and "\n" not in line, line
    assert f"te export.{option}:" in line and "leaves the model's valid range" in line, line
    assert "0, 0.3] m" in line or "[0.000, 300.000] mm" in line, line
    assert "--x-min and --x-max are in m" in line, line


def test_a_range_inside_is_written(model_dir, tmp_path, capsys):
    """Negative control: --x-min 0.1 --x-max 0.2 (m) is exported."""
    out = tmp_path / "t.ini"
    code, so, err = run_in_process(
        ["te", "export", str(model_dir), "-o", str(out), "--x-min", "0.1", "--x-max", "0.2"], capsys
    )
    assert code == 0 and out.exists(), err
