"""``progress.detail``: what a job is doing, recorded by the job process and read back."""

from __future__ import annotations

from fmuid.api.schemas import JobOut
from fmuid.jobs.run import ProgressWriter
from fmuid.jobs.store import JobStore
from fmuid.progress import Progress


def test_detail_of_counted_and_open_ended_stages(tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite", tmp_path)
    job = store.create("fit", "{}", "0" * 64, "msd", [])
    store.claim_next()
    write = ProgressWriter(store, job.id, interval=0.0)
    write(Progress("fit", 25, 25, "genetic algorithm"))
    progress = JobOut.from_job(store.get(job.id)).progress
    assert (progress.done, progress.total, progress.stage) == (25, 25, "fit")
    assert progress.detail == "genetic algorithm"
    write(Progress("refine", 40, 0, "start 1/1, chi2 51.3, 42 simulations"))
    progress = JobOut.from_job(store.get(job.id)).progress
    assert (progress.done, progress.total, progress.stage) == (25, 25, "fit")
    assert progress.detail == "refine: 40 evaluations, start 1/1, chi2 51.3, 42 simulations"


def test_a_store_of_an_earlier_version_gets_the_column(tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite", tmp_path)
    job = store.create("fit", "{}", "0" * 64, "msd", [])
    store.connection().execute("ALTER TABLE jobs DROP COLUMN progress_detail")
    reopened = JobStore(tmp_path / "jobs.sqlite", tmp_path)
    assert reopened.get(job.id).progress_detail == ""
