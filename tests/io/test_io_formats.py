"""File formats: round trips, pandas-style HDF5, MATLAB v5/v7.3, the EMPS file."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
import scipy.io

from drivelash.errors import DataError, DrivelashError
from drivelash.io import load_trace, read_raw, write_trace
from drivelash.io.formats import detect_format
from identify.helpers import emps_file, simulated_trace


@pytest.fixture(scope="module")
def sim_trace():
    return simulated_trace(2.0)


@pytest.mark.parametrize(
    ("fmt", "name"),
    [("csv", "x.csv"), ("parquet", "x.parquet"), ("hdf5", "x.h5"), ("mat", "x.mat"), ("mat73", "x.mat")],
)
def test_round_trip_identical(tmp_path, sim_trace, fmt, name):
    """Simulated Trace → file → load_trace: every column bit-identical, meta preserved."""
    path = write_trace(sim_trace, tmp_path / name, fmt=fmt)
    back = load_trace(path)
    assert back.names == sim_trace.names
    for col in sim_trace.names:
        # CSV uses 17 significant digits: exact float64 round trip; binary formats are exact.
        np.testing.assert_array_equal(back[col], sim_trace[col], err_msg=f"{fmt}: {col}")
    assert back.meta["scenario"] == sim_trace.meta["scenario"]
    assert back.meta["format"] == ("mat73" if fmt == "mat73" else fmt)
    assert not list(tmp_path.glob("*.part")), "temporary files left behind"


def test_mat73_is_hdf5_with_matlab_header(tmp_path, sim_trace):
    path = write_trace(sim_trace, tmp_path / "x.mat", fmt="mat73")
    assert path.read_bytes()[:10] == b"MATLAB 7.3"
    assert detect_format(path) == "mat73"
    with h5py.File(path, "r") as f:  # MATLAB layout: a column vector is stored 1×N
        assert f["theta_m"].shape == (1, len(sim_trace))


def test_pandas_fixed_hdf5_frame(tmp_path):
    """A pandas HDFStore 'fixed' frame (axis0/blockN_items/blockN_values, transposed) — built by hand
    with h5py since PyTables is not a dependency."""
    n = 50
    t = np.arange(n) * 0.01
    x = np.sin(t)
    tq = np.cos(3 * t) + 0.1 * t
    path = tmp_path / "store.h5"
    with h5py.File(path, "w") as f:
        g = f.create_group("df")
        g.attrs["pandas_type"] = np.bytes_("frame")
        g.create_dataset("axis0", data=np.array([b"t", b"theta_m", b"torque_m"]))
        g.create_dataset("axis1", data=np.arange(n))
        g.create_dataset("block0_items", data=np.array([b"t", b"theta_m", b"torque_m"]))
        ds = g.create_dataset("block0_values", data=np.column_stack([t, x, tq]))  # rows × items
        ds.attrs["transposed"] = True
    tr = load_trace(path)
    np.testing.assert_array_equal(tr["theta_m"], x)
    np.testing.assert_array_equal(tr["torque_m"], tq)


def test_hdf5_compound_table(tmp_path):
    """A compound-dtype table (pandas 'table' format with data_columns): fields become columns."""
    n = 40
    arr = np.zeros(n, dtype=[("index", "i8"), ("t", "f8"), ("theta_m", "f8")])
    arr["index"] = np.arange(n)
    arr["t"] = np.arange(n) * 1e-3
    arr["theta_m"] = np.sin(arr["t"] * 50)
    path = tmp_path / "table.h5"
    with h5py.File(path, "w") as f:
        f.create_group("df").create_dataset("table", data=arr)
    raw = read_raw(path)
    np.testing.assert_array_equal(raw.columns["theta_m"], arr["theta_m"])


def test_mat_v5_scalars_and_column_vectors(tmp_path):
    n = 30
    t = np.arange(n) * 1e-3
    scipy.io.savemat(tmp_path / "r.mat", {"t": t[:, None], "pos": np.sin(t)[:, None] * 1e-2, "k": 2.5})
    raw = read_raw(tmp_path / "r.mat")
    assert raw.scalars == {"k": 2.5}
    np.testing.assert_array_equal(raw.columns["t"], t)


def test_emps_mat_is_read_with_gtau_from_the_file():
    """The committed example config maps EMPS: force = gtau · vir, gtau read from the file."""
    from drivelash.io import load_config
    from identify.helpers import EMPS_CONFIG

    path = emps_file("DATA_EMPS.mat")
    tr = load_trace(path, load_config(EMPS_CONFIG))
    d = scipy.io.loadmat(path)
    gtau = float(d["gtau"][0, 0])
    assert gtau == pytest.approx(35.15, abs=0.01)
    np.testing.assert_allclose(tr["torque_m"], gtau * d["vir"].ravel(), rtol=1e-15)
    np.testing.assert_array_equal(tr["theta_m"], d["qm"].ravel())
    assert len(tr) == 24841
    assert tr.T_s == pytest.approx(1e-3, rel=1e-4)
    assert tr.meta["axis"] == "prismatic" and tr.meta["units"]["torque_m"] == "N"


def test_write_is_atomic_on_failure(tmp_path, sim_trace, monkeypatch):
    """A writer that fails half-way leaves no file at all."""
    import drivelash.io.formats as formats

    def boom(trace, path, userblock=0):
        path.write_bytes(b"partial")
        raise OSError("disk full")

    monkeypatch.setattr(formats, "_write_hdf5", boom)
    with pytest.raises(OSError):
        write_trace(sim_trace, tmp_path / "x.h5")
    assert list(tmp_path.iterdir()) == []


def test_csv_meta_line_is_json(tmp_path, sim_trace):
    path = write_trace(sim_trace, tmp_path / "x.csv")
    first = path.read_text().splitlines()[0]
    assert json.loads(first.removeprefix("# drivelash.meta "))["scenario"] == "bench-0A"


def test_unknown_format_name(tmp_path, sim_trace):
    with pytest.raises(DataError, match="unknown format"):
        write_trace(sim_trace, tmp_path / "x.bin", fmt="xlsx")


def test_quoted_csv_header_as_pyarrow_writes_it(tmp_path):
    """pyarrow's CSVWriter (and Excel) quote the header: ``"t","theta_m"`` names t and theta_m."""
    import pyarrow as pa
    import pyarrow.csv as pcsv

    from drivelash.io import load_trace
    from drivelash.io.stream import iter_trace_chunks

    t = np.arange(200) / 8000.0
    batch = pa.record_batch([pa.array(t), pa.array(np.sin(50 * t))], names=["t", "theta_m"])
    p = tmp_path / "quoted.csv"
    with pa.OSFile(str(p), "wb") as f:
        w = pcsv.CSVWriter(f, batch.schema)
        w.write_batch(batch)
        w.close()
    assert p.read_text().startswith('"t","theta_m"')
    tr = load_trace(p)
    assert tr.T_s == pytest.approx(1 / 8000.0, rel=1e-12)  # median of the float intervals
    np.testing.assert_array_equal(tr["theta_m"], np.sin(50 * t))
    streamed = np.concatenate([c["theta_m"] for c in iter_trace_chunks(p, chunk_rows=64)])
    np.testing.assert_array_equal(streamed, tr["theta_m"])


