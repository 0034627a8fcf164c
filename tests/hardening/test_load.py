"""Load: 50 small jobs submitted at once all finish, and health reports the queue while busy.

Only functional facts are asserted here; the timings (jobs/min, status latency, utilisation)
are measured by ``bench/load.py``.
"""

from __future__ import annotations

import json
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import pytest

from api_helpers import msd_spec

pytestmark = pytest.mark.slow

N_JOBS = 50


def test_fifty_concurrent_jobs_all_finish(service_factory, step_csv):
    service = service_factory(FMUID_WORKERS="2")
    client = service.client()
    with ThreadPoolExecutor(N_JOBS) as pool:
        jobs = list(
            pool.map(
                lambda _: service.client().submit("fit", msd_spec(), [step_csv], model="msd"),
                range(N_JOBS),
            )
        )
    assert len(set(jobs)) == N_JOBS

    seen: list[dict[str, int]] = []
    stop = threading.Event()

    def watch_health() -> None:
        with service.client() as watcher:
            while not stop.is_set():
                seen.append(watcher.health())
                time.sleep(0.05)

    watcher = threading.Thread(target=watch_health)
    watcher.start()
    try:
        statuses = [client.wait(job, timeout=600) for job in jobs]
    finally:
        stop.set()
        watcher.join()
    assert [s["status"] for s in statuses] == ["done"] * N_JOBS
    assert max(h["queued"] for h in seen) > 0
    assert max(h["running"] for h in seen) == 2  # both workers busy, never more
    assert client.health()["queued"] == client.health()["running"] == 0
    assert {j["id"] for j in client.list(limit=N_JOBS)} == set(jobs)


def test_fit_job_reports_genetic_algorithm_progress(service, step_csv):
    client = service.client()
    spec = {**json.loads(msd_spec()), "global_search": True}
    job = client.submit("fit", spec, [step_csv], model="msd")
    status = client.wait(job, timeout=300)
    assert status["status"] == "done", status
    progress = status["progress"]
    assert progress["stage"] == "fit" and progress["done"] == progress["total"] > 0
