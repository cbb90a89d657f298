"""TOML configuration: pydantic models, one-line errors with suggestions, fuzzing."""

from __future__ import annotations

import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drivelash.errors import ConfigError, DrivelashError
from drivelash.io import load_config
from drivelash.io.config import drivetrain_fragment, loads_config
from drivelash.params import BacklashParams, DrivetrainParams

FULL = """
[drivetrain]
J_m = 0.01
J_l = 0.05
N = 2.0
K_S = 800.0
D_S = 0.5
T_Cm = 0.1
beta_l = 0.02

[backlash]
delta1 = 0.002
alpha = 2000.0

[estimator]
k1 = 30.0
gamma = 5.0

[columns.enc]
column = "theta_m"
unit = "counts"
counts_per_rev = 4096

[sampling]
time_unit = "ms"
"""


def test_full_config_maps_to_params(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text(FULL)
    cfg = load_config(p)
    drivetrain = cfg.to_drivetrain_params()
    assert drivetrain == DrivetrainParams(
        J_m=0.01, J_l=0.05, N=2.0, K_S=800.0, D_S=0.5, T_Cm=0.1, beta_l=0.02
    )
    assert cfg.to_backlash_params(delta=0.01) == BacklashParams(delta=0.01, delta1=0.002, alpha=2000.0)
    assert cfg.estimator.k1 == 30.0 and cfg.estimator.k2 is None
    assert cfg.columns["enc"].counts_per_rev == 4096
    assert cfg.sampling.time_unit == "ms"


@pytest.mark.parametrize(
    ("text", "expect"),
    [
        (
            "[drivetrain]\nJ_m = 1.0\nbeta_n = 0.1\n",
            "table [drivetrain], key 'beta_n': unknown key; did you mean 'beta_m'?",
        ),
        ("[drivetrian]\nJ_m = 1.0\n", "unknown table [drivetrian]; did you mean 'drivetrain'?"),
        ("[backlash]\ndelta_1 = 0.1\n", "did you mean 'delta1'?"),
        ("[estimator]\ngama = 1.0\n", "did you mean 'gamma'?"),
        (
            '[columns.q]\ncolumn = "theta_m"\nunits = "rad"\n',
            "table [columns.q], key 'units': unknown key; did you mean 'unit'?",
        ),
        ('[columns.q]\ncolumn = "theta_m"\nunit = "rmp"\n', "unknown unit 'rmp' (did you mean 'rpm'?)"),
        ("[backlash]\nalpha = 3.0\n", "table [backlash], key 'delta1': missing"),
        ('[columns.q]\nunit = "rad"\n', "table [columns.q], key 'column': missing"),
        ('[drivetrain]\nJ_m = "heavy"\n', "table [drivetrain], key 'J_m': Input should be a valid number"),
        ("[sampling]\nresample = 3\n", "table [sampling], key 'resample'"),
        ("[identification]\ndecimate = 0\n", "table [identification], key 'decimate'"),
        ("[drivetrain\nJ_m = 1\n", "TOML syntax error"),
    ],
)  # fmt: skip
def test_config_errors_are_one_line_with_file_table_key(tmp_path, text, expect):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(ConfigError) as ei:
        load_config(p)
    msg = str(ei.value)
    assert "\n" not in msg
    assert msg.startswith(str(p) + ":")
    assert expect in msg, msg


def test_sections_optional_until_required():
    cfg = loads_config("", source="empty.toml")
    with pytest.raises(ConfigError, match=r"empty.toml: table \[drivetrain\] is required"):
        cfg.require("drivetrain")
    with pytest.raises(ConfigError, match=r"table \[backlash\] is required"):
        cfg.to_backlash_params(delta=0.1)
    partial = loads_config("[drivetrain]\nJ_m = 95.1\nbeta_m = 203.5\n", source="frag.toml")
    with pytest.raises(ConfigError, match=r"frag.toml: table \[drivetrain\], key 'J_l': missing"):
        partial.to_drivetrain_params()


def test_invalid_physical_value_names_table_and_field():
    cfg = loads_config("[drivetrain]\nJ_m = -1\nJ_l = 1\nN = 1\nK_S = 1\nD_S = 0\n", source="x.toml")
    with pytest.raises(ConfigError, match=r"x.toml: \[drivetrain\] DrivetrainParams.J_m: must be > 0"):
        cfg.to_drivetrain_params()


def test_missing_and_non_utf8_files(tmp_path):
    with pytest.raises(ConfigError, match="no such configuration file"):
        load_config(tmp_path / "nope.toml")
    (tmp_path / "bin.toml").write_bytes(b"\xff\xfe\x00\x01")
    with pytest.raises(ConfigError, match="not a UTF-8"):
        load_config(tmp_path / "bin.toml")


def test_fragment_round_trips_through_the_loader():
    frag = drivetrain_fragment({"J_m": 95.1, "beta_m": 203.5, "T_Cm": 20.39}, ["identified"])
    cfg = loads_config(frag)
    assert cfg.drivetrain.J_m == 95.1 and cfg.drivetrain.T_Cm == 20.39
    assert frag.startswith("# identified\n")


# ----------------------------------------------------------------------------- fuzzing
_keys = st.sampled_from(
    ["drivetrain", "backlash", "estimator", "columns", "sampling", "identification", "J_m", "delta1", "unit",
     "column", "gain", "k1", "x", "resample", "sample_rate", "decimate", "side"]
)  # fmt: skip
_scalars = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.text(max_size=8),
    st.booleans(),
    st.just("counts"),
    st.just("theta_m"),
)
_values = st.recursive(
    _scalars,
    lambda children: st.one_of(st.lists(children, max_size=3), st.dictionaries(_keys, children, max_size=4)),
    max_leaves=12,
)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.dictionaries(_keys, _values, max_size=5))
def test_fuzz_structured_toml_only_raises_toolkit_errors(doc):
    """Random documents (valid TOML structure, random keys/values): parse or ConfigError."""
    import tomli_w

    try:
        text = tomli_w.dumps(doc)
    except (TypeError, ValueError):
        return  # not representable in TOML (e.g. NaN list mixing) — nothing to parse
    try:
        cfg = loads_config(text)
    except DrivelashError as exc:
        assert "\n" not in str(exc)
        return
    if cfg.drivetrain is not None:
        try:
            cfg.to_drivetrain_params()
        except DrivelashError:
            pass


@settings(max_examples=300, deadline=None)
@given(st.text(alphabet=st.sampled_from(list("[]=\".\n #abcJ_m01e+-,{}'\\tuxyz")), max_size=80))
def test_fuzz_raw_toml_text_only_raises_toolkit_errors(text):
    try:
        loads_config(text)
    except DrivelashError as exc:
        assert "\n" not in str(exc)


def test_nan_values_are_rejected_by_params():
    cfg = loads_config("[drivetrain]\nJ_m = nan\nJ_l = 1\nN = 1\nK_S = 1\nD_S = 0\n")
    assert math.isnan(cfg.drivetrain.J_m)
    with pytest.raises(ConfigError, match="finite"):
        cfg.to_drivetrain_params()
