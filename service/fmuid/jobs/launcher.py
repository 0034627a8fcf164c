"""Start job processes: cold (a new Python) or warm (forked from a server that imported the engine).

A cold start runs the bootstrap of :mod:`fmuid.jobs.proc` in a new interpreter, which imports
the engine (numpy, scipy, FMPy, matplotlib) for every job: seconds of CPU. A warm start asks a
multiprocessing forkserver, started once by the supervisor with the engine preloaded, to fork
the job process: each job still has a process (and process group) of its own, so a crash or a
hang hits only that job, but starts in milliseconds. The server dies with the supervisor
(:mod:`fmuid.engine.forkserver_guard`) and each job process with the server; every one of
them carries the store's tag (:data:`fmuid.jobs.proc.JOB_DB_ENV`) in its environment.
"""

from __future__ import annotations

import contextlib
import faulthandler
import logging
import multiprocessing
import multiprocessing.connection
import multiprocessing.forkserver as forkserver
import os
import subprocess
import sys
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from fmuid.engine.guard import POOL_PARENT_ENV, die_with_pool_owner
from fmuid.jobs.proc import JOB_DB_ENV, JOB_NICENESS, job_command, job_environment
from fmuid.processes import is_alive

logger = logging.getLogger(__name__)

PRELOAD = [
    "fmuid.engine.forkserver_guard",
    "fmuid.jobs.launcher",
    "fmuid.jobs.run",
    "fmuid.jobs.draw",
    "fmuid.stages",
    "fmuid.discrepancy",
    "fmuid.report",
]
"""Modules the warm server imports once (the guard first, so it dies with the service)."""


@dataclass(frozen=True)
class Launch:
    """What a job process needs: its job, arguments of :mod:`fmuid.jobs.run`, log and TMPDIR."""

    job_id: str
    args: list[str]
    log_path: Path
    tmp_dir: Path
    db_path: Path


class JobProcess(Protocol):
    """A started job process."""

    pid: int

    def exited(self) -> bool:
        """Whether the process has ended."""

    def wait(self) -> int:
        """Wait for the end; return the exit status (negative: the signal that ended it)."""

    def wait_end(self) -> None:
        """Block until the process has ended, without collecting its status."""


class ColdProcess:
    """A job process in a new interpreter (:func:`fmuid.jobs.proc.job_command`)."""

    def __init__(self, launch: Launch):
        env = job_environment(launch.db_path, launch.job_id)
        env["TMPDIR"] = str(launch.tmp_dir)
        with open(launch.log_path, "ab") as log:
            self.process = subprocess.Popen(
                job_command(sys.executable, launch.job_id, launch.args),
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=subprocess.STDOUT,
                env=env,
                start_new_session=True,
            )
        self.pid = self.process.pid

    def exited(self) -> bool:
        """Whether the child has exited, without reaping it (its pid stays reserved till then)."""
        if self.process.returncode is not None:
            return True
        try:
            info = os.waitid(os.P_PID, self.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT)
        except ChildProcessError:
            return True
        return info is not None

    def wait(self) -> int:
        """Reap the child; return its exit status."""
        return self.process.wait()

    def wait_end(self) -> None:
        """Block until the child has ended, leaving it to :meth:`wait` to reap."""
        with contextlib.suppress(ChildProcessError):
            os.waitid(os.P_PID, self.pid, os.WEXITED | os.WNOWAIT)


class WarmProcess:
    """A process forked by the warm server (see :class:`WarmServer`)."""

    def __init__(self, process: Any, server_pid: int | None):
        self.process = process
        self.pid: int = process.pid
        self.server_pid = server_pid

    def exited(self) -> bool:
        """Whether the process has ended (the server reaps it and reports its status)."""
        return self.process.exitcode is not None

    def wait(self) -> int:
        """Wait for the end; return the exit status."""
        self.process.join()
        code: int = self.process.exitcode
        return code

    def wait_end(self) -> None:
        """Block until the process has ended (or its server died)."""
        multiprocessing.connection.wait([self.process.sentinel])

    def server_died(self) -> bool:
        """Whether the server that forked this process has died (which killed the process)."""
        return self.server_pid is not None and not is_alive(self.server_pid)


