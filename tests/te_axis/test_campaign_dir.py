"""The campaign directory: the published manifest schema and its one-line errors (issue 12 item 2, issue 15).

An imported campaign of the synthetic axis is written once; each test breaks one thing in a
copy and checks that reading it (or ``te fit``) fails with one line naming file and key —
never a traceback, never a file outside the directory.
"""

from __future__ import annotations

import dataclasses
import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from drivelash.errors import DataError
from drivelash.io.campaign import CampaignManifest, read_manifest
from drivelash.te.protocol.campaign import load_campaign
from drivelash.te.protocol.importer import import_campaign

from .synth import Run, standard_runs, write_axis

EXE = Path(sys.executable).parent / "drivelash"
SHORT = {"lo": 0.05, "hi": 0.3}


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("imported")
    runs = [dataclasses.replace(r, **SHORT) for r in standard_runs()]
    runs.append(Run("sine", 0, 0.0, 0.05, **SHORT))
    axis = write_axis(root / "rec", runs)
    out = root / "camp"
    import_campaign(axis, out)
    return out


def _copy(campaign: Path, tmp_path: Path) -> Path:
    d = tmp_path / "c"
    shutil.copytree(campaign, d)
    return d


def _edit(d: Path, fn) -> None:
    m = json.loads((d / "manifest.json").read_text())
    fn(m)
    (d / "manifest.json").write_text(json.dumps(m))


def test_imported_campaign_follows_the_published_schema(campaign):
    m = json.loads((campaign / "manifest.json").read_text())
    assert m["format"] == "drivelash.te-campaign" and m["version"] == 2 and m["source"] == "imported"
    assert "simulator" not in m and "seed" not in json.dumps(m)  # no seed, no true TE
    # docs/te-formats.md §2: the keys of the example; gains unknown here, so left out (not null)
    assert set(m) == {"format", "version", "generator", "source", "axis", "columns", "runs", "import"}
    assert set(m["axis"]) == {"geometry", "drive"}
    assert set(m["import"]) >= {"axis_file", "max_load", "plausibility"}
    run_keys = {"file", "kind", "direction", "velocity", "load", "samples", "duration", "recording"}
    assert set(m["runs"][0]) == run_keys
    assert m["generator"].startswith("drivelash ")
    doc = CampaignManifest.model_validate(m)
    assert doc.loads == (0.0, 1000.0, 2000.0, 3000.0) and doc.velocities == (0.1,)
    assert [r.kind for r in doc.runs].count("sine") == 1
    camp = load_campaign(campaign)
    assert not camp.is_simulated and camp.gains is None
    tr = camp.runs[2].trace()
    assert set(tr.names) >= {"t", "x_T", "theta_m", "torque_m", "x_d", "F_load", "direction"}
    assert np.all(tr["F_load"] == 0.0) and np.all(tr["direction"] == 1.0)
    with pytest.raises(DataError, match="imported campaign has no simulator"):
        camp.true_te_model()


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (lambda m: m["runs"][0].pop("load"), "key 'runs[0].load': missing"),
        (lambda m: m.update(runs={"file": "x"}), "key 'runs': Input should be a valid list"),
        (lambda m: m["runs"].__setitem__(1, ["a", "b"]), "key 'runs[1]': Input should be a valid dictionary"),
        (lambda m: m["axis"]["geometry"].update(travel=-1.0), "key 'axis.geometry': RackGeometry.travel"),
        (lambda m: m["axis"]["geometry"].update(travl=1.0), "key 'axis.geometry.travl': unknown key"),
        (lambda m: m["runs"][0].update(velocity=float("nan")), "non-standard JSON constant NaN"),
        (lambda m: m["runs"][0].update(velocity=1e9), "key 'runs[0].velocity': Input should be less than"),
        (lambda m: m["runs"][0].update(direction=0), "runs[0]': direction 0 does not fit kind 'geometric'"),
        (lambda m: m.update(version=7), "unsupported campaign format version 7"),
        (lambda m: m["columns"].remove("theta_m"), "missing required column 'theta_m'"),
        (lambda m: m["runs"][0].update(file="../../../../etc/hostname.parquet"), "outside the directory"),
        (lambda m: m["runs"][0].update(file="/etc/hostname.parquet"), "outside the directory"),
        (lambda m: m["runs"][0].update(file="../../../../etc/hostname"), "must be a Parquet trace"),
    ],
)
def test_bad_manifests_are_one_line_errors(campaign, tmp_path, edit, needle):
    d = _copy(campaign, tmp_path)
    _edit(d, edit)
    with pytest.raises(DataError) as exc:
        load_campaign(d)
    msg = str(exc.value)
    assert needle in msg and "manifest.json" in msg and "\n" not in msg


