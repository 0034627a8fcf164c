"""One service per data folder, whatever happens to the first one: a service frozen past its
lease (SIGSTOP) keeps the folder, a second one refuses to start, and no job runs twice."""

from __future__ import annotations

import signal

import pytest

from api_helpers import msd_spec, wait_until
from fmuid.jobs import restarts

pytestmark = pytest.mark.slow

FROZEN_S = restarts.LEASE_S + 5


def test_a_frozen_service_keeps_its_store_and_no_job_runs_twice(
    service_factory, step_csv, test_fmus, tmp_path
):
    data_dir = tmp_path / "data"
    first = service_factory(data_dir)
    client = first.client()
    slow = test_fmus["slow_step"]
    jobs = [client.submit("fit", msd_spec(), [step_csv], fmu_path=slow) for _ in range(3)]
    assert wait_until(lambda: client.status(jobs[0])["status"] == "running", 60)

    first.process.send_signal(signal.SIGSTOP)
    try:
        wait_until(lambda: False, FROZEN_S)
        with pytest.raises(RuntimeError, match="in use by another fmuid service"):
            service_factory(data_dir)
    finally:
        first.process.send_signal(signal.SIGCONT)

    for job in jobs:
        status = client.wait(job, timeout=300)
        assert status["status"] == "done" and status["attempts"] == 1, status
    health = client.health()
    assert health["status"] == "ok", health
    assert first.process.poll() is None
