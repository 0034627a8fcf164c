"""The supervisor: a thread in the service that runs queued jobs, each in its own process.

Every job runs in ``python -m fmuid.jobs.run`` started in a new session (its own process group),
with its stderr in ``<data_dir>/logs/<job id>.log``. The supervisor keeps at most
``settings.workers`` of them alive, kills a group past ``settings.job_timeout_s`` or when its job
is cancelled, and, when a process ends without recording an outcome (a segfault, the OOM killer),
fails its job with the reason read from the exit status and the log.
"""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from fmuid.jobs.crash import exit_message
from fmuid.jobs.store import Job, JobStore
from fmuid.settings import Settings

logger = logging.getLogger(__name__)

POLL_S = 0.2


@dataclass
class _Running:
    job: Job
    process: subprocess.Popen[bytes]
    log: IO[bytes]
    log_path: Path
    started: float = field(default_factory=time.monotonic)


def kill_group(pid: int) -> None:
    """Send SIGKILL to the process group led by ``pid`` (a job process), if it still exists."""
    try:
        os.killpg(pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


def _is_job_process(pid: int, job_id: str) -> bool:
    try:
        cmdline = Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return False
    return b"fmuid.jobs.run" in cmdline and job_id.encode() in cmdline


class Supervisor:
    """Runs queued jobs in isolated processes, at most ``settings.workers`` at a time.

    Parameters
    ----------
    settings
        Limits (workers, time, memory), the data folder and the dask scheduler.
    store
        The job store shared with the API.

    """

    def __init__(self, settings: Settings, store: JobStore):
        self.settings = settings
        self.store = store
        self.log_dir = settings.data_dir / "logs"
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self._running: dict[str, _Running] = {}
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    @property
    def busy(self) -> int:
        """Number of job processes alive now."""
        with self._lock:
            return len(self._running)

    def start(self) -> None:
        """Requeue jobs a stopped service left running, then start the supervisor thread."""
        for job in self.store.recover():
            if job.pid and _is_job_process(job.pid, job.id):
                logger.warning("killing job process %s left over from a previous run", job.pid)
                kill_group(job.pid)
            logger.info("job %s was running when the service stopped: queued again", job.id)
        self._thread = threading.Thread(target=self._loop, name="fmuid-supervisor", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop taking jobs and kill the running job processes.

        Their jobs stay ``running`` in the store, so the next start queues them again.
        """
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout=10)
        with self._lock:
            for run in self._running.values():
                kill_group(run.process.pid)
                run.process.wait()
                run.log.close()
            self._running.clear()

    def wake(self) -> None:
        """Look at the queue now (a job was submitted or cancelled)."""
        self._wake.set()

    def cancel(self, job_id: str) -> None:
        """Kill the process of a job (already marked cancelled in the store), if it runs here."""
        with self._lock:
            run = self._running.get(job_id)
        if run is not None:
            kill_group(run.process.pid)
        self._wake.set()

    def _loop(self) -> None:
        while not self._stop.is_set():
            try:
                self._reap()
                self._enforce_limits()
                self._launch()
            except Exception:  # keep supervising whatever one iteration hit
                logger.exception("supervisor iteration failed")
            self._wake.wait(POLL_S)
            self._wake.clear()

    def _launch(self) -> None:
        while self.busy < self.settings.workers and not self._stop.is_set():
            job = self.store.claim_next()
            if job is None:
                return
            self._spawn(job)

    def _spawn(self, job: Job) -> None:
        cmd = [
            sys.executable,
            "-m",
            "fmuid.jobs.run",
            job.id,
            "--db",
            str(self.settings.database),
            "--data-dir",
            str(self.settings.data_dir),
            "--memory-mb",
            str(self.settings.job_memory_mb),
        ]
        if self.settings.dask_scheduler:
            cmd += ["--dask-scheduler", self.settings.dask_scheduler]
        log_path = self.log_dir / f"{job.id}.log"
        log = open(log_path, "ab")  # noqa: SIM115 - closed when the process is reaped
        env = dict(os.environ, PYTHONFAULTHANDLER="1")
        try:
            process = subprocess.Popen(
                cmd,
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=subprocess.STDOUT,
                env=env,
                start_new_session=True,
            )
        except OSError as exc:
            log.close()
            self.store.fail(job.id, f"could not start a job process: {exc}")
            return
        self.store.set_pid(job.id, process.pid)
        with self._lock:
            self._running[job.id] = _Running(job, process, log, log_path)
        logger.info("job %s (%s) started in process %s", job.id, job.kind, process.pid)

    def _enforce_limits(self) -> None:
        with self._lock:
            runs = list(self._running.values())
        limit = self.settings.job_timeout_s
        for run in runs:
            current = self.store.get(run.job.id)
            if current is None or current.status == "cancelled":
                kill_group(run.process.pid)
            elif time.monotonic() - run.started > limit:
                self.store.fail(run.job.id, f"exceeded the time limit of {limit:g} s")
                kill_group(run.process.pid)

    def _reap(self) -> None:
        with self._lock:
            ended = [run for run in self._running.values() if _has_exited(run.process)]
            for run in ended:
                del self._running[run.job.id]
        for run in ended:
            kill_group(run.process.pid)  # pool workers the job left behind, before pid reuse
            returncode = run.process.wait()
            run.log.close()
            job = self.store.get(run.job.id)
            if job is not None and job.status == "running":
                log = run.log_path.read_text(errors="replace")
                self.store.fail(job.id, exit_message(returncode, log, self.settings.job_memory_mb))
            logger.info("job %s process ended with status %s", run.job.id, returncode)


def _has_exited(process: subprocess.Popen[bytes]) -> bool:
    """Whether a child has exited, without reaping it (its pid stays reserved until then)."""
    if process.returncode is not None:
        return True
    try:
        info = os.waitid(os.P_PID, process.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT)
    except ChildProcessError:
        return True
    return info is not None
