"""SIGKILL the service with jobs queued and running; after a restart every job is there and
finishes (or fails with a reason), and every stored result is intact JSON matching the contract.
"""

from __future__ import annotations

import json
import sqlite3
import time

import jsonschema
import pytest

from api_helpers import msd_spec
from fmuid.jobs.store import JobStore
from fmuid.results.schema import json_schema

pytestmark = pytest.mark.slow

KINDS = ["profile", "profile", "fit", "profile", "fit", "fit"]


def wait_for(predicate, timeout=120.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(0.1)
    raise TimeoutError(predicate)


def test_sigkill_with_jobs_queued_and_running(service_factory, step_csv, test_fmus, tmp_path):
    data_dir = tmp_path / "data"
    service = service_factory(data_dir, FMUID_WORKERS="2")
    client = service.client()
    slow = test_fmus["slow_step"]  # msd physics; its jobs cannot end between two looks
    jobs = {client.submit(kind, msd_spec(), [step_csv], fmu_path=slow): kind for kind in KINDS}

    def two_running_several_queued() -> bool:
        states = [client.status(job)["status"] for job in jobs]
        return states.count("running") == 2 and states.count("queued") >= 2

    wait_for(two_running_several_queued)
    before = {job: client.status(job) for job in jobs}
    service.kill()
    service.start()
    client = service.client()
    assert {j["id"] for j in client.list()} == set(jobs)
    for job, kind in jobs.items():
        status = client.wait(job, timeout=600)
        assert status["status"] == "done", status
        assert status["kind"] == kind and status["created"] == before[job]["created"]
        expected_attempts = 2 if before[job]["status"] == "running" else 1
        assert status["attempts"] == expected_attempts, (before[job], status)
        jsonschema.validate(client.result(job), json_schema(kind))
    service.stop()

    with sqlite3.connect(data_dir / "jobs.sqlite") as db:
        assert db.execute("PRAGMA integrity_check").fetchone() == ("ok",)
    store = JobStore(data_dir / "jobs.sqlite", data_dir)
    for job, kind in jobs.items():
        stored = store.result(job)
        assert stored is not None
        jsonschema.validate(json.loads(stored), json_schema(kind))
