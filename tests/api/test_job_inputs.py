"""``load_job_inputs``: the one loader of a stored job's inputs, for the job and its report."""

import json
import shutil
from pathlib import Path

import numpy as np

from fmuid.intake.inputs import load_job_inputs
from fmuid.jobs.records import TEST_DATA
from fmuid.jobs.store import Dataset, JobStore

SPEC = json.dumps(
    {
        "parameters": {"k": {"start": 4.0, "lower": 1.0, "upper": 9.0}},
        "inputs": ["f"],
        "outputs": {"x": {"sigma": 0.1}},
    }
)


def test_experiments_and_held_out_data_are_told_apart(tmp_path: Path, msd_fmu: Path) -> None:
    store = JobStore(tmp_path / "jobs.sqlite", tmp_path / "store")
    fmu = tmp_path / "msd.fmu"
    shutil.copy(msd_fmu, fmu)  # add_file moves the file into the store
    files = {}
    for name, x in (("step.csv", 0.5), ("later.csv", 0.7)):
        files[name] = tmp_path / name
        files[name].write_text(f"time,f,x\n0,1,0\n1,1,{x}\n")
    job = store.create(
        "fit",
        SPEC,
        store.add_file(fmu),
        "msd",
        [
            Dataset("step.csv", store.add_file(files["step.csv"])),
            Dataset(f"{TEST_DATA}/later.csv", store.add_file(files["later.csv"])),
        ],
    )
    work = tmp_path / "work"
    work.mkdir()
    inputs = load_job_inputs(store, job, work)
    assert inputs.fmu.read_bytes() == msd_fmu.read_bytes()
    assert [e.name for e in inputs.experiments] == ["step.csv"]
    assert [e.name for e in inputs.test_data] == ["later.csv"]
    np.testing.assert_array_equal(inputs.test_data[0].columns["x"], [0.0, 0.7])
    assert list(inputs.spec.parameters) == ["k"]
