"""build_table refuses what ``te export`` refuses — positions outside the measured range,
torques above the trained range (the model would extrapolate), oversized grids — with one
shared check worded for the API (the CLI's texts are unchanged); valid requests build the
same table as before. The exported header says what drivelash does beyond the grid."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from drivelash.cli import app
from drivelash.errors import ParameterError, ResourceError
from drivelash.te.runtime.export import export_table
from drivelash.te.runtime.table import DIRECTIONS, build_table

from .analytic import SineTE
from .test_cli import _mdir, stub_model  # noqa: F401 - the stubbed model loader fixture


class _Trained(SineTE):
    """A model trained on 0 … 0.5 m and torques up to 9 N·m."""

    class context:  # noqa: N801 - an attribute namespace like ModelContext
        class valid_range:  # noqa: N801
            x_min, x_max, torque_max = 0.0, 0.5, 9.0


def _one_line(err) -> str:
    msg = str(err.value)
    assert "\n" not in msg
    return msg


def test_torque_above_the_trained_range_is_refused():
    with pytest.raises(ParameterError) as err:
        build_table(_Trained(), 0.0, 0.5, 1e-3, 900.0, 5)
    assert _one_line(err) == (
        "build_table.torque_max: 900 N·m is above the model's valid torque range 0 ... 9 N·m (its"
        " training runs); the model would extrapolate — lower torque_max to at most the model's"
        " context.valid_range.torque_max"
    )
    with pytest.raises(ParameterError, match=r"^build_table.torque_min: -1 N·m is below the model's valid"):
        build_table(_Trained(), 0.0, 0.5, 1e-3, 9.0, 5, torque_min=-1.0)


def test_positions_outside_the_valid_range_are_refused_as_the_export_does():
    with pytest.raises(ParameterError) as err:
        build_table(_Trained(), -0.1, 0.5, 1e-3, 9.0, 3)
    assert _one_line(err) == (
        "build_table.x_min: [-0.1, 0.5] m leaves the model's valid range [0, 0.5] m"
        " (where its no-load runs of both directions were measured)"
    )
    with pytest.raises(ParameterError, match=r"^build_table.x_max: \[0, 0\.7\] m leaves"):
        build_table(_Trained(), 0.0, 0.7, 1e-3, 9.0, 3)


def test_an_oversized_grid_is_refused_before_anything_is_allocated():
    n_x, n_t = 25001, 401  # just over MAX_TABLE_POINTS per flank
    assert n_x * n_t > 10_000_000  # MAX_TABLE_POINTS (te export's limit since before)
    with pytest.raises(ResourceError) as err:
        build_table(_Trained(), 0.0, 0.5, 2e-5, 9.0, n_t)
    assert _one_line(err).startswith(
        f"build_table: 2.5e+04 positions x {n_t} torques x 2 flanks = 2.005e+07 values, more than 2e+07 ("
    )
    assert _one_line(err).endswith("GiB to build); raise dx or lower n_torque or torque_max")
    with pytest.raises(ResourceError, match=r"^build_table: 5e\+08 positions x 5 torques"):
        build_table(_Trained(), 0.0, 0.5, 1e-9, 9.0, 5)  # was a raw numpy MemoryError


def test_valid_request_builds_the_same_table():
    """Negative control: the grid and the values the old build_table sampled, bit for bit."""
    m = _Trained()
    tab = build_table(m, 0.1, 0.4, 1e-3, 9.0, 4)
    x = 0.1 + 1e-3 * np.arange(301)
    tq = np.linspace(0.0, 9.0, 4)
    for d, sgn in enumerate(DIRECTIONS):
        grid_t = tq if sgn == 1 else -tq[::-1]
        X, T = np.meshgrid(x, grid_t, indexing="ij")
        ref = np.asarray(m.predict(X.ravel(), T.ravel(), sgn)).reshape(301, 4)
        assert np.array_equal(tab.te[d].view(np.uint64), ref.view(np.uint64))
    # at the trained torque and over the whole range: accepted; a model without a range is unbounded
    assert build_table(m, 0.0, 0.5, 1e-3, 9.0, 3).te.shape == (2, 501, 3)
    assert build_table(SineTE(), 0.0, 1.0, 1e-3, 900.0, 3).te.shape == (2, 1001, 3)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (
            ["--torque-max", "1e9"],
            "te export.--torque-max: 1e+09 N·m is above the model's valid torque range 0 ... 9 N·m (its"
            " training runs); the model would extrapolate — leave --torque-max out or lower it",
        ),
        (
            ["--x-max", "0.7"],
            "te export.--x-max: [0, 0.7] m leaves the model's valid range [0, 0.5] m"
            " = [0.000, 500.000] mm (where its no-load runs of both directions were measured);"
            " --x-min and --x-max are in m (metres; --dx-mm and --step-mm are in mm)",
        ),
        (
            ["--dx-mm", "1e-4"],
            "te export: 5e+06 positions x 19 torques x 2 flanks = 1.9e+08 values, more than 2e+07"
            " (≈ 4.25 GiB to build); raise --dx-mm or --torque-step, or lower --torque-max",
        ),
    ],
)
def test_export_keeps_its_messages(tmp_path, stub_model, args, message):  # noqa: F811
    """The CLI calls build_table: the same refusals, its own texts (unchanged)."""
    out = tmp_path / "t.csv"
    r = CliRunner().invoke(app, ["te", "export", _mdir(tmp_path), "-o", str(out), *args])
    assert r.exit_code != 0
    assert str(r.exception) == message
    assert not out.exists()


@pytest.mark.parametrize("suffix", [".json", ".csv"])
def test_exported_header_says_what_the_runtime_does_beyond_the_grid(tmp_path, suffix):
    tab = build_table(_Trained(), 0.0, 0.5, 5e-3, 9.0, 3)
    path = export_table(tab, tmp_path / f"t{suffix}")
    text = path.read_text(encoding="utf-8")
    doc = json.loads(text if suffix == ".json" else text.splitlines()[0].split("; ", 1)[1])
    words = doc["interpolation"]
    assert "refuses positions outside it" not in words
    assert "compensator holds the edge value for positions outside it and counts those cycles" in words


def test_export_position_typed_in_mm_is_refused_in_m_and_mm(tmp_path, stub_model):  # noqa: F811
    """--x-max is in m next to --dx-mm in mm: a user who typed 500 (mm) sees the valid range in
    both units and which unit the option takes."""
    out = tmp_path / "t.csv"
    r = CliRunner().invoke(app, ["te", "export", _mdir(tmp_path), "-o", str(out), "--x-max", "500"])
    assert r.exit_code != 0
    msg = str(r.exception)
    assert "\n" not in msg
    assert msg.startswith("te export.--x-max: [0, 500] m leaves the model's valid range [0, 0.5] m")
    assert "= [0.000, 500.000] mm" in msg
    assert msg.endswith("; --x-min and --x-max are in m (metres; --dx-mm and --step-mm are in mm)")
    assert not out.exists()


def test_export_help_states_each_option_unit():
    r = CliRunner().invoke(app, ["te", "export", "--help"], terminal_width=400, env={"COLUMNS": "400"})
    assert r.exit_code == 0
    text = " ".join(r.output.split())
    for needle in (
        "First position in m (metres, not mm",
        "Last position in m (metres, not mm",
        "Position step of the table in mm (millimetres",
        "compensation points in mm (millimetres",
        "Torque step of the grid in N·m",
    ):
        assert needle in text, needle


def test_validate_states_the_torque_range_of_the_table_it_built():
    """`te validate` printed "table torque range 0 … <training torque>" even when
    ``[validation] table_torque_max`` set another range for the table (found by session 18's
    API audit). The line now reads the range off the table and names what set it."""
    from drivelash.te.protocol.bench import ValidationConfig
    from drivelash.te.protocol.validate import _table_torque_line
    from drivelash.te.runtime.table import TETable

    table = TETable(0.0, 1e-3, np.array([0.0, -6.0]), np.array([2.0, 2.0]), np.zeros((2, 3, 4)))
    assert _table_torque_line(table, ValidationConfig(table_torque_max=6.0)) == (
        "table torque range 0 … 6.00 N·m (set by table_torque_max)"
    )
    assert _table_torque_line(table, ValidationConfig()) == (
        "table torque range 0 … 6.00 N·m (the training runs' torque, loads up to 3000 N)"
    )
