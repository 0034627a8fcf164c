"""The job store under failure and its bounds, without a service: retries, damage, the queue
limit, removal and retention of jobs, the lease, and the crash messages of FMI 2 and 3."""

from __future__ import annotations

import os
import sqlite3
import time

import pytest

from api_helpers import wipe_after_schema
from fmuid.jobs import housekeeping as hk
from fmuid.jobs import restarts
from fmuid.jobs.crash import FMI_VERSION_LINE, fmi_call_in_traceback
from fmuid.jobs.health import StoreHealth
from fmuid.jobs.layout import DataLayout
from fmuid.jobs.owner import OwnerLock, StoreInUse
from fmuid.jobs.store import Dataset, JobStore, QueueFull, StoreError


def make_store(tmp_path, **kwargs):
    return JobStore(tmp_path / "jobs.sqlite", tmp_path, **kwargs)


def blob(store, content: bytes):
    path = store.tmp_dir() / "upload"
    path.write_bytes(content)
    return store.add_file(path)


def finished_job(store, content=b"fmu"):
    sha = blob(store, content)
    job = store.create("fit", "{}", sha, "m", [Dataset("a.csv", blob(store, content + b"csv"))])
    store.claim_next()
    assert store.finish(job.id, '{"chi2": 1.0}')
    return job


class FailingConnection:
    """A connection whose writes fail ``failures`` times with ``message``, then work."""

    def __init__(self, conn, failures, message):
        self.conn, self.failures, self.message = conn, failures, message

    def execute(self, sql, *args):
        if sql.startswith(("UPDATE", "INSERT")) and self.failures > 0:
            self.failures -= 1
            raise sqlite3.OperationalError(self.message)
        return self.conn.execute(sql, *args)

    def __getattr__(self, name):
        return getattr(self.conn, name)


def test_a_transient_write_failure_is_retried(tmp_path, monkeypatch):
    store = make_store(tmp_path)
    job = store.create("fit", "{}", blob(store, b"x"), "m", [])
    store.claim_next()
    real = store.connection()
    failing = FailingConnection(real, 2, "disk I/O error")
    monkeypatch.setattr(store, "_connection", lambda: failing)
    store.set_progress(job.id, 1, 2, "fit")
    assert failing.failures == 0
    monkeypatch.undo()
    assert store.get(job.id).progress_done == 1


def test_a_full_disk_gives_back_the_reserve_then_fails_with_the_reason(tmp_path, monkeypatch):
    store = make_store(tmp_path)
    assert store.reserve.stat().st_size > 0
    job = store.create("fit", "{}", blob(store, b"x"), "m", [])
    store.claim_next()
    failing = FailingConnection(store.connection(), 100, "database or disk is full")
    monkeypatch.setattr(store, "_connection", lambda: failing)
    with pytest.raises(StoreError, match="finish failed 4 times: database or disk is full"):
        store.finish(job.id, "{}")
    assert not store.reserve.exists()
    monkeypatch.undo()
    assert store.get(job.id).status == "running" and store.result(job.id) is None
    store.keep_reserve()
    assert store.reserve.exists()


def test_a_damaged_database_is_reported_not_hidden(tmp_path):
    store = make_store(tmp_path)
    for k in range(200):
        store.create("fit", "{}" + " " * 2000, blob(store, b"%d" % k), "m", [])
    del store
    db = tmp_path / "jobs.sqlite"
    wipe_after_schema(db)
    checks = StoreHealth(db, tmp_path, min_free_bytes=0, disk_quota_bytes=0)
    problems = checks.problems()
    assert problems and "damaged" in problems[0]
    store = make_store(tmp_path)
    with pytest.raises(sqlite3.DatabaseError):
        store.list_jobs(limit=1000)
    with pytest.raises(StoreError, match="malformed"):
        store.create("fit", "{}", "0" * 64, "m", [])


def test_health_of_a_sound_store_and_a_disk_short_of_room(tmp_path):
    make_store(tmp_path)
    db = tmp_path / "jobs.sqlite"
    assert StoreHealth(db, tmp_path, min_free_bytes=0, disk_quota_bytes=0).problems() == []
    free = os.statvfs(tmp_path).f_bavail * os.statvfs(tmp_path).f_frsize
    short = StoreHealth(db, tmp_path, min_free_bytes=free * 2, disk_quota_bytes=0)
    assert "FMUID_MIN_FREE_BYTES" in short.problems()[0]
    over = StoreHealth(db, tmp_path, min_free_bytes=0, disk_quota_bytes=1000)
    assert "FMUID_DISK_QUOTA_BYTES" in over.problems()[0]  # the reserve file alone is 4 MiB


def test_the_queue_limit(tmp_path):
    store = make_store(tmp_path, max_queued=2)
    sha = blob(store, b"x")
    store.create("fit", "{}", sha, "m", [])
    store.create("fit", "{}", sha, "m", [])
    with pytest.raises(QueueFull, match="2 jobs wait"):
        store.create("fit", "{}", sha, "m", [])
    store.claim_next()
    store.create("fit", "{}", sha, "m", [])
    assert store.counts()["queued"] == 2