def _european_csv(path, t, cols, first_row_integers=False):
    """``;``-separated, decimal commas — a spreadsheet's export in a German locale."""
    names = ["t", *cols]
    lines = [";".join(names)]
    for i, ti in enumerate(t):
        vals = [ti, *(cols[c][i] for c in cols)]
        text = [repr(float(v)).replace(".", ",") for v in vals]
        if first_row_integers and i == 0:
            text = [str(int(round(v))) for v in vals]
        lines.append(";".join(text))
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("first_row_integers", [False, True])
def test_decimal_comma_csv_reads_the_same_numbers(tmp_path, first_row_integers):
    """``0,05;1,2`` (``;``-separated, decimal commas) loads bit-identical to the ``.`` file, in
    the whole-file and the streamed reader; with an integer first row the streamed reader's
    first guess (``.``) fails and the strict reader decides from every cell."""
    from drivelash.io.stream import iter_trace_chunks

    t = np.arange(400) / 1000.0
    theta = np.sin(7 * t) * 1.5
    theta[0] = 0.0
    p = _european_csv(tmp_path / "de.csv", t, {"theta_m": theta}, first_row_integers)
    assert "0,00" in p.read_text() or first_row_integers
    tr = load_trace(p)
    np.testing.assert_array_equal(tr["theta_m"], theta)
    np.testing.assert_array_equal(tr["t"], t)
    streamed = np.concatenate([c["theta_m"] for c in iter_trace_chunks(p, chunk_rows=64)])
    np.testing.assert_array_equal(streamed, theta)
    # negative control: the same text comma-separated is not numbers (no guessing there)
    q = tmp_path / "comma.csv"
    q.write_text('t,theta_m\n"0,5","1,5"\n"1,5","2,5"\n')
    with pytest.raises(DataError, match=r"comma.csv, column 't', line 2: not a number: '0,5'"):
        load_trace(q)


def test_mixed_decimal_marks_are_refused_naming_the_cell(tmp_path):
    """A point in a decimal-comma file (``1.234,5`` or one row written elsewhere) is ambiguous:
    one line naming file, column, row and the cell; never a number read either way."""
    from drivelash.io.stream import iter_trace_chunks

    p = tmp_path / "mixed.csv"
    p.write_text("t;theta_m\n0,0;0,5\n0,001;1.5\n0,002;2,5\n")
    msg = (
        r"mixed.csv, column 'theta_m', line 3: decimal point in '1.5' where the file's numbers"
        r" have decimal commas"
    )
    with pytest.raises(DataError, match=msg):
        load_trace(p)
    with pytest.raises(DataError, match=msg):
        list(iter_trace_chunks(p, chunk_rows=2))


def test_csv_with_a_byte_order_mark_reads_its_first_column(tmp_path):
    """Excel's "CSV UTF-8" starts with a BOM: the first column is still ``t`` (before: "missing
    required column 't'"), whole and streamed, bit-identical to the file without it."""
    from drivelash.io.stream import iter_trace_chunks

    t = np.arange(300) / 1000.0
    body = "t,theta_m\n" + "".join(f"{float(a)!r},{float(np.sin(a))!r}\n" for a in t)
    plain = tmp_path / "plain.csv"
    plain.write_text(body)
    bom = tmp_path / "bom.csv"
    bom.write_bytes(b"\xef\xbb\xbf" + body.encode())
    ref = load_trace(plain)
    tr = load_trace(bom)
    assert tr.names == ref.names
    np.testing.assert_array_equal(tr["t"], ref["t"])
    np.testing.assert_array_equal(tr["theta_m"], ref["theta_m"])
    streamed = np.concatenate([c["t"] for c in iter_trace_chunks(bom, chunk_rows=64)])
    np.testing.assert_array_equal(streamed, t)


def test_utf16_and_spreadsheet_files_say_how_to_save_them(tmp_path):
    """A spreadsheet's "Unicode Text" (UTF-16) and an .xlsx: one line that names the fix."""
    u16 = tmp_path / "sheet.csv"
    u16.write_text("t\ttheta_m\n0\t0\n0.001\t0.5\n", encoding="utf-16")
    with pytest.raises(DataError, match=r"sheet.csv: wrong file type: .*UTF-16 text.*save it as CSV UTF-8"):
        load_trace(u16)
    x = tmp_path / "sheet.xlsx"
    x.write_bytes(b"PK\x03\x04")
    with pytest.raises(DataError, match=r"sheet.xlsx: unsupported file type '.xlsx'.*save the sheet as CSV"):
        load_trace(x)


PREAMBLE = "Drive trace export\nDate;27.11.2026\nAxis: X1\n\n"


