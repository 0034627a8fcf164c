"""The service over HTTP when its store is damaged, its disk full, its queue long or its data old.

Every answer is JSON; health says ``degraded`` naming the problem, and answers within 100 ms
while the queue fills and while the damaged store is used (the bound of
``tests/hardening/conftest.py``); a job never stays running without a process.
"""

from __future__ import annotations

import subprocess
import threading
import time
from pathlib import Path

import httpx
import pytest

from api_helpers import msd_spec, wait_until, wipe_after_schema
from attacks import HealthWatch

pytestmark = pytest.mark.slow


def submit(service, step_csv, fmu: Path | None = None) -> httpx.Response:
    with open(step_csv, "rb") as data:
        files = [("data", ("step.csv", data, "text/csv"))]
        form = {"kind": "fit", "spec": msd_spec()}
        if fmu is None:
            form["model"] = "msd"
            return httpx.post(service.url + "/v1/jobs", data=form, files=files, timeout=60)
        with open(fmu, "rb") as fmu_file:
            files.append(("fmu", (fmu.name, fmu_file, "application/octet-stream")))
            return httpx.post(service.url + "/v1/jobs", data=form, files=files, timeout=60)


def health(service) -> dict:
    answer = httpx.get(service.url + "/v1/health", timeout=5)
    assert answer.status_code == 200
    return answer.json()


def test_queue_limit_answers_429_naming_it(service_factory, step_csv, test_fmus, health_bound_of):
    service = service_factory(FMUID_QUEUE_LIMIT="2", FMUID_JOB_TIMEOUT_S="120")
    client = service.client()
    bound = health_bound_of(service.url)
    with HealthWatch(service.url) as watch:
        busy = submit(service, step_csv, test_fmus["hang_step"]).json()["id"]
        assert wait_until(lambda: client.status(busy)["status"] == "running")
        queued = [submit(service, step_csv).json()["id"] for _ in range(2)]
        refused = submit(service, step_csv)
    bound.check(watch)
    assert refused.status_code == 429, refused.text
    assert "FMUID_QUEUE_LIMIT" in refused.json()["detail"]
    assert health(service)["queued"] == 2
    client.cancel(busy)
    for job in queued:
        assert client.wait(job, timeout=300)["status"] == "done"
    assert submit(service, step_csv).status_code == 202


def test_delete_of_a_finished_job_removes_it_and_its_files(service_factory, step_csv):
    service = service_factory()
    client = service.client()
    job = submit(service, step_csv).json()["id"]
    assert client.wait(job, timeout=300)["status"] == "done"
    assert "<html" in client.report(job).lower()  # waits while the report is drawn
    report = service.data_dir / "reports" / job
    assert (report / "index.html").is_file()
    answer = httpx.delete(f"{service.url}/v1/jobs/{job}", timeout=10)
    assert answer.status_code == 200 and answer.json()["status"] == "done"
    assert httpx.get(f"{service.url}/v1/jobs/{job}", timeout=10).status_code == 404
    assert httpx.get(f"{service.url}/v1/jobs/{job}/result", timeout=10).status_code == 404
    assert not report.exists() and not (service.data_dir / "logs" / f"{job}.log").exists()
    assert httpx.delete(f"{service.url}/v1/jobs/{job}", timeout=10).status_code == 404


def test_retention_removes_old_finished_jobs(service_factory, step_csv):
    service = service_factory(FMUID_RETENTION_S="3")
    client = service.client()
    job = submit(service, step_csv).json()["id"]
    assert client.wait(job, timeout=300)["status"] == "done"
    assert wait_until(lambda: client.list() == [], 60)
    assert not (service.data_dir / "reports" / job).exists()


def test_the_result_is_kept_when_the_report_cannot_be_drawn(service_factory, step_csv, tmp_path):
    data_dir = tmp_path / "data"
    data_dir.mkdir()
    (data_dir / "reports").write_text("a file where the reports folder should be")
    service = service_factory(data_dir)
    client = service.client()
    job = submit(service, step_csv).json()["id"]
    assert client.wait(job, timeout=300)["status"] == "done"
    assert client.result(job)["parameters"]["k"]["estimate"] == pytest.approx(4.4, rel=0.05)
    answer = httpx.get(f"{service.url}/v1/jobs/{job}/report", timeout=10)
    assert answer.status_code == 503, answer.text
    assert "cannot make the folder of the reports" in answer.json()["detail"]
    assert client.status(job)["status"] == "done"


