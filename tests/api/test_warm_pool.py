"""The warm server is replaced after ``FMUID_WARM_RECYCLE_JOBS`` processes and after a crash.

Each job process logs its parent (``started by <pid>``): warm jobs name their server. With a
recycle count of 2, five jobs in turn come from three servers in the pattern A A B B C. When the
server is killed with jobs queued and one running, every job still ends ``done`` (the running
one is queued again) on a new server.
"""

from __future__ import annotations

import os
import re
import signal
import time

from api_helpers import msd_spec

STARTED_BY = re.compile(r"job \S+ in process \d+, started by (\d+)")


def parents(service, job: str) -> list[int]:
    log = (service.data_dir / "logs" / f"{job}.log").read_text()
    return [int(pid) for pid in STARTED_BY.findall(log)]


def test_server_replaced_after_n_jobs(service_factory, step_csv):
    service = service_factory(FMUID_WARM_RECYCLE_JOBS="2")
    client = service.client()
    servers = []
    for _ in range(5):
        job = client.submit("fit", msd_spec(), [step_csv], model="msd")
        assert client.wait(job, timeout=300)["status"] == "done"
        servers += parents(service, job)
    a, b, c = dict.fromkeys(servers)
    assert servers == [a, a, b, b, c]
    assert service.process is not None and service.process.pid not in servers


def test_crashed_server_loses_no_job(service_factory, step_csv):
    service = service_factory(FMUID_WORKERS="1")
    client = service.client()
    first = client.submit("fit", msd_spec(), [step_csv], model="msd")
    assert client.wait(first, timeout=300)["status"] == "done"
    (server,) = parents(service, first)
    jobs = [client.submit("fit", msd_spec(), [step_csv], model="msd") for _ in range(3)]
    deadline = time.monotonic() + 60
    while client.status(jobs[0])["status"] == "queued" and time.monotonic() < deadline:
        time.sleep(0.01)
    os.kill(server, signal.SIGKILL)
    for job in jobs:
        assert client.wait(job, timeout=300)["status"] == "done", client.status(job)
    later = [pid for job in jobs for pid in parents(service, job)]
    assert later[-1] != server
    assert set(later) - {server}