@pytest.mark.parametrize("sep", [";", ","])
def test_a_tools_preamble_above_the_header_is_skipped_and_said(tmp_path, sep):
    """Lines a drive tool writes above the table (name, date, axis) are skipped: the same
    numbers as the file without them, whole and streamed, and a warning naming what was
    skipped (before: "column 'Drive', row 0: not a number")."""
    from drivelash.io.stream import iter_trace_chunks

    t = np.arange(500) / 1000.0
    body = f"t{sep}theta_m\n" + "".join(f"{float(a)!r}{sep}{float(np.cos(a))!r}\n" for a in t)
    plain = tmp_path / "plain.csv"
    plain.write_text(body)
    pre = tmp_path / "pre.csv"
    pre.write_text(PREAMBLE + body)
    ref, tr = load_trace(plain), load_trace(pre)
    np.testing.assert_array_equal(tr["theta_m"], ref["theta_m"])
    np.testing.assert_array_equal(tr["t"], ref["t"])
    warn = "skipped 3 line(s) above the column header (a preamble starting 'Drive trace export')"
    assert warn in tr.meta["warnings"]
    assert not ref.meta["warnings"]
    chunks = list(iter_trace_chunks(pre, chunk_rows=128))
    np.testing.assert_array_equal(np.concatenate([c["theta_m"] for c in chunks]), ref["theta_m"])
    assert warn in chunks[0].meta["warnings"]


def test_table_reader_keeps_the_preamble_warning(tmp_path):
    """Finding: a skipped preamble warned for a time series but not for a table (load_table
    replaced the reader's warnings with the mapping's)."""
    from drivelash.io.load import load_table

    body = "Target [mm],Run,Dir,Error [um]\n" + "".join(f"{x}.0,1,1,-1.5\n" for x in range(10))
    plain, pre = tmp_path / "plain.csv", tmp_path / "pre.csv"
    plain.write_text(body)
    pre.write_text(PREAMBLE + body)
    mapping = {
        "Target [mm]": {"column": "P_target", "unit": "mm"},
        "Error [um]": {"column": "x_dev", "unit": "um"},
    }
    warn = "skipped 3 line(s) above the column header (a preamble starting 'Drive trace export')"
    got = load_table(pre, mapping)
    assert warn in got.meta["warnings"]
    np.testing.assert_array_equal(got.columns["x_dev"], load_table(plain, mapping).columns["x_dev"])
    assert not load_table(plain, mapping).meta["warnings"]  # negative control: no preamble, no warning


def test_no_header_search_where_the_first_line_fits(tmp_path):
    """The search runs only when the first line's width differs from the next line's: a bad
    cell in the first data row is still named there (not taken as a header), and a preamble
    without a numeric table below it keeps the first line's error."""
    bad = tmp_path / "bad.csv"
    bad.write_text("t,theta_m\n0,abc\n0.001,0.5\n0.002,0.7\n")
    with pytest.raises(DataError, match=r"bad.csv, column 'theta_m', line 2: not a number: 'abc'"):
        load_trace(bad)
    junk = tmp_path / "junk.csv"
    junk.write_text(PREAMBLE + "t;theta_m\n0;x\n1;y\n")
    with pytest.raises(DataError, match=r"junk.csv, column 'Drive'"):
        load_trace(junk)


def _units_csv(path, units: str | None, *, head: str = "", sep: str = ";"):
    """t, theta_m, omega_m, torque_m in SI with an optional units row below the header."""
    t = np.arange(600) / 1000.0
    cols = [t, np.sin(t), np.cos(t), 0.3 * np.sin(3 * t)]
    rows = "".join(sep.join(repr(float(c[k])) for c in cols) + "\n" for k in range(t.size))
    names = sep.join(["t", "theta_m", "omega_m", "torque_m"])
    path.write_text(head + names + "\n" + (units + "\n" if units is not None else "") + rows)
    return path


def _both_ways(path, mapping=None):
    """theta_m and torque_m of ``path``, read whole and streamed (they must agree)."""
    from drivelash.io.stream import iter_trace_chunks

    whole = load_trace(path, mapping)
    chunks = list(iter_trace_chunks(path, mapping, chunk_rows=128))
    for n in ("t", "theta_m", "torque_m"):
        if n in whole.columns:
            np.testing.assert_array_equal(np.concatenate([c[n] for c in chunks]), whole[n])
    assert chunks[0].meta.get("column_units") == whole.meta.get("column_units")
    return whole


@pytest.mark.parametrize(
    "units",
    ["s;rad;rad/s;N·m", "[s];[rad];[rad/s];[Nm]", " (s) ; rad ; rad/s ; N.m ", ";rad;;Nm"],
)
def test_a_units_row_below_the_header_is_read_and_checked(tmp_path, units):
    """A DAQ's units row under the column names (``s;rad;rad/s;N·m``, bracketed or with the
    usual spellings of N·m) is not data: the same numbers as the file without it, whole and
    streamed, and the units it states are kept (before: "column 't', row 0: not a number")."""
    ref = load_trace(_units_csv(tmp_path / "plain.csv", None))
    tr = _both_ways(_units_csv(tmp_path / "units.csv", units))
    for n in ("t", "theta_m", "omega_m", "torque_m"):
        np.testing.assert_array_equal(tr[n], ref[n])
    from drivelash.io.formats import unit_name

    assert unit_name(tr.meta["column_units"]["theta_m"]) == "rad"  # kept as written ("[rad]")
    assert "column_units" not in ref.meta


