"""The supervisor: a thread in the service that runs queued jobs, each in its own process.

Every job runs in a job process (:mod:`fmuid.jobs.run`, started as :mod:`fmuid.jobs.proc` says)
in a new session (its own process group), with its stderr in its log and its temporary files in
its own folder (:class:`fmuid.jobs.layout.DataLayout`). The supervisor keeps at most
``settings.workers`` of them alive, kills a group past ``settings.job_timeout_s`` or when its job
is cancelled, and, when a process ends without recording an outcome (a segfault, the OOM killer),
fails its job with the reason read from the exit status and the log; when the store cannot take
that outcome (a full disk), it tries again on every round until it can.

One service owns a data folder: it holds an exclusive lock of the operating system on it for
its whole life (:mod:`fmuid.jobs.owner`), so that a second one refuses to start, and a lease in
the store, which every claim of a job checks; a service that finds its lease gone stops
claiming, says so in health and exits. On start it takes the lock and the lease, kills every
process left by the previous run of the same store, queues the interrupted jobs again and
removes their leftover files. Every :data:`MAINTENANCE_S` it removes jobs past
``settings.retention_s`` and files no job owns.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import sqlite3
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from fmuid.jobs import housekeeping as hk
from fmuid.jobs import restarts
from fmuid.jobs.crash import exit_message
from fmuid.jobs.launcher import ColdProcess, JobProcess, Launch, WarmProcess, WarmServer
from fmuid.jobs.layout import fit_own_tmp
from fmuid.jobs.owner import OwnerLock, StoreInUse
from fmuid.jobs.proc import end_job, end_processes, find_job_processes
from fmuid.jobs.store import Job, JobStore, StoreError
from fmuid.processes import kill_group
from fmuid.settings import Settings

logger = logging.getLogger(__name__)

POLL_S = 0.2
LEASE_RENEW_S = 3.0
MAINTENANCE_S = 30.0
FAILED_ROUND_PAUSE_S = 2.0


@dataclass
class _Running:
    job: Job
    process: JobProcess
    log_path: Path
    started: float = field(default_factory=time.monotonic)


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
        self.layout = store.layout
        self.layout.logs.mkdir(parents=True, exist_ok=True)
        fit_own_tmp()  # and a TMPDIR too long for any socket path is refused here
        self.layout.job_tmp_root.parent.mkdir(parents=True, exist_ok=True)
        self._running: dict[str, _Running] = {}
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._unrecorded: dict[str, str] = {}  # job id -> failure the store could not take yet
        self._renewed = 0.0
        self._maintained = 0.0
        self._recovered = False
        self._lost: str | None = None
        self._owner = OwnerLock(settings.data_dir, settings.database)
        self._warm = WarmServer(settings.database, settings.warm_recycle_jobs)

    @property
    def warm(self) -> WarmServer:
        """The warm server that forks job (and report drawing) processes."""
        return self._warm

    @property
    def problem(self) -> str | None:
        """Why this service no longer supervises its store (``None`` while it does)."""
        return self._lost

    @property
    def busy(self) -> int:
        """Number of job processes alive now."""
        with self._lock:
            return len(self._running)

    def start(self) -> None:
        """Take the store's lease, end what a previous run left, requeue its jobs, then start.

        A store that cannot be read or written now is tried again every round; no job starts
        until then.

        Raises
        ------
        StoreInUse
            When another live service holds the data folder.
        LeaseHeld
            When another live service uses the same store.

        """
        try:
            self._owner.acquire()
        except StoreInUse as exc:
            logger.error("not starting: %s", exc)
            raise
        try:
            self._recover()
        except restarts.LeaseHeld:
            self._owner.release()
            raise
        except (StoreError, sqlite3.Error):
            logger.exception("cannot recover the jobs of %s yet", self.settings.database)
        self._thread = threading.Thread(target=self._loop, name="fmuid-supervisor", daemon=True)
        self._thread.start()

    def _recover(self) -> None:
        restarts.take_lease(self.store)
        self._renewed = time.monotonic()
        leftovers = find_job_processes(self.settings.database)
        if leftovers:
            logger.warning("ending %d process(es) of a previous run: %s", len(leftovers), leftovers)
            stuck = end_processes(leftovers)
            if stuck:
                logger.error("processes of a previous run would not die: %s", stuck)
        for job in restarts.recover(self.store):
            logger.info("job %s was running when the service stopped: queued again", job.id)
        hk.remove_orphans(self.store, alive=set())
        for partial in self.layout.reports.glob("*.tmp"):
            hk.remove_paths([partial])
        self._recovered = True

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
                end_job(run.process.pid)
                run.process.wait()
                hk.remove_paths([self.layout.job_tmp(run.job.id)])
            self._running.clear()
        root = self.layout.job_tmp_root  # whatever a job or a drawing left there, then itself
        hk.remove_paths(list(root.iterdir()) if root.is_dir() else [])
        with contextlib.suppress(OSError):
            root.rmdir()
        try:
            if self._lost is None:
                restarts.release_lease(self.store)
        except StoreError:
            logger.exception("could not release the lease of the job store")
        try:
            self.store.checkpoint()
        except sqlite3.Error:
            logger.exception("could not checkpoint the job store %s", self.settings.database)
        self._owner.release()

    def wake(self) -> None:
        """Look at the queue now (a job was submitted or cancelled)."""
        self._wake.set()

    def cancel(self, job_id: str) -> None:
        """Kill the process of a job (already marked cancelled in the store), if it runs here."""
        with self._lock:
            run = self._running.get(job_id)
        if run is not None:
            end_job(run.process.pid)
        self._wake.set()

    def _loop(self) -> None:
        while not self._stop.is_set():
            try:
                if not self._recovered:
                    self._recover()
                self._reap()
                self._record_unrecorded()
                self._enforce_limits()
                self._housekeeping()
                self._launch()
                delay = POLL_S
            except Exception:  # keep supervising whatever one iteration hit
                logger.exception("supervisor iteration failed")
                delay = FAILED_ROUND_PAUSE_S
            self._wake.wait(delay)
            self._wake.clear()

    def _launch(self) -> None:
        while self.busy < self.settings.workers and not self._stop.is_set():
            job = self.store.claim_next(owner=os.getpid())
            if job is None:
                return
            self._spawn(job)

    def _housekeeping(self) -> None:
        now = time.monotonic()
        if now - self._renewed > LEASE_RENEW_S:
            if not restarts.renew_lease(self.store):
                self._lose_lease()
                return
            self._renewed = now
        retention = self.settings.retention_s
        interval = min(MAINTENANCE_S, retention / 4) if retention > 0 else MAINTENANCE_S
        if now - self._maintained < interval:
            return
        self._maintained = now
        if retention > 0:
            expired = hk.expired_jobs(self.store, retention)
            for job_id in hk.delete_jobs(self.store, expired):
                logger.info("job %s removed by retention (FMUID_RETENTION_S)", job_id)
        with self._lock:
            alive = set(self._running)
        hk.remove_orphans(self.store, alive)
        hk.remove_unused_blobs(self.store)
        self.store.keep_reserve()

    def _lose_lease(self) -> None:
        """Another service took the store: claim nothing more, fail health, and exit."""
        self._lost = f"another service took the job store {self.settings.database}; exiting"
        logger.error("%s", self._lost)
        self._stop.set()
        os.kill(os.getpid(), signal.SIGTERM)  # uvicorn stops the app: stop() kills our jobs

    def _spawn(self, job: Job) -> None:
        args = [
            "--db",
            str(self.settings.database),
            "--data-dir",
            str(self.settings.data_dir),
            "--memory-mb",
            str(self.settings.job_memory_mb),
            "--timeout-s",
            str(self.settings.job_timeout_s),
            "--min-free-bytes",
            str(self.settings.min_free_bytes),
            "--service-pid",
            str(os.getpid()),
        ]
        if self.settings.dask_scheduler:
            args += ["--dask-scheduler", self.settings.dask_scheduler]
        log_path = self.layout.log(job.id)
        tmp = self.layout.job_tmp(job.id)
        launch = Launch(job.id, args, log_path, tmp, self.settings.database)
        try:
            tmp.mkdir(parents=True, exist_ok=True)
            process = self._start(launch)
        except OSError as exc:
            self.store.fail(job.id, f"could not start a job process: {exc}")
            return
        self.store.set_pid(job.id, process.pid)
        with self._lock:
            if self._stop.is_set():  # stop() gave up waiting for this thread: leave nothing
                end_job(process.pid)
                hk.remove_paths([tmp])
                return
            self._running[job.id] = _Running(job, process, log_path)
        threading.Thread(target=self._wake_at_end, args=(process,), daemon=True).start()
        logger.info("job %s (%s) started in process %s", job.id, job.kind, process.pid)

    def _start(self, launch: Launch) -> JobProcess:
        """Fork the job process from the warm server; start it cold when that cannot be done.

        While the warm server waits for its processes to end before it is replaced
        (``FMUID_WARM_RECYCLE_JOBS``), jobs start cold.
        """
        if self.settings.warm_start and not self._warm.due():
            try:
                return self._warm.start(launch)
            except Exception:  # a server that cannot fork must not lose the job
                logger.exception("warm start of job %s failed; starting it cold", launch.job_id)
        return ColdProcess(launch)

    def _wake_at_end(self, process: JobProcess) -> None:
        """Wake the loop as soon as ``process`` ends, so that the next job starts at once."""
        process.wait_end()
        self._wake.set()

    def _enforce_limits(self) -> None:
        with self._lock:
            runs = list(self._running.values())
        limit = self.settings.job_timeout_s
        for run in runs:
            current = self.store.get(run.job.id)
            if current is None or current.status == "cancelled":
                end_job(run.process.pid)
            elif time.monotonic() - run.started > limit:
                self.store.fail(run.job.id, f"exceeded the time limit of {limit:g} s")
                end_job(run.process.pid)

    def _reap(self) -> None:
        with self._lock:
            ended = [run for run in self._running.values() if run.process.exited()]
            for run in ended:
                del self._running[run.job.id]
        for run in ended:
            kill_group(run.process.pid)  # pool workers the job left behind, before pid reuse
            returncode = run.process.wait()
            hk.remove_paths([self.layout.job_tmp(run.job.id)])
            logger.info("job %s process ended with status %s", run.job.id, returncode)
            job = self.store.get(run.job.id)
            if job is None or job.status != "running":
                continue
            if isinstance(run.process, WarmProcess) and run.process.server_died():
                reason = "its process died with the warm server that forked it"
                queued = restarts.requeue(self.store, job.id, reason)
                outcome = "queued again" if queued else "failed"
                logger.warning("job %s: %s; %s", job.id, reason, outcome)
                continue
            log = run.log_path.read_text(errors="replace")
            reason = exit_message(returncode, log, self.settings.job_memory_mb)
            self._unrecorded[job.id] = reason

    def _record_unrecorded(self) -> None:
        for job_id, reason in list(self._unrecorded.items()):
            try:
                self.store.fail(job_id, reason)
            except StoreError:
                logger.exception("cannot record that job %s failed yet", job_id)
                return
            del self._unrecorded[job_id]