def test_removing_a_finished_job_removes_its_files_and_unshared_blobs(tmp_path, monkeypatch):
    monkeypatch.setattr(hk, "BLOB_GRACE_S", 0.0)
    store = make_store(tmp_path)
    gone, kept = finished_job(store, b"one"), finished_job(store, b"two")
    running = store.create("fit", "{}", kept.fmu_sha256, "m", [])
    store.claim_next()
    files = DataLayout(tmp_path).job_files(gone.id)
    files[0].mkdir(parents=True)
    (files[0] / "index.html").write_text("<html>")
    files[3].parent.mkdir(parents=True)
    files[3].write_text("log")
    assert hk.delete_jobs(store, [gone.id, running.id]) == [gone.id]
    assert store.get(gone.id) is None and store.result(gone.id) is None
    assert not any(path.exists() for path in files)
    assert not store.blob_path(gone.fmu_sha256).exists()
    assert store.blob_path(kept.fmu_sha256).exists() and store.get(running.id) is not None


def test_retention_removes_only_old_finished_jobs(tmp_path):
    store = make_store(tmp_path)
    old = finished_job(store, b"old")
    finished_job(store, b"new")
    queued = store.create("fit", "{}", blob(store, b"q"), "m", [])
    with store.transaction() as conn:
        conn.execute("UPDATE jobs SET finished = ? WHERE id = ?", (time.time() - 100, old.id))
        conn.execute("UPDATE jobs SET created = ? WHERE id = ?", (time.time() - 100, queued.id))
    assert hk.expired_jobs(store, 50) == [old.id]


def test_orphan_files_are_swept_and_live_jobs_keep_theirs(tmp_path):
    store = make_store(tmp_path)
    job = finished_job(store)
    orphan = DataLayout(tmp_path).job_files("no-such-job")
    for path in (
        orphan[0],
        DataLayout(tmp_path).job_tmp(job.id),
        DataLayout(tmp_path).job_tmp("x"),
    ):
        path.mkdir(parents=True)
    hk.remove_orphans(store, alive={job.id})
    assert not orphan[0].exists() and not DataLayout(tmp_path).job_tmp("x").exists()
    assert DataLayout(tmp_path).job_tmp(job.id).exists()
    hk.remove_orphans(store, alive=set())
    assert not DataLayout(tmp_path).job_tmp(job.id).exists()


def test_the_lease_keeps_a_second_service_out_until_the_first_is_gone(tmp_path, monkeypatch):
    store = make_store(tmp_path)
    restarts.take_lease(store)
    restarts.take_lease(store)  # the holder may take it again
    monkeypatch.setattr(os, "getpid", lambda: 2**22 + 1)  # another process
    with pytest.raises(restarts.LeaseHeld, match="in use by service process"):
        restarts.take_lease(store)
    monkeypatch.undo()
    restarts.release_lease(store)
    monkeypatch.setattr(os, "getpid", lambda: 2**22 + 1)
    restarts.take_lease(store)


def test_a_lease_of_a_dead_service_is_taken_over(tmp_path):
    store = make_store(tmp_path)
    with store.transaction() as conn:  # a service that was SIGKILLed a moment ago
        conn.execute("INSERT INTO lease (id, pid, heartbeat) VALUES (1, ?, ?)", (2**22 + 3, 0))
        conn.execute("UPDATE lease SET heartbeat = ?", (time.time(),))
    restarts.take_lease(store)


@pytest.mark.parametrize(
    ("version", "module", "expected"),
    [("2.0", "fmi2", "fmi2DoStep"), ("3.0", "fmi3", "fmi3DoStep")],
)
def test_crash_messages_name_the_fmi_function_of_the_fmus_version(version, module, expected):
    log = (
        f"{FMI_VERSION_LINE}{version}\n"
        "Fatal Python error: Segmentation fault\n\n"
        "Thread 0x2 (most recent call first):\n"  # the job's watchdog, listed first
        '  File "/usr/lib/python3.11/threading.py", line 331 in wait\n\n'
        "Current thread 0x1 (most recent call first):\n"
        f'  File "/x/fmpy/{module}.py", line 10 in w\n'
        f'  File "/x/fmpy/{module}.py", line 20 in doStep\n'
    )
    assert fmi_call_in_traceback(log) == expected


def test_a_service_that_lost_its_lease_claims_nothing(tmp_path, monkeypatch):
    store = make_store(tmp_path)
    store.create("fit", "{}", "0" * 64, "m", [])
    restarts.take_lease(store)
    monkeypatch.setattr(os, "getpid", lambda: 2**22 + 1)  # a second service took it over
    with store.transaction() as conn:
        conn.execute("UPDATE lease SET pid = ?", (os.getpid(),))
    monkeypatch.undo()
    assert not restarts.renew_lease(store)
    assert store.claim_next(owner=os.getpid()) is None
    assert store.claim_next(owner=2**22 + 1) is not None


def test_the_owner_lock_keeps_a_second_service_out(tmp_path):
    first = OwnerLock(tmp_path, tmp_path / "jobs.sqlite")
    first.acquire()
    with pytest.raises(StoreInUse, match=f"process {os.getpid()} holds"):
        OwnerLock(tmp_path, tmp_path / "jobs.sqlite").acquire()
    first.release()
    OwnerLock(tmp_path, tmp_path / "jobs.sqlite").acquire()


def test_health_says_when_the_database_file_was_replaced(tmp_path):
    make_store(tmp_path)
    db = tmp_path / "jobs.sqlite"
    checks = StoreHealth(db, tmp_path, min_free_bytes=0, disk_quota_bytes=0)
    copy = tmp_path / "copy.sqlite"
    copy.write_bytes(db.read_bytes())
    os.replace(copy, db)
    assert "removed or replaced" in checks.database_problems()[0]