@pytest.mark.parametrize("units", [False, True])
@pytest.mark.parametrize("pre", [PREAMBLE, "Recorder;Trace1\nSample time;0,001\n"])
def test_a_preamble_above_a_table_with_a_text_column(tmp_path, pre, units):
    """Session 30 tester A (M1): a preamble *and* a CNC's text status column together — each
    alone worked — failed: the header search wanted a row of numbers only below the header, so
    the first preamble line was taken for it ("column 'Trace', line 2: not a number: 'Axis:'",
    or "7 fields where the header names 2 columns" below a key;value preamble). Now the same
    numbers as the file without preamble and status column, whole and streamed."""
    from drivelash.io.stream import iter_trace_chunks

    t = np.arange(500) / 1000.0
    head = "t;theta_m;Status\n" + ("s;rad;-\n" if units else "")
    rows = "".join(f"{float(a)!r};{float(np.cos(a))!r};OK\n".replace(".", ",") for a in t)
    plain = tmp_path / "plain.csv"
    plain.write_text("t;theta_m\n" + "".join(f"{float(a)!r};{float(np.cos(a))!r}\n" for a in t))
    p = tmp_path / "status.csv"
    p.write_text(pre + head + rows)
    ref, tr = load_trace(plain), load_trace(p)
    np.testing.assert_array_equal(tr["theta_m"], ref["theta_m"])
    assert "Status" not in tr.columns
    n_pre = len(pre.strip().splitlines())
    assert any(f"skipped {n_pre} line(s) above the column header" in w for w in tr.meta["warnings"])
    chunks = list(iter_trace_chunks(p, chunk_rows=128))
    np.testing.assert_array_equal(np.concatenate([c["theta_m"] for c in chunks]), ref["theta_m"])


def test_a_units_row_below_a_preamble(tmp_path):
    """Preamble, names, units, numbers (a drive tool's export): both skipped, both said."""
    ref = load_trace(_units_csv(tmp_path / "plain.csv", None))
    tr = _both_ways(_units_csv(tmp_path / "pre.csv", "s;rad;rad/s;Nm", head=PREAMBLE))
    np.testing.assert_array_equal(tr["theta_m"], ref["theta_m"])
    assert any("skipped 3 line(s)" in w for w in tr.meta["warnings"])
    assert tr.meta["column_units"] == {"t": "s", "theta_m": "rad", "omega_m": "rad/s", "torque_m": "Nm"}


@pytest.mark.parametrize(
    ("units", "mapping", "message"),
    [
        # unmapped: read as SI under its Trace name, the file says degrees
        (
            "s;deg;rad/s;Nm",
            None,
            r"column 'theta_m': the file's units row says 'deg', but the column"
            r" would be read in 'rad'; map it in \[columns.theta_m\] with unit = 'deg'",
        ),
        # the time column in ms, [sampling] time_unit left at s
        (
            "ms;rad;rad/s;Nm",
            None,
            r"column 't': the file's units row says 'ms', but the column would"
            r" be read in 's'; set \[sampling\] time_unit = 'ms'",
        ),
        # mapped with another unit than the file states
        (
            "s;rad;rpm;Nm",
            {"omega_m": {"column": "omega_m", "unit": "rad/s"}},
            r"column 'omega_m': the file's units row says 'rpm', but the column would be read in"
            r" 'rad/s'; set unit = 'rpm' in \[columns.omega_m\]",
        ),
        # mapped without a unit (dimensionless, scale by hand): the stated unit must be declared
        (
            "s;deg;rad/s;Nm",
            {"theta_m": {"column": "theta_m", "scale": 0.0174533}},
            r"column 'theta_m': the file's units row says 'deg', but the column would be read in '1'",
        ),
        # a units row with a unit drivelash does not read
        (
            "s;rad;rad/s;kNm",
            None,
            r"column 'torque_m': the file's units row names 'kNm', not a unit drivelash reads",
        ),
    ],
)
def test_a_units_row_that_contradicts_the_reading_is_refused(tmp_path, units, mapping, message):
    """Where the file states a unit and the column would be read in another, one line naming
    the file, column, both units and where to declare it — never a silent factor of 57.3."""
    from drivelash.io.stream import iter_trace_chunks

    f = _units_csv(tmp_path / "u.csv", units)
    with pytest.raises(DataError, match=r"u\.csv, " + message):
        load_trace(f, mapping)
    with pytest.raises(DataError, match=r"u\.csv, " + message):
        list(iter_trace_chunks(f, mapping, chunk_rows=128))


def test_a_units_row_declared_in_the_mapping_converts(tmp_path):
    """The stated units declared in [columns] (spelled either way: ``Nm`` / ``N·m``): read
    and converted as any mapped column. Negative control: the same file read as SI is refused."""
    t = np.arange(600) / 1000.0
    deg = np.degrees(np.sin(t))
    f = tmp_path / "deg.csv"
    f.write_text(
        "t;pos;omega_m;torque_m\nms;°;rad/s;Nm\n"
        + "".join(
            f"{float(1e3 * a)!r};{float(b)!r};{float(np.cos(a))!r};{float(np.sin(3 * a))!r}\n"
            for a, b in zip(t, deg, strict=True)
        )
    )
    mapping = {
        "pos": {"column": "theta_m", "unit": "deg"},
        "t": {"column": "t", "unit": "ms"},
        "torque_m": {"column": "torque_m", "unit": "N·m"},
    }
    tr = _both_ways(f, mapping)
    np.testing.assert_allclose(tr["theta_m"], np.sin(t), rtol=0, atol=1e-15)
    np.testing.assert_allclose(tr["t"], t, rtol=0, atol=1e-15)
    with pytest.raises(DataError, match=r"column 't': the file's units row says 'ms'"):
        load_trace(f, {"pos": {"column": "theta_m", "unit": "deg"}})


def test_a_data_row_that_names_one_unit_is_still_data(tmp_path):
    """A units row has at least half of its cells naming units, and a number is never a unit:
    a first data row with bad cells keeps its error (``1;m;x`` is a value, a unit-like cell and
    a bad one — not a units row, so no row is dropped unseen)."""
    f = tmp_path / "bad.csv"
    f.write_text("t;theta_m;omega_m\n1;m;x\n0.001;0.5;1\n0.002;0.7;1\n")
    with pytest.raises(DataError, match=r"bad.csv, column 'theta_m', line 2: not a number: 'm'"):
        load_trace(f)


