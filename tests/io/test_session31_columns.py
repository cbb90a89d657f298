"""Session 31 (tester C): column mappings the loader must refuse.

C2 — a velocity column counting against its position (ratio −1 to dθ/dt) was accepted and
`observe` then reported negative friction (EMPS: −61.6 N forward / +55.4 N backward).
C6 — ``gain`` / ``torque_constant`` / ``counts_per_rev`` with a unit that does not use them were
dropped silently (EMPS force declared N with gain = gtau: M = 2.7 kg instead of 95.1).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import drivelash as dl
from drivelash.errors import DataError
from drivelash.io import Trace, load_trace, write_trace
from drivelash.io.stream import TraceStream

N = 400
DT = 1e-3


def _good() -> dict[str, np.ndarray]:
    t = np.arange(N) * DT
    th = 0.3 * np.sin(2 * np.pi * 2 * t) + 0.2 * t
    om = 0.3 * 2 * np.pi * 2 * np.cos(2 * np.pi * 2 * t) + 0.2
    th_l = 0.5 * th + 0.01 * np.sin(2 * np.pi * 9 * t)
    om_l = np.gradient(th_l, t)
    tq = 1.5 * np.sin(2 * np.pi * 2 * t + 0.3) + 0.1 * np.cos(2 * np.pi * 7 * t)
    return {"t": t, "theta_m": th, "omega_m": om, "theta_l": th_l, "omega_l": om_l, "torque_m": tq}


# ------------------------------------------------------------------------------------------ C2
@pytest.mark.parametrize("side", ["m", "l"])
@pytest.mark.parametrize("factor", [-1.0, -180 / np.pi, -1e3])
def test_velocity_counting_against_its_position_is_refused(tmp_path, side, factor):
    c = _good()
    c[f"omega_{side}"] = c[f"omega_{side}"] * factor
    p = write_trace(Trace(c), tmp_path / "neg.csv")
    with pytest.raises(DataError) as e:
        load_trace(p)
    msg = str(e.value)
    assert "\n" not in msg
    assert f"column 'omega_{side}'" in msg and "neg.csv" in msg
    assert f"velocity counts against the derivative of theta_{side}" in msg
    assert "scale = -1" in msg
    if factor != -1.0:
        assert "deg/s" in msg or "ms" in msg  # the unit slip is named too
    with pytest.raises(DataError, match="velocity counts against"):  # the streamed reader too
        with TraceStream(p, chunk_rows=97) as s:
            list(s.chunks())
    # the same frame through the notebook entry
    with pytest.raises(DataError, match="set scale = -1"):
        Trace.from_frame(pd.DataFrame(c))


def test_scale_minus_one_accepts_it_again(tmp_path):
    c = _good()
    c["omega_m"] = -c["omega_m"]
    df = pd.DataFrame(c)
    mapping = {k: k for k in c}
    mapping["omega_m"] = {"column": "omega_m", "unit": "rad/s", "scale": -1.0}
    tr = Trace.from_frame(df, mapping)
    np.testing.assert_allclose(tr["omega_m"], _good()["omega_m"], rtol=1e-15)


@pytest.mark.parametrize("name", ["bench-0A", "bench-0B", "paper-sim"])
def test_correct_recordings_still_load(tmp_path, name):
    """Negative control: simulated drives (quantised encoders, velocity channels) load unchanged."""
    from drivelash.sim.scenarios import get_scenario

    tr = get_scenario(name).simulate(duration=3.0, seed=1)
    cols = {c: np.asarray(tr[c]) for c in ("t", "theta_m", "omega_m", "theta_l", "omega_l", "torque_m")}
    p = write_trace(Trace(cols), tmp_path / "ok.parquet")
    got = load_trace(p)
    np.testing.assert_array_equal(got["omega_m"], cols["omega_m"])


# ------------------------------------------------------------------------------------------ C6
@pytest.mark.parametrize(
    ("spec", "key", "needs"),
    [
        ({"unit": "N", "gain": "gtau"}, "gain", "'V'"),
        ({"unit": "N·m", "gain": 35.15}, "gain", "'V'"),
        ({"unit": "N", "torque_constant": 35.15}, "torque_constant", "'A'"),
        ({"unit": "V", "torque_constant": 0.8, "gain": 2.0}, "torque_constant", "'A'"),
        ({"unit": "m", "counts_per_rev": 4096}, "counts_per_rev", "'counts'"),
        ({"unit": "rad", "counts_per_rev": 4096}, "counts_per_rev", "'counts'"),
    ],
)
def test_conversion_key_with_a_unit_that_ignores_it_is_refused(tmp_path, spec, key, needs):
    from drivelash.errors import ConfigError, ParameterError

    col = "torque_m" if key != "counts_per_rev" else "theta_m"
    df = pd.DataFrame(_good())
    mapping = {k: k for k in df.columns if k != col} | {"raw": {"column": col, **spec}}
    df = df.rename(columns={col: "raw"})
    with pytest.raises(ParameterError) as e:  # notebook: Trace.from_frame / load_trace mappings
        Trace.from_frame(df, mapping)
    msg = str(e.value)
    assert "\n" not in msg and key in msg and f"unit = {needs}" in msg
    # the same in a TOML [columns] table: one line naming file, table, source and key
    lines = [f"{k} = {v!r}".replace("'", '"') for k, v in spec.items()]
    (tmp_path / "c.toml").write_text('[columns.raw]\ncolumn = "' + col + '"\n' + "\n".join(lines) + "\n")
    with pytest.raises(ConfigError) as e:
        dl.load_config(tmp_path / "c.toml")
    msg = str(e.value)
    assert "\n" not in msg and "c.toml" in msg and "'raw'" in msg and key in msg and needs in msg


def test_conversion_keys_with_their_unit_still_apply():
    """Negative control: each key with its own unit converts as before."""
    c = _good()
    df = pd.DataFrame(
        {
            "t": c["t"],
            "enc": np.rint(c["theta_m"] * 4096 / (2 * np.pi)),
            "iq": c["torque_m"] / 0.8,
            "cmd": c["torque_m"] / 2.5,
        }
    )
    enc = {"column": "theta_m", "unit": "counts", "counts_per_rev": 4096}
    iq = {"column": "torque_m", "unit": "A", "torque_constant": 0.8}
    tr = Trace.from_frame(df, {"t": "t", "enc": enc, "iq": iq})
    np.testing.assert_allclose(tr["torque_m"], c["torque_m"], rtol=1e-12)
    np.testing.assert_allclose(tr["theta_m"], df["enc"].to_numpy() * 2 * np.pi / 4096)
    tr = Trace.from_frame(df, {"t": "t", "enc": enc, "cmd": {"column": "torque_m", "unit": "V", "gain": 2.5}})
    np.testing.assert_allclose(tr["torque_m"], c["torque_m"], rtol=1e-12)
