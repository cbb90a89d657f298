"""Two axes whose ``recordings`` globs match the same files are refused before anything is
written (exploration: a copy-pasted glob estimated M02/X from M01/X's files with M02/X's drive
parameters and raised a false threshold alarm)."""

from __future__ import annotations

import shutil

import pytest

from drivelash.errors import ConfigError
from drivelash.wear import Store, ingest, load_fleet

from .conftest import ingest_here
from .test_redate_duplicates import FILENAME_TIME, _tiny


def _two_axes(small_fleet, dst, second_glob: str):
    f = _tiny(small_fleet, dst, FILENAME_TIME)  # M01/X on rec/*.parquet
    # M02/X gets M01/X's drive: its recording in the negative control below is a copy of an
    # M01/X recording, which M02/X's own drive (N = 3) contradicts (named since s20 B6)
    shutil.copy(small_fleet / "drives" / "M01-X.toml", dst / "drives" / "M02-X.toml")
    (dst / "rec2").mkdir()
    shutil.copy(next((dst / "rec").iterdir()), dst / "rec2")
    f.write_text(
        f.read_text()
        + '[[axis]]\nid = "M02/X"\ndrive = "drives/M02-X.toml"\n'
        + f'recordings = "{second_glob}"\nthreshold = 0.2\n'
    )
    return f


def test_cli_a_file_of_two_axes_is_refused_nothing_written(small_fleet, tmp_path, capsys):
    f = _two_axes(small_fleet, tmp_path / "f", "rec/*.parquet")  # the copy-paste slip
    db = tmp_path / "w.sqlite"
    r = ingest_here(f, db, capsys)
    assert r.returncode == 2, r.stderr
    err = r.stderr.strip()
    assert "\n" not in err and err.startswith(f"drivelash: error: {f}: "), err
    assert "'M01/X'" in err and "'M02/X'" in err and "key 'recordings'" in err
    assert str(tmp_path / "f" / "rec") in err and ".parquet is matched by" in err
    assert "nothing was written" in err and not db.exists()
    # negative control: M02/X on its own directory (a copy of the same content is another file)
    f2 = _two_axes(small_fleet, tmp_path / "g", "rec2/*.parquet")
    r = ingest_here(f2, db, capsys)
    assert r.returncode == 0, r.stderr
    assert {r["axis"] for r in Store(db, create=False).estimates()} == {"M01/X", "M02/X"}


def test_api_refuses_a_shared_file_reached_by_another_path(small_fleet, tmp_path):
    """The same file under another spelling of its path (``rec/../rec``) is still the same file."""
    f = _two_axes(small_fleet, tmp_path / "f", "rec2/../rec/*.parquet")
    st = Store(tmp_path / "w.sqlite")
    with pytest.raises(ConfigError, match=r"\[\[axis\]\] #2 \(id 'M02/X'\).*#1 \(id 'M01/X'\)"):
        ingest(load_fleet(f), st, workers=1)
    assert st.counts() == dict.fromkeys(("axis", "recording", "estimate", "measurement", "alarm"), 0)
