"""The table of job kinds and the design space's own column (and rows stored before it)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from api_helpers import msd_spec, stored_file
from design_cases import MSD_SPACE
from fmuid.errors import SpecError
from fmuid.experiment_design import space_from_json
from fmuid.intake.inputs import load_job_inputs
from fmuid.jobs import run
from fmuid.jobs.kinds import RUNNERS, runner
from fmuid.jobs.records import KINDS
from fmuid.jobs.store import Dataset, JobStore

SPACE = json.dumps(MSD_SPACE)


def test_every_kind_has_one_runner_and_only_design_takes_a_space():
    assert list(RUNNERS) == list(KINDS)
    assert all(RUNNERS[kind].kind == kind for kind in KINDS)
    assert [kind for kind in KINDS if runner(kind).takes_space] == ["design"]


def test_an_unknown_kind_is_refused_naming_it_and_the_kinds(tmp_path):
    with pytest.raises(SpecError, match="unknown job kind 'optimise'; the kinds: fit, profile"):
        runner("optimise")
    store = JobStore(tmp_path / "jobs.sqlite", tmp_path)
    job = store.create("fit", "{}", "0" * 64, "m", [])
    store.connection().execute("UPDATE jobs SET kind = 'optimise' WHERE id = ?", (job.id,))
    assert run.run_job(store, store.claim_next(), 2000, None) == 1
    assert "unknown job kind 'optimise'" in store.get(job.id).error


def _old_store(tmp_path: Path) -> JobStore:
    """A store with the jobs table of the version before the ``space`` column."""
    store = JobStore(tmp_path / "jobs.sqlite", tmp_path)
    store.connection().execute("ALTER TABLE jobs DROP COLUMN space")
    return store


def test_a_design_row_stored_before_the_space_column_still_loads(tmp_path, msd_file):
    old = _old_store(tmp_path)
    fmu = stored_file(old, msd_file)
    space_blob = stored_file(old, text=SPACE)
    old.connection().execute(  # the insert of the previous version: the space as its dataset
        "INSERT INTO jobs (id, kind, status, created, fmu_sha256, model_name, spec, datasets)"
        " VALUES ('old', 'design', 'queued', 0, ?, 'msd', ?, ?)",
        (fmu, msd_spec(0.02), json.dumps([{"name": "space.json", "sha256": space_blob}])),
    )
    store = JobStore(tmp_path / "jobs.sqlite", tmp_path)  # the new version opens it
    before = store.get("old")
    assert before.space is None and before.datasets == (Dataset("space.json", space_blob),)
    new = store.create("design", msd_spec(0.02), fmu, "msd", [], space=SPACE)
    assert new.space == SPACE and new.datasets == ()
    expected = space_from_json(SPACE)
    for job, work in ((before, tmp_path / "old"), (new, tmp_path / "new")):
        work.mkdir()
        inputs = load_job_inputs(store, job, work)
        assert inputs.space == expected and inputs.experiments == inputs.test_data == []
        assert list(inputs.spec.parameters) == list(json.loads(msd_spec(0.02))["parameters"])


def test_a_design_without_a_space_fails_naming_the_job(tmp_path, msd_file):
    store = JobStore(tmp_path / "jobs.sqlite", tmp_path)
    job = store.create("design", msd_spec(0.02), stored_file(store, msd_file), "msd", [])
    (tmp_path / "work").mkdir()
    with pytest.raises(SpecError, match=f"job {job.id}: a design job without an experiment"):
        load_job_inputs(store, job, tmp_path / "work")
