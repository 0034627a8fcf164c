"""Job store and crash messages, without a service."""

from __future__ import annotations

import io

from fmuid.jobs.crash import exit_message
from fmuid.jobs.restarts import MAX_ATTEMPTS, recover
from fmuid.jobs.store import Dataset, JobStore


def make_store(tmp_path):
    return JobStore(tmp_path / "jobs.sqlite", tmp_path)


def blob(store, content: bytes):
    path = store.tmp_dir() / "upload"
    path.write_bytes(content)
    return store.add_file(path)


def test_blobs_are_content_addressed(tmp_path):
    store = make_store(tmp_path)
    a, b = blob(store, b"abc"), blob(store, b"abc")
    assert a == b == "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
    assert store.blob_path(a).read_bytes() == b"abc"
    assert not list(store.tmp_dir().iterdir())


def test_jobs_survive_reopening_and_running_ones_are_requeued(tmp_path):
    store = make_store(tmp_path)
    sha = blob(store, b"fmu")
    first = store.create("profile", "{}", sha, "msd", [Dataset("step.csv", sha)])
    second = store.create("fit", "{}", sha, "msd", [])
    assert store.claim_next().id == first.id
    store.set_progress(first.id, 3, 10, "profile")
    reopened = make_store(tmp_path)
    assert [j.id for j in recover(reopened)] == [first.id]
    job = reopened.get(first.id)
    assert job.status == "queued" and job.attempts == 1 and job.datasets[0].name == "step.csv"
    assert [j.id for j in reopened.list_jobs()] == [second.id, first.id]
    assert reopened.counts()["queued"] == 2


def test_a_job_interrupted_too_often_fails_with_the_reason(tmp_path):
    store = make_store(tmp_path)
    job = store.create("fit", "{}", blob(store, b"x"), "m", [])
    for _ in range(MAX_ATTEMPTS):
        assert store.claim_next().id == job.id
        recover(store)
    failed = store.get(job.id)
    assert failed.status == "failed" and f"{MAX_ATTEMPTS} times" in failed.error


def test_finish_after_cancel_stores_nothing(tmp_path):
    store = make_store(tmp_path)
    job = store.create("fit", "{}", blob(store, b"x"), "m", [])
    store.claim_next()
    assert store.cancel(job.id)
    assert not store.finish(job.id, '{"chi2": 1}')
    assert store.get(job.id).status == "cancelled" and store.result(job.id) is None


def test_exit_messages():
    log = io.StringIO()
    log.write(
        "Fatal Python error: Segmentation fault\n\nCurrent thread 0x1 (most recent call first):\n"
    )
    log.write(
        '  File "/x/fmpy/fmi2.py", line 10 in w\n  File "/x/fmpy/fmi2.py", line 20 in doStep\n'
    )
    message = exit_message(-11, log.getvalue(), 4096)
    assert "segmentation fault" in message and "fmi2DoStep" in message
    assert "out-of-memory" in exit_message(-9, "", 4096)
    assert "by an operator" in exit_message(-9, "", 4096)
    stopped = exit_message(-15, "", 4096)
    assert "SIGTERM from outside the service" in stopped and "crashed" not in stopped
    assert "memory limit of 512 MB" in exit_message(1, "MemoryError", 512)