def test_a_unit_the_reader_does_not_know_matters_only_where_read(tmp_path):
    """An extra channel's unit (``°C`` of a temperature) is no reason to refuse the file while
    the channel is not read. A read column in a unit drivelash does not know (``kNm``) is refused
    where it would be read as SI, and read with a warning where the user's mapping states unit
    and scale. ``%`` (a drive trace's torque in % of rated) is dimensionless: SI refused with
    the hint to map it with its scale; mapped as unit "1" with the scale, read silently."""
    t = np.arange(600) / 1000.0
    tq = 0.4 * np.sin(3 * t)

    def write(name, unit, values):
        f = tmp_path / name
        f.write_text(
            f"t;theta_m;omega_m;torque_m;temp\ns;rad;rad/s;{unit};°C\n"
            + "".join(
                f"{float(a)!r};{float(np.sin(a))!r};{float(np.cos(a))!r};{float(v)!r};21.5\n"
                for a, v in zip(t, values, strict=True)
            )
        )
        return f

    plain = load_trace(write("nm.csv", "Nm", tq))
    np.testing.assert_array_equal(plain["torque_m"], np.array([float(v) for v in tq]))
    assert plain.meta["column_units"]["temp"] == "°C" and not plain.meta["warnings"]
    knm = write("knm.csv", "kNm", tq / 1e3)
    with pytest.raises(
        DataError,
        match=r"knm.csv, column 'torque_m': the file's units row names 'kNm', not a unit drivelash reads"
        r" .*map it in \[columns.torque_m\] with the unit and scale to SI",
    ):
        load_trace(knm)
    tr = _both_ways(knm, {"torque_m": {"column": "torque_m", "unit": "N·m", "scale": 1000.0}})
    np.testing.assert_allclose(tr["torque_m"], tq, rtol=1e-15, atol=0)
    assert tr.meta["warnings"] == [
        f"{knm}, column 'torque_m': the file's units row names 'kNm', which drivelash cannot check;"
        " read as [columns.torque_m] unit = 'N·m' with its scale"
    ]
    pct = write("pct.csv", "%", 100.0 * tq / 2.0)  # rated torque 2 N·m
    with pytest.raises(
        DataError,
        match=r"says '%', but .* map it in \[columns.torque_m\] with unit = '1'" r" and its scale to SI",
    ):
        load_trace(pct)
    tr = _both_ways(pct, {"torque_m": {"column": "torque_m", "unit": "1", "scale": 0.02}})
    np.testing.assert_allclose(tr["torque_m"], tq, rtol=1e-14, atol=1e-17)
    assert not tr.meta["warnings"]


@pytest.mark.parametrize("fmt", ["hdf5", "parquet"])
def test_a_unit_attribute_is_checked_like_a_units_row(tmp_path, fmt):
    """An HDF5 dataset's ``units`` attribute or a Parquet field's ``unit`` metadata states the
    column's unit the same way: degrees read as rad refused (naming where the file says it),
    declared in the mapping converted. Negative control: the same file without the attribute
    is read as rad without a word: with no velocity column to compare against (the plausibility
    check of theta against omega), the statement is the only evidence."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    t = np.arange(600) / 1000.0
    deg = np.degrees(np.sin(t))

    def write(path, unit):
        if fmt == "hdf5":
            with h5py.File(path, "w") as f:
                f["t"], f["theta_m"], f["torque_m"] = t, deg, np.cos(t)
                if unit:
                    f["theta_m"].attrs["units"] = unit
        else:
            tab = pa.table({"t": t, "theta_m": deg, "torque_m": np.cos(t)})
            if unit:
                tab = tab.cast(tab.schema.set(1, tab.schema.field(1).with_metadata({b"unit": unit.encode()})))
            pq.write_table(tab, path)
        return path

    f = write(tmp_path / f"a.{'h5' if fmt == 'hdf5' else 'parquet'}", "deg")
    where = "unit attribute" if fmt == "hdf5" else "unit metadata"
    with pytest.raises(
        DataError, match=rf"column 'theta_m': the file's {where} says 'deg', but the column would"
    ):
        load_trace(f)
    tr = load_trace(f, {"theta_m": {"column": "theta_m", "unit": "deg"}})
    np.testing.assert_allclose(tr["theta_m"], np.sin(t), rtol=0, atol=1e-15)
    bare = load_trace(write(tmp_path / f"b.{'h5' if fmt == 'hdf5' else 'parquet'}", None))
    np.testing.assert_array_equal(bare["theta_m"], deg)  # no statement: nothing to check against


def test_stated_units_of_a_source_are_not_checked_again_on_a_written_trace(tmp_path):
    """A trace loaded from a file whose units row says ``ms`` (mapped: read as s) and written
    back by drivelash keeps that provenance in its metadata; reading the written file does not
    check its seconds against the source's ``ms``."""
    t = np.arange(600) / 1000.0
    f = tmp_path / "ms.csv"
    f.write_text(
        "t;theta_m;omega_m\nms;rad;rad/s\n"
        + "".join(f"{float(1e3 * a)!r};{float(np.sin(a))!r};{float(np.cos(a))!r}\n" for a in t)
    )
    tr = load_trace(f, {"t": {"column": "t", "unit": "ms"}})
    assert tr.meta["column_units"]["t"] == "ms"
    for ext in ("csv", "parquet", "h5"):
        back = load_trace(write_trace(tr, tmp_path / f"back.{ext}"))
        np.testing.assert_array_equal(back["t"], tr["t"])
        assert "column_units" not in back.meta


def _stamped_csv(path, t, theta, sep=","):
    import pandas as pd

    stamps = (pd.Timestamp("2026-11-27 13:00:00") + pd.to_timedelta(t, unit="s")).strftime(
        "%Y-%m-%d %H:%M:%S.%f"
    )
    path.write_text(
        f"time{sep}theta_m\n" + "".join(f"{a}{sep}{float(b)!r}\n" for a, b in zip(stamps, theta, strict=True))
    )
    return path


