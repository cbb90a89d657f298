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
    """A complete table is checked by the dataclass's own __post_init__ when the file loads."""
    text = "[drivetrain]\nJ_m = -1\nJ_l = 1\nN = 1\nK_S = 1\nD_S = 0\n"
    with pytest.raises(ConfigError, match=r"^x.toml: table \[drivetrain\], key 'J_m': must be > 0, got -1"):
        loads_config(text, source="x.toml")
    # cross-field check of the dataclass (static >= Coulomb friction)
    text = "[drivetrain]\nJ_m = 1\nJ_l = 1\nN = 1\nK_S = 1\nD_S = 0\nT_Cm = 0.2\nT_Sm = 0.1\n"
    with pytest.raises(
        ConfigError, match=r"table \[drivetrain\], key 'T_Sm': static friction must be 0 or >= T_Cm"
    ):
        loads_config(text, source="x.toml")
    # a partial table is checked when the command completes it
    cfg = loads_config("[backlash]\ndelta1 = 0.3\n", source="x.toml")
    with pytest.raises(
        ConfigError, match=r"x.toml: table \[backlash\], key 'delta1': must lie in \[0, delta\]"
    ):
        cfg.to_backlash_params(delta=0.2)


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
    with pytest.raises(ConfigError, match=r"table \[drivetrain\], key 'J_m': must be finite"):
        loads_config("[drivetrain]\nJ_m = nan\nJ_l = 1\nN = 1\nK_S = 1\nD_S = 0\n")
    partial = loads_config("[drivetrain]\nJ_m = nan\n")  # incomplete: checked when completed
    assert math.isnan(partial.drivetrain.J_m)
    with pytest.raises(ConfigError, match="finite"):
        partial.params("drivetrain", J_l=1.0, N=1.0, K_S=1.0, D_S=0.0)


# ----------------------------------------------------------------------------- one schema
def test_tables_are_generated_from_the_dataclasses():
    """Keys, defaults and units of [drivetrain], [backlash], [estimator] are the dataclasses'."""
    import dataclasses

    from drivelash.io.config import BacklashSection, DrivetrainSection, EstimatorSection, unit_of
    from drivelash.params import EstimatorConfig

    for model, cls in (
        (DrivetrainSection, DrivetrainParams),
        (BacklashSection, BacklashParams),
        (EstimatorSection, EstimatorConfig),
    ):
        fields = [f for f in dataclasses.fields(cls) if f.init]
        assert list(model.model_fields) == [f.name for f in fields]  # every field, same order
        for f in fields:
            if model is not EstimatorSection and f.default is not dataclasses.MISSING:
                assert model.model_fields[f.name].default == f.default
            if f.type in ("float", float):
                assert unit_of(model, f.name), f"{cls.__name__}.{f.name} has no unit in its numpydoc"
    assert len(EstimatorSection.model_fields) >= 24
    # the unit of eps_delta is the dataclass's (a ratio), not [rad]
    assert unit_of(EstimatorSection, "eps_delta") == "-"
    assert unit_of(EstimatorSection, "k2") == "rad/s³"
    assert unit_of(DrivetrainSection, "J_m") == "kg·m²"
    assert "inertia" in DrivetrainSection.model_fields["J_m"].description.lower()


def test_every_estimator_key_reaches_the_estimator_config():
    """Each [estimator] key overrides the tuning rule, value for value."""
    from drivelash.params import EstimatorConfig

    text = (
        "[estimator]\nk1 = 11.0\nk2 = 222.0\ngamma = 3.0\ndelta_max = 1.5\neps_delta = 0.2\n"
        'delta0 = 0.01\nalpha = 500.0\nmethod = "paper"\nomega_c = 12.0\ntau_f = 0.01\nlam = 0.3\n'
        "P_max = 9.0\nomega_eps = 0.001\nT_thr = 0.02\nwindow = 3.0\nestimate_stiffness = false\n"
        "estimate_offset = true\nq_offset = 0.5\noffset_check = false\noffset_switch = 0.004\n"
        "theta_def = 0.002\nq_aux = 0.2\nreset_e = 2.0\nreset_t = 0.05\n"
        'torque_source = "motor"\nk1_m = 5.0\nk2_m = 50.0\nlam_g = 1.0\nomega_g = 0.2\ngap_margin = 0.2\n'
        'contact_bound = false\nencoder_reading = "truncate"\nangle_scale = 0.5\n'
    )
    cfg = loads_config(text)
    given = cfg.estimator.given()
    assert set(given) == {f.name for f in __import__("dataclasses").fields(EstimatorConfig)}
    rig = DrivetrainParams(J_m=8.31e-4, J_l=8.31e-4, N=1.0, K_S=32.94, D_S=0.0548, T_Cl=0.0232)
    ec = EstimatorConfig.tuned(rig, 125e-6, 0.5, **given)
    for k, v in given.items():
        assert getattr(ec, k) == v, k


@pytest.mark.parametrize(
    ("text", "expect"),
    [
        ("[drivetrain]\nJ_m = true\n", "table [drivetrain], key 'J_m': Input should be a valid number"),
        ('[drivetrain]\nJ_m = "1.5"\n', "table [drivetrain], key 'J_m': Input should be a valid number"),
        ("[estimator]\nestimate_stiffness = 1\n", "'estimate_stiffness': Input should be a valid boolean"),
        ('[estimator]\nmethod = "fast"\n', "key 'method': Input should be 'paper' or 'default'"),
        ("[estimator]\nK_S = 3.0\n", "[estimator], key 'K_S': unknown key; it is a key of [drivetrain]"),
        ("drivetrain = 3\n", "table [drivetrain] must be a table"),
        ("[estimator]\neps_delta = -0.1\n", None),  # partial table: checked by the estimator (below)
    ],
)  # fmt: skip
def test_strict_types_and_helpful_errors(text, expect):
    if expect is None:
        cfg = loads_config(text, source="e.toml")
        from drivelash.params import EstimatorConfig

        with pytest.raises(DrivelashError, match="eps_delta"):
            EstimatorConfig.tuned(DrivetrainParams(1, 1, 1, 1, 0), 1e-3, **cfg.estimator.given())
        return
    with pytest.raises(ConfigError) as ei:
        loads_config(text, source="e.toml")
    assert str(ei.value).startswith("e.toml: ") and expect in str(ei.value), str(ei.value)


