"""Every result says how it was made (``provenance``), and ``load_result`` reads it back."""

import hashlib
import json
import os
from datetime import datetime

import fmuid
from fmuid.cli import main
from fmuid.data import load_experiment, load_spec
from msd_study import write_msd_study


def _sha256(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_fit_records_how_it_was_made_and_reads_it_back(msd_fmu, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_msd_study(tmp_path)
    spec = load_spec("spec.json")
    result = fmuid.fit(msd_fmu, [load_experiment("step.csv")], spec)
    block = result.to_dict()["provenance"]
    assert block["fmuid_version"] == fmuid.__version__
    assert block["fmu_sha256"] == _sha256(msd_fmu)
    assert block["seed"] == spec.seed
    assert block["spec_sha256"] == hashlib.sha256(spec.model_dump_json().encode()).hexdigest()
    assert block["data"] == [
        {"name": "step.csv", "sha256": _sha256(tmp_path / "step.csv"), "of": "file"}
    ]
    assert block["options"]["global_search"] == spec.global_search
    started, finished = (datetime.fromisoformat(block[k]) for k in ("started", "finished"))
    assert started <= finished and started.utcoffset().total_seconds() == 0
    assert block["machine"]["cores"] == os.cpu_count()
    path = tmp_path / "fit.json"
    path.write_text(json.dumps(result.to_dict()))
    loaded = fmuid.load_result(path)
    assert loaded.provenance == result.provenance
    assert loaded.to_dict() == json.loads(path.read_text())


def test_the_command_line_writes_the_block(msd_fmu, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    write_msd_study(tmp_path)
    args = ["fit", "--fmu", str(msd_fmu), "--data", "step.csv", "--spec", "spec.json"]
    assert main([*args, "--out", "r.json"]) == 0
    block = json.loads((tmp_path / "r.json").read_text())["provenance"]
    assert block["fmu_sha256"] == _sha256(msd_fmu)
    assert block["data"][0]["sha256"] == _sha256(tmp_path / "step.csv")
    assert fmuid.load_result(tmp_path / "r.json").provenance.fmu_sha256 == _sha256(msd_fmu)
