"""The axis description (TOML) and the defaults derived from it (no simulation)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from drivelash.errors import ConfigError
from drivelash.physics.rack_pinion import RackPinionBench
from drivelash.sim.rack_axis import bench_gains
from drivelash.sim.rack_campaign import default_gains
from drivelash.te.learn.fit import default_holdout
from drivelash.te.protocol.axis import load_axis

REPO = Path(__file__).resolve().parents[2]


def test_example_axis_file():
    axis = load_axis(REPO / "examples" / "rack_axis.toml")
    b = axis.bench()
    assert (b.m_n, b.n_t, b.i_PG, b.travel, b.m_T) == (0.003, 24, 10.0, 1.2, 300.0)
    # d_p = m_n n_t / cos(beta), tooth pitch = pi d_p / n_t
    assert b.d_p == pytest.approx(0.003 * 24 / math.cos(0.340808), rel=1e-9)
    assert b.tooth_pitch == pytest.approx(math.pi * b.d_p / 24, rel=1e-12)
    g = axis.cascade_gains(b)
    assert g.K_v == 231.0 and g.K_p / b.J_s == pytest.approx(12.4 / RackPinionBench().J_s, rel=1e-12)
    assert axis.cascade_gains(b, default=False) is None  # import: no gains unless the file gives them
    assert default_gains(RackPinionBench()) == bench_gains()


def test_partial_tables_override_the_defaults(tmp_path):
    p = tmp_path / "a.toml"
    p.write_text("[geometry]\ntravel = 0.8\ncontact_ratio = 2.2\n[gains]\nK_v = 150.0\n")
    p.write_text(p.read_text() + "[campaign]\nloads = [0.0, 2000.0]\n")
    axis = load_axis(p)
    b = axis.bench()
    assert b.travel == 0.8 and b.epsilon == 2.2 and b.n_t == 20
    assert axis.cascade_gains(b).K_v == 150.0 and axis.cascade_gains(b).T_n == 3.05e-3
    assert axis.campaign_config().loads == (0.0, 2000.0)
    with pytest.raises(ConfigError, match=r"table \[geometry\] is required"):
        load_axis(tmp_path / "a.toml").bench(require_geometry=False) and load_axis(_empty(tmp_path)).bench(
            True
        )


def _empty(tmp_path: Path) -> Path:
    p = tmp_path / "empty.toml"
    p.write_text("[drive]\nm_T = 100.0\n")
    return p


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        (
            "[geometry]\ntravel = 0.01\n",
            "table [geometry], key 'travel': must cover at least two tooth pitches",
        ),
        ("[geometry]\ncontact_ratio = 1e9\n", "key 'contact_ratio'"),
        ("[geometry]\nn_t = 2.5\n", "key 'n_t'"),
        ("[[runs]]\nkind = 'geometric'\ndirection = 1\nload = 100.0\n", "a geometric run has no load"),
        ("[[runs]]\nkind = 'sine'\ndirection = 1\n", "does not fit kind 'sine'"),
        ("[columns.x]\ncolumn = 'x_T'\nunit = 'furlong'\n", "unknown unit 'furlong'"),
    ],
)
def test_bad_axis_files(tmp_path, text, needle):
    p = tmp_path / "axis.toml"
    p.write_text(text)
    with pytest.raises(ConfigError) as exc:
        load_axis(p).bench()
    assert needle in str(exc.value) and "axis.toml" in str(exc.value)


def test_default_holdout_from_the_campaign_loads():
    paper = [500.0 * i for i in range(11)]
    assert default_holdout(paper, 3000.0) == (1000.0, 2500.0)  # the paper-like default
    assert default_holdout([0.0, 2500.0, 5000.0], 3000.0) == ()  # quick: both in-range loads train
    assert default_holdout([0.0, 1000.0, 2000.0, 3000.0], 3000.0) == (1000.0,)
    assert default_holdout([0.0, 1500.0, 3000.0, 4500.0], 3000.0) == ()
    # in range 0 … 4000 N: nearest to 1/3 and 5/6 of the span (1333, 3333 N)
    assert default_holdout([0, 1000, 2000, 3000, 4000, 6000], 5000.0) == (1000.0, 3000.0)


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        (
            "[geometry]\nhelix_angle = 19.53\n",
            "table [geometry], key 'helix_angle': 19.53 is read in rad (19.53 rad = 1119°), the key is in"
            " rad — 19.53° is 0.340863 rad",
        ),
        ("[geometry]\nalpha_n = 20\n", "key 'alpha_n': 20 is read in rad (20 rad = 1146°)"),
        (
            "[geometry]\nm_n = 3.0\n",
            "table [geometry], key 'm_n': 3 is read in m (3 m), the module is in m — 3 mm is 0.003",
        ),
        ("[geometry]\nface_width = 40.0\n", "key 'face_width': 40 is read in m (40 m)"),
        (
            "[geometry]\ntravel = 1200\n",
            "table [geometry], key 'travel': 1200 is read in m (1200 m), the travel is in m — 1200 mm is 1.2"
            " (limit 100 m; no rack-and-pinion machine axis is longer)",
        ),
    ],
)
def test_unit_slips_in_the_geometry_are_named(tmp_path, text, needle):
    p = tmp_path / "axis.toml"
    p.write_text(text)
    with pytest.raises(ConfigError) as exc:
        load_axis(p)
    assert needle in str(exc.value) and str(exc.value).startswith(str(p))
    assert "must be < 60°" not in str(exc.value) and "two tooth pitches" not in str(exc.value)


def test_plausible_geometry_at_the_unit_limits_is_accepted(tmp_path):
    # negative control: a 100 m gantry, 50 mm module, 59° helix and 1 m face width are read as given
    p = tmp_path / "axis.toml"
    p.write_text("[geometry]\ntravel = 100.0\nm_n = 0.05\nhelix_angle = 1.03\nface_width = 1.0\nn_t = 20\n")
    g = load_axis(p).bench().geometry
    assert (g.travel, g.m_n, g.helix_angle, g.face_width) == (100.0, 0.05, 1.03, 1.0)