def test_iso_time_stamps_are_seconds_from_the_first(tmp_path):
    """A logger's time column of ISO 8601 stamps (``2026-11-27 13:00:00.125000``) is read as
    seconds from the first stamp (exact to the µs the file holds), whole and streamed; the
    first stamp is kept in ``meta["time_origin"]``."""
    from drivelash.io.stream import iter_trace_chunks

    t = np.arange(600) * 1e-3
    theta = np.sin(3 * t)
    p = _stamped_csv(tmp_path / "stamped.csv", t, theta)
    tr = load_trace(p)
    np.testing.assert_allclose(tr["t"], t, rtol=0, atol=1e-12)
    assert tr.T_s == pytest.approx(1e-3, rel=1e-12)
    np.testing.assert_array_equal(tr["theta_m"], theta)
    assert tr.meta["time_origin"] == {"time": "2026-11-27T13:00:00"}  # no zone in the file: none added
    streamed = np.concatenate([c["t"] for c in iter_trace_chunks(p, chunk_rows=100)])
    np.testing.assert_array_equal(streamed, tr["t"])
    # in a ';' file with decimal commas the stamps keep their decimal point
    q = tmp_path / "de.csv"
    q.write_text(p.read_text().replace(",", ";").replace(";0.", ";0,").replace(";-0.", ";-0,"))
    np.testing.assert_allclose(load_trace(q)["theta_m"], theta, rtol=0, atol=0)


def test_dotted_day_first_time_stamps_are_read_as_iso(tmp_path):
    """A German-locale tool's stamps (``27.11.2026 13:00:00,125``, day first, comma before the
    milliseconds, values with decimal commas) are the same times as ISO 8601 stamps: identical
    seconds, whole and streamed, the first stamp in ``meta["time_origin"]``. Negative control:
    the ISO file of the same times gives the same array."""
    import pandas as pd

    from drivelash.io.stream import iter_trace_chunks

    t = np.arange(600) * 1e-3
    theta = np.round(np.sin(3 * t), 9)
    stamps = pd.Timestamp("2026-11-05 07:03:00") + pd.to_timedelta(t, unit="s")
    dotted = [f"{a.strftime('%d.%m.%Y %H:%M:%S')},{a.microsecond // 1000:03d}" for a in stamps]
    p = tmp_path / "dotted.csv"
    p.write_text(
        "time;theta_m\n"
        + "".join(
            f"{a};{float(b)!r}\n".replace(".", ",").replace(",", ".", 2)
            for a, b in zip(dotted, theta, strict=True)
        )
    )
    assert p.read_text().splitlines()[2] == "05.11.2026 07:03:00,001;0,002999996"
    iso = _stamped_csv(tmp_path / "iso.csv", t, theta)
    tr, ref = load_trace(p), load_trace(iso)
    np.testing.assert_array_equal(tr["t"], ref["t"])
    np.testing.assert_array_equal(tr["theta_m"], theta)
    assert tr.meta["time_origin"] == {"time": "2026-11-05T07:03:00"}
    np.testing.assert_array_equal(
        np.concatenate([c["t"] for c in iter_trace_chunks(p, chunk_rows=100)]), tr["t"]
    )