def test_a_run_file_that_leads_out_through_a_symlink_is_refused(campaign, tmp_path):
    d = _copy(campaign, tmp_path)
    name = json.loads((d / "manifest.json").read_text())["runs"][0]["file"]
    outside = tmp_path / "outside.parquet"
    shutil.copy(d / name, outside)
    (d / name).unlink()
    (d / name).symlink_to(outside)
    with pytest.raises(DataError, match="leads outside the directory"):
        load_campaign(d)


@pytest.mark.parametrize("damage", ["truncated", "empty", "nan", "no-column"])
def test_damaged_run_files_are_one_line_errors(campaign, tmp_path, damage):
    import pyarrow as pa
    import pyarrow.parquet as pq

    d = _copy(campaign, tmp_path)
    camp = load_campaign(d)
    run = camp.runs[3]
    if damage == "truncated":
        data = run.path.read_bytes()
        run.path.write_bytes(data[: len(data) // 2])
    elif damage == "empty":
        run.path.write_bytes(b"")
    else:
        tab = pq.read_table(run.path)
        if damage == "nan":  # one NaN: refused, never silently dropped with its neighbourhood
            x = tab.column("x_T").to_numpy().copy()
            x[1234] = np.nan
            tab = tab.set_column(tab.schema.get_field_index("x_T"), "x_T", pa.array(x))
        else:
            tab = tab.drop(["theta_m"])
        pq.write_table(tab, run.path)
    with pytest.raises(DataError) as exc:
        run.trace()
    msg = str(exc.value)
    assert run.path.name in msg and "\n" not in msg
    if damage == "nan":
        assert "column 'x_T', data row 1235 (1-based)" in msg and "NaN" in msg
    if damage == "no-column":
        assert "theta_m" in msg


def test_te_fit_refuses_a_traversal_with_one_line_and_writes_nothing(campaign, tmp_path):
    d = _copy(campaign, tmp_path)
    _edit(d, lambda m: m["runs"][0].update(file="../../../../etc/hostname.parquet"))
    r = subprocess.run(
        [str(EXE), "te", "fit", str(d), "-o", str(tmp_path / "m")], capture_output=True, text=True
    )
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert "runs[0].file" in r.stderr and "outside the directory" in r.stderr
    assert not (tmp_path / "m").exists()


def test_first_release_manifest_is_read(campaign, tmp_path):
    """An unversioned (v1) simulator manifest of the first release is converted on reading."""
    from drivelash.physics.rack_pinion import RackPinionBench

    d = _copy(campaign, tmp_path)
    m = json.loads((d / "manifest.json").read_text())
    v1 = {
        "format": "drivelash.te_campaign/1", "seed": 4, "bench": RackPinionBench().to_dict(),
        "te_model": {"defects": []}, "te_generator": {}, "gains": None, "sim_config": {}, "campaign": {},
        "store_rate": 1000.0, "columns": m["columns"],
        "runs": [{**r, "seed": 4} for r in m["runs"]],
    }  # fmt: skip
    (d / "manifest.json").write_text(json.dumps(v1))
    man = read_manifest(d)
    assert man.source == "simulated" and man.simulator["seed"] == 4 and len(man.runs) == len(m["runs"])
