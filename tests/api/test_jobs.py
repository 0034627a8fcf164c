"""Jobs end to end over HTTP with a real worker: results, restarts, crashing FMUs, dask."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

import fmuid
from api_helpers import msd_spec
from discrepancy.test_parallel_scan import OFFSET_SPEC, offset_record
from fmuid.data import load_experiment, spec_from_json

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def direct_profile(msd_file, step_csv):
    """The same profile computed in this process, the reference for the service's results."""
    result = fmuid.profile(msd_file, [load_experiment(step_csv)], spec_from_json(msd_spec()))
    return result.to_dict()


def assert_same_intervals(result, reference):
    assert result["parameters"].keys() == reference["parameters"].keys()
    for name, expected in reference["parameters"].items():
        got = result["parameters"][name]
        assert got["status"] == expected["status"], name
        assert got["estimate"] == pytest.approx(expected["estimate"], rel=1e-6), name
        for kind in ("simultaneous", "pointwise"):
            assert got["ci"][kind] == pytest.approx(expected["ci"][kind], rel=1e-6), (name, kind)


def wait_running(client, job, min_done=1, timeout=120.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        status = client.status(job)
        if status["status"] == "running" and status["progress"]["done"] >= min_done:
            return status
        assert status["status"] in ("queued", "running"), status
        time.sleep(0.1)
    raise TimeoutError(job)


def test_profile_uploaded_fmu_and_builtin_model_equal_direct_call(
    service, broken_fmus, step_csv, direct_profile
):
    client = service.client()
    # the uploaded FMU has the msd physics and is slow enough to be seen running
    uploaded = client.submit("profile", msd_spec(), [step_csv], fmu_path=broken_fmus["slow_step"])
    builtin = client.submit("profile", msd_spec(), [step_csv], model="msd")
    running = wait_running(client, uploaded)
    assert 0 < running["progress"]["done"] <= running["progress"]["total"]
    assert running["progress"]["detail"], running  # what it is doing, e.g. "m 3/24, k 2/24"
    assert client.health()["queued"] >= 1
    for job in (uploaded, builtin):
        status = client.wait(job, timeout=600)
        assert status["status"] == "done", status
        assert status["datasets"][0]["name"] == "step.csv"
        assert_same_intervals(client.result(job), direct_profile)
    assert [j["id"] for j in client.list()[:2]] == [builtin, uploaded]


def test_sigkill_while_running_then_restart_finishes_every_job(
    service_factory, step_csv, broken_fmus, tmp_path
):
    service = service_factory(tmp_path / "data")
    client = service.client()
    slow = broken_fmus["slow_step"]  # msd physics; the job cannot end before it is seen running
    running = client.submit("profile", msd_spec(), [step_csv], fmu_path=slow)
    queued = client.submit("fit", msd_spec(), [step_csv], model="msd")
    wait_running(client, running)
    service.kill()
    service.start()
    client = service.client()
    assert {j["id"] for j in client.list()} == {running, queued}
    for job in (running, queued):
        status = client.wait(job, timeout=600)
        assert status["status"] == "done", status
        assert client.result(job)["parameters"]["k"]["estimate"] == pytest.approx(4.4, rel=0.05)
    assert client.status(running)["attempts"] == 2


def test_crashing_and_hanging_fmus_fail_only_their_job(service_factory, broken_fmus, step_csv):
    service = service_factory(FMUID_JOB_TIMEOUT_S="20")
    client = service.client()
    crash = client.submit("fit", msd_spec(), [step_csv], fmu_path=broken_fmus["crash_step"])
    hang = client.submit("fit", msd_spec(), [step_csv], fmu_path=broken_fmus["hang_step"])
    cancelled = client.submit("fit", msd_spec(), [step_csv], fmu_path=broken_fmus["hang_step"])
    good = client.submit("fit", msd_spec(), [step_csv], model="msd")

    status = client.wait(crash, timeout=120)
    assert status["status"] == "failed"
    assert "segmentation fault" in status["error"] and "fmi2DoStep" in status["error"]
    status = client.wait(hang, timeout=120)
    assert status["status"] == "failed"
    assert status["error"] == "exceeded the time limit of 20 s"
    deadline = time.monotonic() + 60
    while client.status(cancelled)["status"] != "running" and time.monotonic() < deadline:
        time.sleep(0.2)
    time.sleep(2)  # inside the endless fmi2DoStep by now
    started = time.monotonic()
    client.cancel(cancelled)
    status = client.wait(good, timeout=300)
    assert status["status"] == "done", status
    assert time.monotonic() - started < 60
    assert client.status(cancelled)["status"] == "cancelled"
    assert client.health()["running"] == 0


def test_profile_on_dask_local_cluster_equals_local_pool(service_factory, step_csv, direct_profile):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    ) as cluster:
        service = service_factory(FMUID_DASK_SCHEDULER=cluster.scheduler_address)
        client = service.client()
        assert client.health()["dask_scheduler"] == cluster.scheduler_address
        job = client.submit("profile", msd_spec(), [step_csv], model="msd")
        status = client.wait(job, timeout=600)
        assert status["status"] == "done", status
        assert_same_intervals(client.result(job), direct_profile)
        assert "BranchTask" in cluster.scheduler.task_prefixes  # branches ran on dask


@pytest.mark.slow
def test_diagnose_job_names_an_input_offset_as_the_direct_call_does(service, tmp_path):
    record = offset_record()  # the msd driven by f + an offset (scipy), with noise
    path = tmp_path / record.name
    columns = [record.time, record.columns["f"], record.columns["x"]]
    np.savetxt(path, np.column_stack(columns), delimiter=",", header="time,f,x", comments="")
    spec = json.loads(OFFSET_SPEC)
    client = service.client()
    job = client.submit("diagnose", spec, [path], model="msd")
    status = client.wait(job, timeout=900)
    assert status["status"] == "done", status
    result = client.result(job)
    direct = fmuid.diagnose("msd", [load_experiment(path)], spec_from_json(OFFSET_SPEC)).to_dict()
    assert result["effect"] == direct["effect"] == "input_offset"
    assert result["verdict"] == direct["verdict"]
    assert result["added_parameters"]["offset_f"]["ci"] == pytest.approx(
        direct["added_parameters"]["offset_f"]["ci"], rel=1e-6
    )
    assert "Verdict" in client.report(job)