@pytest.mark.parametrize("layout", ["iso", "daq", "daq-dash"])
def test_a_preamble_above_time_stamped_rows_is_found(tmp_path, layout):
    """The header below a preamble is found when the rows under it start with time stamps
    (before: the rows had to be all numbers, so the first preamble line became the header and
    'decimal point in 05.11.2026' was reported). ``daq``: a German DAQ export as written —
    preamble, names, a units row with an empty time cell and an unread °C channel, dotted
    stamps with a comma before the fraction, decimal commas; mapped by a config, the same
    numbers as the SI file, whole and streamed. ``daq-dash``: the units row writes ``-`` above
    the stamps (before: refused, and the fix it named — unit = '1' — was refused too)."""
    import pandas as pd

    t = np.arange(600) * 1e-3
    theta = np.sin(3 * t)
    stamps = pd.Timestamp("2026-11-05 07:03:00") + pd.to_timedelta(t, unit="s")
    if layout == "iso":
        cells = [
            (a.strftime("%Y-%m-%d %H:%M:%S.%f"), repr(float(b))) for a, b in zip(stamps, theta, strict=True)
        ]
        text = PREAMBLE + "time;theta_m\n" + "".join(f"{a};{b}\n" for a, b in cells)
        mapping = None
    else:
        cells = [
            (
                f"{a.strftime('%d.%m.%Y %H:%M:%S')},{a.microsecond:06d}",
                repr(float(np.degrees(b))).replace(".", ","),
            )
            for a, b in zip(stamps, theta, strict=True)
        ]
        dash = "-" if layout == "daq-dash" else ""
        text = PREAMBLE + f"Zeit;Pos;Temp\n{dash};°;°C\n" + "".join(f"{a};{b};21,5\n" for a, b in cells)
        mapping = {"Zeit": {"column": "t", "unit": "s"}, "Pos": {"column": "theta_m", "unit": "deg"}}
    f = tmp_path / f"{layout}.csv"
    f.write_text(text)
    tr = _both_ways(f, mapping)
    np.testing.assert_allclose(tr["t"], t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(tr["theta_m"], theta, rtol=0, atol=1e-15 if layout.startswith("daq") else 0)
    assert any("skipped 3 line(s)" in w for w in tr.meta["warnings"])


@pytest.mark.parametrize("units", [False, True])
def test_a_key_value_preamble_is_skipped(tmp_path, units):
    """``Maschine;M01`` / ``Achse;X`` above the table (a drive tool's key;value lines, as wide
    as each other): before, the first of them was taken as the header ("column 'Maschine'").
    The table is found among lines of another width, whole and streamed. A first data row with
    a bad cell under a fitting header is still named there (no search: it holds a number)."""
    ref = load_trace(_units_csv(tmp_path / "plain.csv", None))
    head = "Maschine;M01\nAchse;X\nDatum;27.11.2026\n\n"
    f = _units_csv(tmp_path / "kv.csv", "s;rad;rad/s;Nm" if units else None, head=head)
    tr = _both_ways(f)
    np.testing.assert_array_equal(tr["theta_m"], ref["theta_m"])
    assert any(
        "skipped 3 line(s) above the column header (a preamble starting 'Maschine;M01')" in w
        for w in tr.meta["warnings"]
    )
    bad = tmp_path / "bad.csv"
    bad.write_text("t;theta_m;omega_m\n0;abc;x\n0.001;0.5;1\n")
    with pytest.raises(DataError, match=r"bad.csv, column 'theta_m', line 2: not a number: 'abc'"):
        load_trace(bad)


def test_a_date_with_slashes_is_named_not_guessed(tmp_path):
    """``11/05/2026`` is 5 November or 11 May: not guessed, one line saying why and what to write."""
    p = tmp_path / "slashed.csv"
    p.write_text("time,theta_m\n11/05/2026 07:03:00.000,0.1\n11/05/2026 07:03:00.001,0.2\n")
    with pytest.raises(
        DataError,
        match=r"slashed.csv, column 'time', line 2: a date with slashes .* is not read: "
        r"month/day or day/month is not known; write ISO 8601",
    ):
        load_trace(p)


def test_time_stamps_refuse_a_time_unit_and_name_a_bad_stamp(tmp_path):
    """Seconds from stamps scaled again by ``time_unit = "ms"`` would be a silent factor 1000:
    refused, whole and streamed. A cell that is not a stamp is named by its row."""
    from drivelash.io.stream import iter_trace_chunks

    t = np.arange(50) * 1e-3
    p = _stamped_csv(tmp_path / "stamped.csv", t, np.cos(t))
    msg = r"stamped.csv, column 'time': holds ISO 8601 time stamps .* its unit is 's', not 'ms'"
    with pytest.raises(DataError, match=msg):
        load_trace(p, _ms_config(tmp_path))
    with pytest.raises(DataError, match=msg):
        list(iter_trace_chunks(p, _ms_config(tmp_path)))
    with pytest.raises(DataError, match=msg):
        load_trace(p, {"time": {"column": "t", "unit": "ms"}, "theta_m": {"column": "theta_m"}})
    # mapped in s: the seconds as read
    tr = load_trace(p, {"time": {"column": "t", "unit": "s"}, "theta_m": {"column": "theta_m"}})
    np.testing.assert_allclose(tr["t"], t, rtol=0, atol=1e-12)
    text = p.read_text().splitlines()
    text[4] = "13:00:00.003," + text[4].split(",")[1]
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(text) + "\n")
    with pytest.raises(
        DataError, match=r"bad.csv, column 'time', line 5: not an ISO 8601 time: '13:00:00.003'"
    ):
        load_trace(bad)


def _ms_config(tmp_path):
    from drivelash.io.config import load_config

    c = tmp_path / "ms.toml"
    c.write_text('[sampling]\ntime_unit = "ms"\n')
    return load_config(c)


def test_time_stamped_file_over_the_budget_says_why_it_is_read_whole(tmp_path, monkeypatch):
    """Time stamps are read by the strict (whole-file) reader: over the memory budget the
    one-line error names the stamps as the reason and Parquet as the way out."""
    from drivelash.io.stream import iter_trace_chunks

    t = np.arange(20000) * 1e-3
    p = _stamped_csv(tmp_path / "big.csv", t, np.sin(t))
    monkeypatch.setenv("DRIVELASH_MEMORY_BUDGET", "1M")
    with pytest.raises(DrivelashError, match=r"strict pass \(time stamps in column 'time'\).*Parquet"):
        list(iter_trace_chunks(p))


def test_rows_wider_than_the_header_are_refused_not_shifted(tmp_path):
    """A header naming 2 columns above rows of 3 fields: pandas would take the first field as
    an index and shift every column (t read from the second field) — a silent wrong number.
    One line naming the row instead, whole and streamed."""
    from drivelash.io.stream import iter_trace_chunks

    p = tmp_path / "wide.csv"
    p.write_text("t,theta_m\n0,1,2\n0.001,1.1,2.1\n0.002,1.2,2.2\n")
    msg = r"wide.csv, line 2: 3 fields where the header names 2 columns"
    with pytest.raises(DataError, match=msg):
        load_trace(p)
    with pytest.raises(DataError, match=msg):
        list(iter_trace_chunks(p))


@pytest.mark.parametrize(
    ("name", "text"),
    [
        ("every_row.csv", "t,theta_m,\n{rows}"),  # a separator ending every line, header too
        ("data_rows.csv", "t,theta_m\n{rows}"),  # ... only the data rows
        ("empty_rows.csv", "t;theta_m\n{rows_sc};;\n;;\n"),  # a spreadsheet's empty rows at the end
    ],
)
def test_trailing_separators_and_empty_rows_hold_no_value(tmp_path, name, text):
    """Separators at the end of every row and rows of separators only at the end of the file
    (spreadsheet exports) carry no value: the same numbers as the clean file, whole and streamed
    (before: "row 0: empty field" without a column name, or "row 399: empty field")."""
    from drivelash.io.stream import iter_trace_chunks

    t = np.arange(400) / 1000.0
    x = np.sin(t)
    rows = "".join(f"{float(a)!r},{float(b)!r},\n" for a, b in zip(t, x, strict=True))
    rows_sc = "".join(f"{float(a)!r};{float(b)!r};\n" for a, b in zip(t, x, strict=True))
    p = tmp_path / name
    p.write_text(text.format(rows=rows, rows_sc=rows_sc))
    tr = load_trace(p)
    assert tr.names == ["t", "theta_m"]
    np.testing.assert_array_equal(tr["t"], t)
    np.testing.assert_array_equal(tr["theta_m"], x)
    streamed = np.concatenate([c["theta_m"] for c in iter_trace_chunks(p, chunk_rows=100)])
    np.testing.assert_array_equal(streamed, x)


