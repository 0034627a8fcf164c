"""A job whose disk fell below the free-space reserve fails naming it, and stores no result.

The write of a result can still succeed on a full disk (SQLite reuses its WAL pages), so the job
process checks the reserve itself before storing: what the job's outcome is does not depend on
which pages the store happens to have.
"""

import json
import shutil

from api_helpers import msd_spec, stored_file
from fmuid.jobs import run
from fmuid.jobs.store import Dataset, JobStore
from fmuid.model.builtin import builtin_fmu


def queued_fit(store: JobStore, step_csv) -> str:
    fmu = stored_file(store, builtin_fmu("msd"))
    datasets = [Dataset("step.csv", stored_file(store, step_csv))]
    return store.create("fit", msd_spec(), fmu, "msd", datasets).id


def test_a_job_under_the_reserve_fails_naming_it_and_stores_no_result(tmp_path, step_csv):
    store = JobStore(tmp_path / "jobs.sqlite", tmp_path)
    job_id = queued_fit(store, step_csv)
    free = shutil.disk_usage(tmp_path).free
    assert run.run_job(store, store.claim_next(), 2000, None, min_free_bytes=free * 2) == 1
    job = store.get(job_id)
    assert job.status == "failed" and store.result(job_id) is None
    assert "job store" in job.error and "FMUID_MIN_FREE_BYTES" in job.error, job.error


def test_a_job_with_room_stores_its_result(tmp_path, step_csv):
    store = JobStore(tmp_path / "jobs.sqlite", tmp_path)
    job_id = queued_fit(store, step_csv)
    assert run.run_job(store, store.claim_next(), 2000, None, min_free_bytes=1 << 20) == 0
    assert store.get(job_id).status == "done"
    assert "parameters" in json.loads(store.result(job_id))