def test_a_damaged_database_makes_health_degraded_and_errors_json(
    service_factory, step_csv, tmp_path, health_bound_of
):
    data_dir = tmp_path / "data"
    service = service_factory(data_dir)
    jobs = [submit(service, step_csv).json()["id"] for _ in range(3)]
    client = service.client()
    for job in jobs:
        client.wait(job, timeout=300)
    service.stop()
    db = data_dir / "jobs.sqlite"
    wipe_after_schema(db)
    service.start()
    state = health(service)
    assert state["status"] == "degraded", state
    assert any("damaged" in p or "malformed" in p for p in state["problems"]), state
    bound = health_bound_of(service.url)
    with HealthWatch(service.url) as watch:
        listing = httpx.get(service.url + "/v1/jobs", timeout=10)
        refused = submit(service, step_csv)
    bound.check(watch)
    assert listing.status_code == 503 and "job store" in listing.json()["detail"]
    assert refused.status_code == 503 and "damaged" in refused.json()["detail"], refused.text


def test_a_clean_stop_leaves_a_store_that_needs_no_log(service_factory, step_csv, tmp_path):
    """Losing the write-ahead log of a cleanly stopped service loses nothing."""
    data_dir = tmp_path / "data"
    service = service_factory(data_dir)
    client = service.client()
    jobs = [submit(service, step_csv).json()["id"] for _ in range(3)]
    results = {job: client.result(job) for job in jobs[:2] if client.wait(job, timeout=300)}
    before = {job["id"]: job["status"] for job in client.list()}
    service.stop()
    for name in ("jobs.sqlite-wal", "jobs.sqlite-shm"):
        (data_dir / name).unlink(missing_ok=True)
    service.start()
    client = service.client()
    after = {job["id"]: job["status"] for job in client.list()}
    assert set(after) == set(before) == set(jobs)
    assert all(after[job] == "done" for job in results)
    assert {job: client.result(job) for job in results} == results
    assert health(service)["status"] == "ok"


@pytest.fixture
def small_disk(tmp_path):
    """A 48 MiB tmpfs (needs root); unmounted afterwards."""
    mount = tmp_path / "disk"
    mount.mkdir()
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=48m", "tmpfs", str(mount)], capture_output=True
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.decode().strip()}")
    yield mount
    subprocess.run(["umount", "-l", str(mount)], check=False)


class Filler:
    """Keeps ``disk`` full to the last byte (topping it up as space is freed) until stopped."""

    def __init__(self, disk: Path):
        self.path = disk / "filler"
        self.stop = threading.Event()
        self.full = threading.Event()  # set once the disk has been filled the first time
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        with open(self.path, "ab", buffering=0) as stream:
            while not self.stop.is_set():
                for size in (1 << 16, 4096, 512, 1):
                    try:
                        while True:
                            stream.write(b"\0" * size)
                    except OSError:
                        continue
                self.full.set()
                time.sleep(0.02)

    def remove(self) -> None:
        self.stop.set()
        self.thread.join()
        self.path.unlink()


def job_processes(data_dir: Path, service_pid: int) -> list[str]:
    """Pids of processes tagged with the store of ``data_dir``, but the service's own children
    (its warm forkserver and resource tracker)."""
    tag = f"FMUID_JOB_DB={data_dir / 'jobs.sqlite'}".encode()
    found = []
    for entry in Path("/proc").glob("[0-9]*"):
        try:
            tagged = tag in (entry / "environ").read_bytes().split(b"\0")
            ppid = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
        except OSError:
            continue
        if tagged and ppid != service_pid:
            found.append(entry.name)
    return found


def test_a_full_disk_fails_the_running_job_with_the_reason(
    service_factory, step_csv, test_fmus, small_disk
):
    data_dir = small_disk / "data"
    service = service_factory(data_dir, FMUID_MIN_FREE_BYTES=str(1 << 20))
    client = service.client()
    # msd physics, slow enough that the job cannot end before the disk is full
    job = client.submit("profile", msd_spec(), [step_csv], fmu_path=test_fmus["slow_step"])
    assert wait_until(lambda: client.status(job)["progress"]["done"] >= 1, 300)
    filler = Filler(small_disk)
    try:
        assert filler.full.wait(60)
        assert client.status(job)["status"] == "running", client.status(job)
        assert wait_until(lambda: not job_processes(data_dir, service.process.pid), 600)
        state = health(service)
        assert state["status"] == "degraded", state
        assert any("FMUID_MIN_FREE_BYTES" in p for p in state["problems"]), state
        refused = submit(service, step_csv)
        assert refused.status_code == 507 and "FMUID_MIN_FREE_BYTES" in refused.json()["detail"]
    finally:
        filler.remove()
    assert wait_until(lambda: client.status(job)["status"] != "running", 60), client.status(job)
    status = client.status(job)
    assert status["status"] == "failed", status
    assert "job store" in status["error"], status
    assert wait_until(lambda: health(service)["status"] == "ok", 30), health(service)
    assert client.wait(submit(service, step_csv).json()["id"], timeout=300)["status"] == "done"