def test_param_docs_reads_numpydoc_entries_and_units():
    from drivelash.io.config import param_docs

    class Thing:
        """A thing.

        Parameters
        ----------
        a, b : float
            Two lengths [m]; the second
            may wrap.
        n : int
            A count.
        ratio : float
            Dimensionless [-].

        Notes
        -----
        x : float
            Not a parameter [s].
        """

    d = param_docs(Thing)
    assert d["a"] == ("Two lengths [m]; the second may wrap.", "m") and d["b"][1] == "m"
    assert d["n"] == ("A count.", None)
    assert d["ratio"][1] == "-"
    assert "x" not in d


def test_extension_point_a_new_file_with_a_generated_table(tmp_path):
    """How another owner adds a table: generate it from a dataclass, list it in a file model."""
    import dataclasses

    from drivelash.errors import ParameterError
    from drivelash.io.config import ConfigFile, EstimatorSection, load_file, section

    @dataclasses.dataclass(frozen=True)
    class Geometry:
        """Rack geometry.

        Parameters
        ----------
        m_n : float
            Normal module [m].
        z : int
            Number of pinion teeth [-].
        """

        m_n: float
        z: int = 20

        def __post_init__(self):
            if not self.m_n > 0:
                raise ParameterError("Geometry", "m_n", f"must be > 0, got {self.m_n!r}")

    class AxisFile(ConfigFile):
        geometry: section(Geometry, overrides=True) | None = None  # type: ignore[valid-type]
        estimator: EstimatorSection | None = None  # type: ignore[valid-type]

    p = tmp_path / "axis.toml"
    p.write_text("[geometry]\nz = 24\n[estimator]\nk1 = 3.0\n")
    cfg = load_file(p, AxisFile)
    assert cfg.params("geometry", base=Geometry(m_n=0.004)) == Geometry(m_n=0.004, z=24)
    assert cfg.estimator.k1 == 3.0
    p.write_text("[geometry]\nm_n = -1.0\n")
    with pytest.raises(ConfigError, match=rf"^{p}: table \[geometry\], key 'm_n': must be > 0, got -1.0$"):
        load_file(p, AxisFile).params("geometry", base=Geometry(m_n=0.004))
    p.write_text("[geometry]\nm_N = 0.004\n")
    with pytest.raises(
        ConfigError, match=r"table \[geometry\], key 'm_N': unknown key; did you mean 'm_n'\?"
    ):
        load_file(p, AxisFile)
    p.write_text("[geometri]\nm_n = 0.004\n")
    with pytest.raises(ConfigError, match=r"unknown table \[geometri\]; did you mean 'geometry'\?"):
        load_file(p, AxisFile)


def test_generated_tables_pickle_across_processes(tmp_path):
    """Configs cross process boundaries (wear ingest's process pool, Dask): a generated table
    pickles by its recipe and unpickles in a fresh interpreter, equal to the original."""
    import pickle
    import subprocess
    import sys

    from drivelash.sim.scenarios import DrivetrainOverrides

    cfg = loads_config("[drivetrain]\nJ_l = 0.002\nK_S = 30.0\n[backlash]\ndelta1 = 0.1\n", "a.toml")
    ov = DrivetrainOverrides(K_S=12.0)
    blob = tmp_path / "cfg.pkl"
    blob.write_bytes(pickle.dumps((cfg, ov)))
    assert pickle.loads(blob.read_bytes()) == (cfg, ov)
    code = (
        "import pickle, sys; cfg, ov = pickle.loads(open(sys.argv[1], 'rb').read()); "
        "print(cfg.drivetrain.K_S, cfg.backlash.delta1, ov.K_S, ov.given())"
    )
    out = subprocess.run([sys.executable, "-c", code, str(blob)], capture_output=True, text=True, check=True)
    assert out.stdout.split(maxsplit=3) == ["30.0", "0.1", "12.0", "{'K_S': 12.0}\n"]


@pytest.mark.parametrize(
    ("example", "loader"),
    [
        ("drive_bench.toml", "drivelash.io.config:load_config"),
        ("iso230_recording.toml", "drivelash.iso230.config:load_iso230_config"),
        ("rack_axis.toml", "drivelash.te.protocol.axis:load_axis"),
    ],
)
def test_config_with_utf8_bom_reads_like_without(tmp_path, example, loader):
    """A TOML saved by a Windows editor starts with a BOM; every config loader accepts it."""
    import importlib
    from pathlib import Path

    mod, name = loader.split(":")
    load = getattr(importlib.import_module(mod), name)
    src = Path(__file__).resolve().parents[2] / "examples" / example
    bom = tmp_path / example
    bom.write_bytes(b"\xef\xbb\xbf" + src.read_bytes())
    assert repr(load(bom)).replace(str(bom), "X") == repr(load(src)).replace(str(src), "X")
    # negative control: a BOM in the middle is still a syntax error naming the file
    mid = tmp_path / f"mid_{example}"
    mid.write_bytes(src.read_bytes() + b"\n\xef\xbb\xbf[x]\n")
    with pytest.raises(ConfigError, match=f"^{mid}: "):
        load(mid)
