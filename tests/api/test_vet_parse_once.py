"""Vetting an upload parses and hashes the FMU once; its binary probe gets the parsed facts."""

import json
import re
import shutil

import pytest

from fmuid.data import InputLimits
from fmuid.errors import SpecError
from fmuid.intake.vet import VetTask, _check_design, check_json_shape, vet
from fmuid.model.world import registry

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
    before = registry().parses
    answer = vet(_task(tmp_path, msd_file, step_csv, "mine.fmu"))
    assert answer == {"ok": True, "model_name": "msd"}
    assert registry().parses - before == 1


def test_a_built_in_model_is_parsed_once(tmp_path, msd_file, step_csv):
    before = registry().parses
    assert vet(_task(tmp_path, msd_file, step_csv, None))["ok"]
    assert registry().parses - before == 1


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ('{"a": [' + "1" * 5000 + "]}", "a number of 5000 characters"),
        ("[" * 100_000 + "]" * 100_000, "nested arrays and objects (FMUID_MAX_SPEC_DEPTH)"),
    ],
    ids=["5000-digits", "100k-deep"],
)
def test_a_hostile_design_space_is_refused_before_it_is_parsed(tmp_path, text, needle):
    space = tmp_path / "space.json"
    space.write_text(text)
    with pytest.raises(SpecError, match=re.escape(needle)):
        _check_design(space, None, None, InputLimits())


def test_numbers_inside_strings_are_not_numbers():
    check_json_shape('{"name": "' + "1" * 500 + '", "x": [[1.5e-3]]}', "spec", InputLimits())
