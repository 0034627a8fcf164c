"""Every process of a job dies with the service, and a restart ends whatever a crash left.

Processes of a service's jobs carry ``FMUID_JOB_DB=<its database>`` in their environment
(:mod:`fmuid.jobs.proc`); the tests look for them in ``/proc`` independently of that module.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from api_helpers import msd_spec, wait_until
from fmuid.jobs.layout import DataLayout
from fmuid.jobs.proc import job_command, job_environment
from fmuid.jobs.store import Dataset, JobStore

pytestmark = pytest.mark.slow


def tagged_processes(db: Path) -> list[int]:
    """Pids of live (not zombie) processes whose environment names ``db`` as their job store."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            env = (entry / "environ").read_bytes().split(b"\0")
            state = (entry / "stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if f"FMUID_JOB_DB={db}".encode() in env and state != "Z":
            found.append(int(entry.name))
    return found


def test_sigkill_of_the_service_leaves_no_job_process(
    service_factory, step_csv, test_fmus, tmp_path
):
    data_dir = tmp_path / "data"
    db = data_dir / "jobs.sqlite"
    service = service_factory(data_dir, FMUID_WORKERS="2")
    client = service.client()
    slow = test_fmus["slow_step"]  # msd physics; its jobs cannot end between two looks
    jobs = [client.submit("profile", msd_spec(), [step_csv], fmu_path=slow) for _ in range(2)]

    def profiling_on_a_pool() -> bool:
        states = [client.status(job) for job in jobs]
        assert all(s["status"] in ("queued", "running") for s in states), states
        profiling = any(s["progress"]["stage"] == "profile" for s in states)
        # a leader, its resource tracker, its forkserver and at least one pool worker
        return profiling and len(tagged_processes(db)) >= 4

    assert wait_until(profiling_on_a_pool), [client.status(job) for job in jobs]
    service.kill()
    assert wait_until(lambda: not tagged_processes(db), 20), tagged_processes(db)

    service.start()
    client = service.client()
    assert wait_until(lambda: len(tagged_processes(db)) >= 2, 60)
    service.stop()
    assert wait_until(lambda: not tagged_processes(db), 20), tagged_processes(db)
    tmp_root = DataLayout(data_dir).job_tmp_root  # the jobs' temporary files are gone
    assert not tmp_root.exists() or not list(tmp_root.iterdir())


def test_a_restart_ends_stray_processes_of_the_previous_run(service_factory, step_csv, tmp_path):
    data_dir = tmp_path / "data"
    db = data_dir / "jobs.sqlite"
    service = service_factory(data_dir)
    service.kill()
    # a process a job left behind that escaped its group and ignores its parent's death
    stray = subprocess.Popen(
        [sys.executable, "-c", "import signal, time; signal.signal(15, 1); time.sleep(600)"],
        env={**os.environ, "FMUID_JOB_DB": str(db), "FMUID_JOB_ID": "stray"},
        start_new_session=True,
    )
    other = subprocess.Popen(  # another service's job: left alone
        [sys.executable, "-c", "import time; time.sleep(600)"],
        env={**os.environ, "FMUID_JOB_DB": str(tmp_path / "other.sqlite")},
        start_new_session=True,
    )
    try:
        assert tagged_processes(db) == [stray.pid]
        service.start()
        assert stray.wait(timeout=20) == -signal.SIGKILL
        assert other.poll() is None
    finally:
        for process in (stray, other):
            process.kill()
            process.wait()


def test_a_job_process_enforces_its_own_time_limit(test_fmus, step_csv, tmp_path):
    """With no supervisor watching, a hanging job still ends at its limit, saying why."""
    store = JobStore(tmp_path / "jobs.sqlite", tmp_path)
    fmu_copy = store.tmp_dir() / "hang.fmu"
    fmu_copy.write_bytes(test_fmus["hang_step"].read_bytes())
    csv_copy = store.tmp_dir() / "step.csv"
    csv_copy.write_bytes(step_csv.read_bytes())
    datasets = [Dataset("step.csv", store.add_file(csv_copy))]
    job = store.create("fit", msd_spec(), store.add_file(fmu_copy), "hang_step", datasets)
    assert store.claim_next().id == job.id
    args = ["--db", str(store.db_path), "--data-dir", str(tmp_path), "--memory-mb", "4096"]
    process = subprocess.Popen(
        job_command(sys.executable, job.id, [*args, "--timeout-s", "4"]),
        env=job_environment(store.db_path, job.id),
        start_new_session=True,
        stderr=subprocess.DEVNULL,
    )
    try:
        assert process.wait(timeout=60) == -signal.SIGKILL
    finally:
        process.kill()
    failed = store.get(job.id)
    assert failed.status == "failed" and failed.error == "exceeded the time limit of 4 s"
    assert not tagged_processes(store.db_path)


def test_a_job_process_whose_service_is_gone_does_not_run(tmp_path):
    """The bootstrap checks its parent after asking to die with it: an orphan exits at once."""
    db = tmp_path / "jobs.sqlite"
    env = {**job_environment(db, "x"), "FMUID_JOB_PARENT": "1"}
    done = subprocess.run(
        job_command(sys.executable, "x", ["--db", str(db)]),
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 1 and "the service that started this job is gone" in done.stderr
