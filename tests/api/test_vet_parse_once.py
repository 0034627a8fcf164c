"""Vetting an upload parses and hashes the FMU once; its binary probe gets the parsed facts."""

import json
import shutil

from fmuid.jobs.vet import VetTask, vet
from fmuid.model.fmu import FmuModel

SPEC = {
    "parameters": {"k": {"start": 4.0, "lower": 0.1, "upper": 20.0}},
    "inputs": ["f"],
    "outputs": {"x": {"sigma": 0.1}},
}


def _task(tmp_path, msd_file, step_csv, fmu_name):
    (tmp_path / "data").mkdir()
    shutil.copy(step_csv, tmp_path / "data" / "step.csv")
    (tmp_path / "spec.json").write_text(json.dumps(SPEC))
    shutil.copy(msd_file, tmp_path / "upload.fmu")
    return VetTask(str(tmp_path), ["step.csv"], "upload.fmu", fmu_name, cpu_seconds=60)


def test_an_upload_is_parsed_once(tmp_path, msd_file, step_csv):
    before = FmuModel.parses
    answer = vet(_task(tmp_path, msd_file, step_csv, "mine.fmu"))
    assert answer == {"ok": True, "model_name": "msd"}
    assert FmuModel.parses - before == 1


def test_a_built_in_model_is_parsed_once(tmp_path, msd_file, step_csv):
    before = FmuModel.parses
    assert vet(_task(tmp_path, msd_file, step_csv, None))["ok"]
    assert FmuModel.parses - before == 1