@pytest.mark.parametrize("tz", [None, "Europe/Berlin"])
@pytest.mark.parametrize("as_index", [False, True])
def test_parquet_time_stamp_column_is_seconds_from_the_first(tmp_path, tz, as_index):
    """A pandas datetime64 column (or index) written to Parquet is the time axis in seconds from
    its first stamp, whole and streamed, like ISO 8601 stamps in a CSV (before: the column was
    dropped — "missing required column 't'" for a file that has one)."""
    import pandas as pd

    from drivelash.io.stream import iter_trace_chunks

    t = np.arange(3000) * 125e-6
    stamps = pd.Timestamp("2026-11-27 13:00:00", tz=tz) + pd.to_timedelta(t, unit="s")
    df = pd.DataFrame({"t": stamps, "theta_m": np.sin(5 * t)})
    p = tmp_path / "stamped.parquet"
    (df.set_index("t") if as_index else df).to_parquet(p)
    tr = load_trace(p)
    # the stamps hold whole nanoseconds (pandas rounded t to them): exactly those, in seconds
    np.testing.assert_array_equal(tr["t"], (stamps - stamps[0]).asi8 / 1e9)
    np.testing.assert_allclose(tr["t"], t, rtol=0, atol=1.5e-9)  # pandas truncates t to whole ns
    assert tr.T_s == pytest.approx(125e-6, rel=1e-9)
    np.testing.assert_array_equal(tr["theta_m"], np.sin(5 * t))
    assert tr.meta["time_origin"]["t"].startswith("2026-11-27T13:00:00")
    streamed = np.concatenate([c["t"] for c in iter_trace_chunks(p, chunk_rows=700)])
    np.testing.assert_array_equal(streamed, tr["t"])
    with pytest.raises(DataError, match=r"column 't': holds ISO 8601 time stamps .* not 'ms'"):
        load_trace(p, _ms_config(tmp_path))


def test_windows_1252_csv_is_named_with_byte_line_and_the_fix(tmp_path):
    """Finding: a CSV saved by Excel on Windows (µ as byte 0xB5 in its header) was called
    "unrecognised binary data"."""
    p = tmp_path / "latin1.csv"
    p.write_bytes("Target [mm],Run,Dir,Error [µm]\r\n0.0,1,1,-3.699\r\n50.0,1,1,-2.461\r\n".encode("cp1252"))
    with pytest.raises(DataError) as ei:
        read_raw(p)
    msg = str(ei.value)
    assert msg == (
        f"{p}: not UTF-8 text (byte 0xB5 at line 1, position 28 — Windows-1252 'µ'?): save it as CSV UTF-8"
    )
    deg = tmp_path / "deg.csv"
    deg.write_bytes("t,theta_m [°]\n0,1\n".encode("cp1252"))
    with pytest.raises(DataError, match=r"byte 0xB0 at line 1, position 12 — Windows-1252 '°'"):
        read_raw(deg)
    # negative controls: binary data stays binary; the same header in UTF-8 is read
    b = tmp_path / "bin.csv"
    b.write_bytes(bytes(range(1, 256)) * 4)
    with pytest.raises(DataError, match="unrecognised binary data"):
        read_raw(b)
    p.write_bytes("Target [mm],Run,Dir,Error [µm]\r\n0.0,1,1,-3.699\r\n50.0,1,1,-2.461\r\n".encode())
    assert "Error [µm]" in read_raw(p).columns


@pytest.mark.parametrize(
    "head",
    [
        "Renishaw XL-80\nMachine;DMU 65\nDate;27.11.2026 13:00\n",  # title + key;value lines
        "Date;27.11.2026 13:00\nTemp;20,3\n",  # key;value lines with a number as the value
        # a title as wide (at its spaces) as the table, key;value lines, a blank line
        "Renishaw XL-80 linear measurement\nMachine;DMU 65 X axis\nDate;27.11.2026 13:00\n"
        "Material temperature;20,3 °C\n\n",
    ],
)
def test_a_laser_export_preamble_is_skipped(tmp_path, head):
    """Found by an exploratory tester (s19 F3): the usual head of a laser/DAQ export — a title
    line, then ``key;value`` lines (date, temperature) — was not skipped though the README says
    a preamble is: the title (``Renishaw XL-80`` splits at its space like ``Machine;DMU 65``) or
    ``Date;…`` over ``Temp;20,3`` looked like a header over a data row, and the error blamed
    the real header ("line 4: 3 fields where the header names 2 columns") or a preamble line
    ("column 'Renishaw' … decimal point in 'Date;27.11.2026'"). Now: the same numbers as the
    file without it, whole and streamed, and the warning. On the old code each case raises."""
    t = np.arange(600) / 1000.0
    body = "t;theta_m;omega_m;torque_m\n" + "".join(
        ";".join(repr(float(v)).replace(".", ",") for v in (a, np.sin(a), np.cos(a), 0.3 * a)) + "\n"
        for a in t
    )
    plain, pre = tmp_path / "plain.csv", tmp_path / "pre.csv"
    plain.write_text(body, encoding="utf-8")
    pre.write_text(head + body, encoding="utf-8")
    ref = load_trace(plain)
    tr = _both_ways(pre)
    np.testing.assert_array_equal(tr["theta_m"], ref["theta_m"])
    np.testing.assert_array_equal(tr["torque_m"], ref["torque_m"])
    n = len([ln for ln in head.splitlines() if ln.strip()])
    first = head.splitlines()[0]
    assert f"skipped {n} line(s) above the column header (a preamble starting {first[:40]!r}" in " ".join(
        tr.meta["warnings"]
    )
    assert not ref.meta["warnings"]  # negative control: no preamble, no warning
