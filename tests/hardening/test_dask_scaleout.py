"""Scale-out on dask: a scheduler and two workers started as separate processes on loopback,
the service pointed at them; a worker killed in the middle of a profile job, which still
finishes with the local pool's intervals."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import pytest

import fmuid
from api_helpers import msd_spec, wait_until
from fmuid.data import load_experiment, spec_from_json

pytestmark = pytest.mark.slow


@pytest.fixture
def dask_cluster(tmp_path):
    """``dask scheduler`` and two ``dask worker`` processes; yields the scheduler's address."""
    pytest.importorskip("distributed")
    dask = [sys.executable, "-m"]
    scheduler_file = tmp_path / "scheduler.json"
    log = open(tmp_path / "dask.log", "ab")  # noqa: SIM115 - closed below
    started = [
        subprocess.Popen(
            [
                *dask,
                "distributed.cli.dask_scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--dashboard-address",
                ":0",
                "--scheduler-file",
                str(scheduler_file),
            ],
            stdout=log,
            stderr=log,
            start_new_session=True,
        )
    ]
    try:
        assert wait_until(scheduler_file.exists, 60), (tmp_path / "dask.log").read_text()
        address = json.loads(scheduler_file.read_text())["address"]
        workers = [
            subprocess.Popen(
                [
                    *dask,
                    "distributed.cli.dask_worker",
                    address,
                    "--nthreads",
                    "1",
                    "--nworkers",
                    "1",
                    "--no-nanny",
                    "--host",
                    "127.0.0.1",
                    "--dashboard-address",
                    ":0",
                ],
                stdout=log,
                stderr=log,
                start_new_session=True,
                env=dict(os.environ),
            )
            for _ in range(2)
        ]
        started += workers
        yield address
    finally:
        for process in started:
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
            process.wait()
        log.close()


def test_a_profile_job_survives_a_killed_dask_worker(
    service_factory, step_csv, test_fmus, dask_cluster, tmp_path
):
    address = dask_cluster
    from distributed import Client

    with Client(address, timeout="60s") as dask_client:
        dask_client.wait_for_workers(2, timeout=120)
        service = service_factory(tmp_path / "data", FMUID_DASK_SCHEDULER=address)
        client = service.client()
        assert client.health()["dask_scheduler"] == address
        # msd physics, slow enough that the job is still running after the worker is killed
        job = client.submit("profile", msd_spec(), [step_csv], fmu_path=test_fmus["slow_step"])

        def busy_worker() -> str | None:
            busy = [w for w, tasks in dask_client.processing().items() if tasks]
            return busy[0] if busy else None

        assert wait_until(lambda: busy_worker() is not None, 600), client.status(job)
        victim = busy_worker()
        pid = dask_client.run(os.getpid, workers=[victim])[victim]
        os.kill(pid, signal.SIGKILL)  # a worker dies with branches of the job on it
        assert client.status(job)["status"] == "running"
        status = client.wait(job, timeout=900)
        assert status["status"] == "done", status["error"]
        assert len(dask_client.scheduler_info()["workers"]) == 1
    result = client.result(job)
    direct = fmuid.profile(
        "msd", [load_experiment(step_csv)], spec_from_json(msd_spec()), workers=1
    ).to_dict()
    for name, expected in direct["parameters"].items():
        got = result["parameters"][name]
        assert got["status"] == expected["status"], name
        for kind in ("simultaneous", "pointwise"):
            assert got["ci"][kind] == pytest.approx(expected["ci"][kind], rel=1e-6), (name, kind)
