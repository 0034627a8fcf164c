"""The FMU is parsed (and hashed) once per process: in a profile job and in its workers."""

import collections
import json
import os
import pickle
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

import fmuid
from fmuid.engine.cluster import PickledTask, execute_anywhere
from fmuid.estimation.optimize import fit_problem
from fmuid.jobs.store import Dataset, JobStore
from fmuid.model.fmu import FmuModel
from fmuid.model.world import FmuRegistry, open_registry, registry
from fmuid.profiling.branch import BranchTask
from fmuid.profiling.engine import thresholds
from fmuid.profiling.walk import WalkOptions
from fmuid.stages import make_problem

from .test_msd import msd_step_data, spec

TRUTH = {"m": 1.1, "k": 4.4, "b": 1.6}
LOGGER = Path(__file__).with_name("parse_log")


def _blob(store: JobStore, data: bytes) -> str:
    path = store.tmp_dir() / "upload"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    return store.add_file(path)


def _csv(experiment) -> bytes:
    rows = np.column_stack([experiment.time, experiment.columns["f"], experiment.columns["x"]])
    lines = ["time,f,x", *(",".join(f"{v:.17g}" for v in row) for row in rows)]
    return ("\n".join(lines) + "\n").encode()


@pytest.mark.slow
@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="a profile job starts workers on 2+ CPUs")
def test_a_profile_job_parses_the_fmu_once_per_process(msd_fmu, tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite", tmp_path)
    data = msd_step_data(**TRUTH, sigma=0.3, seed=5)
    body = {
        "parameters": {n: {"start": v, "lower": 0.01, "upper": 5.0} for n, v in TRUTH.items()},
        "inputs": ["f"],
        "outputs": {"x": {"sigma": 0.3}},
        "global_search": False,
    }
    fmu_sha = _blob(store, Path(msd_fmu).read_bytes())
    job = store.create(
        "profile", json.dumps(body), fmu_sha, "msd", [Dataset("step.csv", _blob(store, _csv(data)))]
    )
    assert store.claim_next().id == job.id
    log = tmp_path / "parses.log"
    service = Path(fmuid.__file__).parents[1]
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(LOGGER), str(service)]),
        "FMUID_TEST_PARSE_LOG": str(log),
    }
    db = str(tmp_path / "jobs.sqlite")
    limits = ["--memory-mb", "4000", "--timeout-s", "300"]
    command = [
        sys.executable,
        "-m",
        "fmuid.jobs.run",
        job.id,
        "--db",
        db,
        "--data-dir",
        str(tmp_path),
    ]
    proc = subprocess.run([*command, *limits], env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert store.get(job.id).status == "done", store.get(job.id).error
    result = json.loads(store.result(job.id))
    assert result["fmu"]["sha256"] == fmu_sha
    lines = log.read_text().split("\n")[:-1]
    parses = collections.Counter(line.split()[0] for line in lines)
    assert len(parses) >= 3, f"the job process and at least two workers: {lines}"
    assert set(parses.values()) == {1}, f"one parse per process: {lines}"


def test_a_study_parses_the_fmu_once_in_process(msd_fmu):
    data = msd_step_data(**TRUTH, sigma=0.3, seed=5)
    with open_registry() as world:  # as a process of its own: nothing parsed yet
        problem = make_problem(msd_fmu, [data], spec(TRUTH, 0.3, interface="co_simulation"))
        result = fmuid.profile(msd_fmu, [data], problem.spec, problem=problem, workers=1)
        assert world.parses == 1
    assert result.fit.fmu_sha256 == problem.model.sha256
    assert problem.predictor.model is problem.model


def test_a_worker_without_the_file_parses_a_copy_of_the_bytes(msd_fmu, tmp_path, monkeypatch):
    """As a dask worker on another machine: the task arrives pickled, the FMU as bytes."""
    moved = Path(shutil.copy(msd_fmu, tmp_path / "moved.fmu"))
    data = msd_step_data(**TRUTH, sigma=0.3, seed=6)
    problem = make_problem(moved, [data], spec(TRUTH, 0.3))
    fit = fit_problem(problem, global_search=False)
    thr = thresholds(0.68, 3)["simultaneous"]
    task = BranchTask(
        problem, fit.z_estimate(), fit.chi2, 0, 1, thr, fit.fisher_sd_z()["m"], WalkOptions()
    )
    sent = PickledTask(problem.model.file, pickle.dumps(task))
    here = task.execute(lambda n: None)
    blob = moved.read_bytes()
    moved.unlink()
    monkeypatch.setattr("fmuid.model.world._current", FmuRegistry())  # a worker that parsed nothing
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    before = registry().parses
    there, _ = execute_anywhere(sent, problem.model.sha256, blob)
    assert registry().parses - before == 1
    assert (tmp_path / "fmuid-fmus" / problem.model.sha256 / "moved.fmu").read_bytes() == blob
    assert [p.chi2 for p in there.points] == [p.chi2 for p in here.points]
    assert there.points[-1].chi2 - fit.chi2 > thr


def test_stages_hand_on_a_parsed_model(msd_fmu):
    """``fmuid.simulate`` and ``make_problem`` take the model as it is: no parse."""
    model = FmuModel(msd_fmu)
    data = msd_step_data(**TRUTH, sigma=0.0, seed=0)
    before = registry().parses
    run = fmuid.simulate(model, data, {"k": 4.4})
    problem = make_problem(model, [data], spec(TRUTH, 0.3))
    assert registry().parses == before
    assert problem.model is model and run.model is model
    np.testing.assert_allclose(run.outputs["x"], data.columns["x"], atol=1e-8)  # scipy's
    np.testing.assert_array_equal(run.inputs["f"], data.columns["f"])