class WarmServer:
    """The forkserver of job and drawing processes, started on first use.

    It is replaced by a new one once it has forked ``recycle_after`` processes and every one
    of them has ended (its processes die with it), so that memory an engine import or a job
    left in it does not pile up; until then :meth:`due` tells the caller to start jobs cold.
    A server that crashed is replaced on the next fork; a fork that fails because the server
    died during it is tried once more on a new server.

    Parameters
    ----------
    db_path
        The job store: the server and its processes carry it as their tag.
    recycle_after
        Processes one server forks before it is replaced.

    """

    def __init__(self, db_path: Path, recycle_after: int):
        self.db_path = db_path
        self.recycle_after = recycle_after
        self._ctx = multiprocessing.get_context("forkserver")
        self._lock = threading.Lock()
        self._forked = 0
        self._live: list[WarmProcess] = []

    def due(self) -> bool:
        """Whether the server has forked its share and waits for its processes to end."""
        with self._lock:
            self._live = [p for p in self._live if not p.exited()]
            return self._forked >= self.recycle_after and bool(self._live)

    def start(self, launch: Launch) -> WarmProcess:
        """Fork a job process for ``launch`` and return it."""
        return self.fork(forked_job, (launch, os.getpid()), f"fmuid-job-{launch.job_id}")

    def fork(self, target: Any, args: tuple[Any, ...], name: str) -> WarmProcess:
        """Fork a process that runs ``target(*args)`` (picklable) and return it."""
        with self._lock:
            self._live = [p for p in self._live if not p.exited()]
            if self._forked >= self.recycle_after and not self._live:
                logger.info("warm server replaced after %d processes", self._forked)
                _forkserver(stop=True)
            server_pid = _forkserver()
            if server_pid is None or not is_alive(server_pid):
                self._forked = 0
            os.environ[JOB_DB_ENV] = str(self.db_path)  # inherited by the server when it starts
            os.environ[POOL_PARENT_ENV] = str(os.getpid())
            os.environ["PYTHONFAULTHANDLER"] = "1"
            self._ctx.set_forkserver_preload(PRELOAD)
            try:
                process = self._start(target, args, name)
            except (OSError, EOFError) as exc:  # the server died while forking
                logger.warning("warm server failed to fork (%s); starting a new one", exc)
                _forkserver(stop=True)
                self._forked = 0
                process = self._start(target, args, name)
            self._forked += 1
            warm = WarmProcess(process, _forkserver())
            self._live.append(warm)
            return warm

    def _start(self, target: Any, args: tuple[Any, ...], name: str) -> Any:
        process = self._ctx.Process(target=target, args=args, name=name)
        process.start()
        return process


def _forkserver(stop: bool = False) -> int | None:
    """Return the pid of multiprocessing's forkserver, or ``None`` when none has started.

    With ``stop``, stop the server first (dead or alive), so that the next fork starts a new
    one, and return ``None``. This is the one place that reaches into multiprocessing's
    private state: its forkserver is a module-global ``ForkServer`` whose public functions
    (``ensure_running``, ``set_forkserver_preload``, ``connect_to_new_process``) neither give
    its pid nor stop it (Python 3.11 to 3.13), and ``Process.start`` of the "forkserver"
    context uses that global, so a server of our own would not serve its processes.
    """
    server: Any = forkserver._forkserver  # type: ignore[attr-defined]
    if stop:
        try:
            server._stop()
        except (OSError, TypeError):  # it died: its socket or alive pipe is gone already
            server._forkserver_pid = server._forkserver_alive_fd = None
            server._forkserver_address = None
    pid: int | None = server._forkserver_pid
    return pid


def forked_job(launch: Launch, service_pid: int) -> None:
    """Body of a warm job process: its own session, log and TMPDIR, then :mod:`fmuid.jobs.run`.

    It dies with the server that forked it (which dies with the service), and exits at once
    when the service is gone already.
    """
    os.setsid()
    die_with_pool_owner(service_pid)
    os.nice(JOB_NICENESS)
    log = os.open(launch.log_path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
    os.dup2(log, 1)
    os.dup2(log, 2)
    os.close(log)
    faulthandler.enable(sys.stderr)
    os.environ["TMPDIR"] = str(launch.tmp_dir)
    tempfile.tempdir = None
    from fmuid.jobs.run import main

    sys.exit(main([launch.job_id, *launch.args]))
