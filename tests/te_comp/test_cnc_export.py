"""CNC layouts of the geometric (no-load) TE (issue 12 item 6): golden files and refusals.

The golden files in ``golden/`` were written by hand from the layouts of the SINUMERIK
840D sl function manual K3 (``$AA_ENC_COMP`` init program, CEC tables with
``$AN_CEC_DIRECTION``) and the HEIDENHAIN ``.COM`` table (NR, AXISPOS, axis column,
BACKLASH), for a model whose no-load curves are known in closed form:
TE+ = 1 µm + 1 µm/mm · (x − 100 mm), TE− = 21 µm + 3 µm/mm · (x − 100 mm) on a valid range
of 100 … 104 mm. Mean of both directions 11 … 19 µm; direction rest ∓(10 … 14) µm.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from drivelash.errors import DataError, ParameterError
from drivelash.te.runtime.cnc import geometric_table, write_cnc, write_heidenhain, write_sinumerik

GOLDEN = Path(__file__).parent / "golden"


class LinearGeoModel:
    """No-load curves linear in x on [100, 104] mm (held at the edges like the model)."""

    def __init__(self, scale: float = 1.0, lo: float = 0.100, hi: float = 0.104):
        self.scale, self.lo, self.hi = scale, lo, hi

    def geometric_range(self):
        return self.lo, self.hi

    def geometric(self, x, direction):
        u = np.clip(np.asarray(x, dtype=float), self.lo, self.hi) - 0.100
        te = 1e-6 + 1e-3 * u if direction > 0 else 21e-6 + 3e-3 * u
        return self.scale * te


def _read(path: Path) -> bytes:
    return path.read_bytes()


def test_sinumerik_golden(tmp_path):
    tab = geometric_table(LinearGeoModel(), step=1e-3)
    out = write_sinumerik(tab, tmp_path / "axis.ini", axis="X1")
    raw = _read(out)
    assert b"\r\n" in raw and raw.count(b"\r\n") == raw.count(b"\n")  # CR LF line ends throughout
    assert raw.replace(b"\r\n", b"\n") == _read(GOLDEN / "X1_sinumerik.ini")


def test_heidenhain_golden(tmp_path):
    tab = geometric_table(LinearGeoModel(), step=1e-3)
    out = write_heidenhain(tab, tmp_path / "x.com", axis="X")
    assert _read(out).replace(b"\r\n", b"\n") == _read(GOLDEN / "X.COM")


def test_sinumerik_layout_follows_the_k3_examples(tmp_path):
    # Function Manual Extended Functions (K3) 03/2013: the init program starts with its header
    # (§4.4.2.3 example, p. 242), an axis is assigned to $AN_CEC_INPUT_AXIS/_OUTPUT_AXIS in
    # parentheses (p. 268: "$AN_CEC_INPUT_AXIS[0] = (AX1)"), tables load only while MD32700/MD32710
    # are 0 (p. 237), a CEC table acts only with SD41300 $SN_CEC_TABLE_ENABLE[t] (p. 245) and
    # MD18342 is set per table (p. 264: "$MN_MM_CEC_MAX_POINTS[0] = 11").
    tab = geometric_table(LinearGeoModel(), step=1e-3)
    lines = write_sinumerik(tab, tmp_path / "a.ini", axis="Y2", cec_tables=(4, 7)).read_text().splitlines()
    assert lines[0] == "%_N_AX_EEC_INI"
    code = [ln for ln in lines if not ln.startswith(";")]
    assert code[:2] == ["%_N_AX_EEC_INI", "CHANDATA(1)"]
    i = code.index("%_N_NC_CEC_INI")
    assert code[i - 1] == "M17" and code[i + 1] == "CHANDATA(1)" and code[-1] == "M17"
    for t in (4, 7):
        assert f"$AN_CEC_INPUT_AXIS[{t}]=(Y2)" in code and f"$AN_CEC_OUTPUT_AXIS[{t}]=(Y2)" in code
    assert not any(ln.startswith("$AN_CEC_") and ln.endswith("=Y2") for ln in code)
    head = " ".join(ln for ln in lines if ln.startswith(";"))
    assert "$SN_CEC_TABLE_ENABLE[4] = 1" in head and "$SN_CEC_TABLE_ENABLE[7] = 1" in head
    assert "$MN_MM_CEC_MAX_POINTS[4] and [7] >= 5" in head
    assert "MD32700 $MA_ENC_COMP_ENABLE[0] = 0 and MD32710 $MA_CEC_ENABLE = 0" in head


def test_layouts_hold_the_model_values(tmp_path):
    # read the golden-layout files back and compare with the model at the points
    m = LinearGeoModel()
    tab = geometric_table(m, step=0.5e-3)
    x = np.arange(0.100, 0.104 + 1e-12, 0.5e-3)
    write_heidenhain(tab, tmp_path / "X.COM")
    rows = [ln.split() for ln in (tmp_path / "X.COM").read_text().splitlines()[2:] if ln[0].isdigit()]
    arr = np.array(rows, dtype=float)
    np.testing.assert_allclose(arr[:, 1], x * 1e3, atol=5e-5)
    np.testing.assert_allclose(arr[:, 2], m.geometric(x, 1) * 1e3, atol=5e-6)
    np.testing.assert_allclose(arr[:, 3], m.geometric(x, -1) * 1e3, atol=5e-6)
    write_sinumerik(tab, tmp_path / "s.ini")
    txt = (tmp_path / "s.ini").read_text()
    enc = np.array([float(ln.split("=")[1]) for ln in txt.splitlines() if ln.startswith("$AA_ENC_COMP[")])
    cec0 = np.array([float(ln.split("=")[1]) for ln in txt.splitlines() if ln.startswith("$AN_CEC[0,")])
    cec1 = np.array([float(ln.split("=")[1]) for ln in txt.splitlines() if ln.startswith("$AN_CEC[1,")])
    # LEC + (−CEC of the direction) = the direction's TE at every point
    np.testing.assert_allclose(enc - cec0, m.geometric(x, 1) * 1e3, atol=2e-6)
    np.testing.assert_allclose(enc - cec1, m.geometric(x, -1) * 1e3, atol=2e-6)


def test_positions_outside_the_valid_range_are_refused():
    m = LinearGeoModel()
    with pytest.raises(
        ParameterError, match=r"--x-max.*leaves the model's valid range \[100\.000, 104\.000\] mm"
    ):
        geometric_table(m, step=1e-3, x_max=0.105)
    with pytest.raises(ParameterError, match="--x-min"):
        geometric_table(m, step=1e-3, x_min=0.099)
    with pytest.raises(ParameterError, match="--step-mm"):
        geometric_table(m, step=0.0)
    with pytest.raises(ParameterError, match="--step-mm"):
        geometric_table(m, step=1.0)  # fewer than 2 points
    # inside the range: accepted, and the table spans exactly the requested positions
    tab = geometric_table(m, step=1e-3, x_min=0.101, x_max=0.103)
    assert tab.x0 == pytest.approx(0.101) and tab.x_max == pytest.approx(0.103)


def test_implausible_values_are_refused():
    # a no-load TE of 21 mm (a unit error: µm read as mm) is not a rack
    with pytest.raises(DataError, match="refusing to export a no-load TE"):
        geometric_table(LinearGeoModel(scale=1000.0), step=1e-3)


def test_interpolation_error_is_reported():
    class Wavy(LinearGeoModel):
        def geometric(self, x, direction):
            return 5e-6 * np.sin(2 * np.pi * np.asarray(x) / 13.333e-3)  # 5 µm meshing error

    wide = geometric_table(Wavy(lo=0.0, hi=0.1), step=4e-3)
    fine = geometric_table(Wavy(lo=0.0, hi=0.1), step=0.5e-3)
    # linear interpolation of a sine of amplitude A between points h apart: ≤ A (π h/λ)²/2
    assert fine.interpolation_error <= 5e-6 * (np.pi * 0.5 / 13.333) ** 2 / 2 * 1.05
    assert wide.interpolation_error > 10 * fine.interpolation_error


def test_bad_axis_and_layout_names(tmp_path):
    tab = geometric_table(LinearGeoModel(), step=1e-3)
    with pytest.raises(ParameterError, match="--axis"):
        write_sinumerik(tab, tmp_path / "a.ini", axis="X1; M30")
    with pytest.raises(ParameterError, match="--format"):
        write_cnc(tab, tmp_path / "a.txt", "fanuc")


def test_more_than_100_000_points_are_refused():
    """docs/te-formats.md §4: "more than 100 000 points" are refused; 100 000 are written."""
    span = 0.104 - 0.100
    with pytest.raises(ParameterError, match=r"--step-mm.*gives 100001 points \(limit 100000\)"):
        geometric_table(LinearGeoModel(), step=span / 100_000)
    # negative control: one point fewer is the limit itself, accepted and spanning the range
    tab = geometric_table(LinearGeoModel(), step=span / 99_999)
    assert tab.te_pos.size == tab.te_neg.size == 100_000
    assert tab.x0 + tab.step * (tab.te_pos.size - 1) == pytest.approx(0.104, abs=1e-12)


@pytest.mark.parametrize("layout,name", [("sinumerik", "axis.ini"), ("heidenhain", "axis.com")])
def test_a_rerun_of_te_export_replaces_its_own_cnc_table(tmp_path, layout, name):
    """``te export --format sinumerik -o x.ini`` twice: the second run said "an existing file
    that is not a drivelash output" (the signature is on the line after ``%_N_AX_EEC_INI``).
    A user's init program with the same header stays refused without --force."""
    from drivelash.errors import OutputError
    from drivelash.io.outputs import Outputs

    tab = geometric_table(LinearGeoModel(), step=1e-3)
    target = tmp_path / name
    for _ in range(2):
        with Outputs("te export") as out:
            write_cnc(tab, out.staging(out.file(target, option="-o")), layout)
    user = tmp_path / "user.ini"
    user.write_bytes(b"%_N_AX_EEC_INI\r\n; my own compensation\r\nM17\r\n")
    with pytest.raises(OutputError) as ei, Outputs("te export") as out:
        out.file(user, option="-o")
    assert str(ei.value) == (
        f"-o {user}: an existing file that is not a drivelash output; use --force to replace it"
        " or choose another path"
    )
    assert user.read_bytes() == b"%_N_AX_EEC_INI\r\n; my own compensation\r\nM17\r\n"


@pytest.mark.parametrize("layout,name", [("sinumerik", "axis.ini"), ("heidenhain", "axis.com")])
def test_a_failed_library_write_leaves_the_previous_cnc_table(tmp_path, monkeypatch, layout, name):
    """``write_cnc(tab, path)`` outside a command opened ``path`` for writing at once: a full disk
    left the machine's previous table truncated. Now through ``write_target`` (atomic)."""
    import errno
    import os

    tab = geometric_table(LinearGeoModel(), step=1e-3)
    target = tmp_path / name
    write_cnc(tab, target, layout)
    before = target.read_bytes()
    real_open = Path.open

    class HalfThenFull:
        def __init__(self, fh):
            self.fh = fh

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.fh.close()

        def write(self, text):
            self.fh.write(text[:20])
            self.fh.flush()
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(Path, "open", lambda self, *a, **k: HalfThenFull(real_open(self, *a, **k)))
    with pytest.raises(OSError):
        write_cnc(geometric_table(LinearGeoModel(scale=2.0), step=1e-3), target, layout)
    monkeypatch.undo()
    assert target.read_bytes() == before
    assert os.listdir(tmp_path) == [name]
