"""Start job processes: cold (a new Python) or warm (forked from a server that imported the engine).

A cold start runs the bootstrap of :mod:`fmuid.jobs.proc` in a new interpreter, which imports
the engine (numpy, scipy, FMPy, matplotlib) for every job: seconds of CPU. A warm start asks a
multiprocessing forkserver, started once by the supervisor with the engine preloaded, to fork
the job process: each job still has a process (and process group) of its own, so a crash or a
hang hits only that job, but starts in milliseconds. The server dies with the supervisor
(:mod:`fmuid.profile.forkserver_guard`) and each job process with the server; every one of
them carries the store's tag (:data:`fmuid.jobs.proc.JOB_DB_ENV`) in its environment.
"""

from __future__ import annotations

import faulthandler
import multiprocessing
import os
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from fmuid.jobs.proc import JOB_DB_ENV, job_command, job_environment
from fmuid.profile.pool_guard import POOL_PARENT_ENV, die_with_pool_owner

PRELOAD = [
    "fmuid.profile.forkserver_guard",
    "fmuid.jobs.launcher",
    "fmuid.jobs.run",
    "fmuid.stages",
    "fmuid.diagnose",
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


class WarmProcess:
    """A job process forked by the warm server (see :class:`WarmServer`)."""

    def __init__(self, process: Any):
        self.process = process
        self.pid: int = process.pid

    def exited(self) -> bool:
        """Whether the process has ended (the server reaps it and reports its status)."""
        return self.process.exitcode is not None

    def wait(self) -> int:
        """Wait for the end; return the exit status."""
        self.process.join()
        code: int = self.process.exitcode
        return code


class WarmServer:
    """The forkserver of job processes, started on first use by the supervisor's thread.

    Parameters
    ----------
    db_path
        The job store: the server and its job processes carry it as their tag.

    """

    def __init__(self, db_path: Path):
        self.db_path = db_path
        self._ctx = multiprocessing.get_context("forkserver")

    def start(self, launch: Launch) -> WarmProcess:
        """Fork a job process for ``launch`` and return it."""
        os.environ[JOB_DB_ENV] = str(self.db_path)  # inherited by the server when it starts
        os.environ[POOL_PARENT_ENV] = str(os.getpid())
        os.environ["PYTHONFAULTHANDLER"] = "1"
        self._ctx.set_forkserver_preload(PRELOAD)
        process = self._ctx.Process(
            target=forked_job,
            args=(launch, os.getpid()),
            name=f"fmuid-job-{launch.job_id}",
        )
        process.start()
        return WarmProcess(process)


def forked_job(launch: Launch, service_pid: int) -> None:
    """Body of a warm job process: its own session, log and TMPDIR, then :mod:`fmuid.jobs.run`.

    It dies with the server that forked it (which dies with the service), and exits at once
    when the service is gone already.
    """
    os.setsid()
    die_with_pool_owner(service_pid)
    log = os.open(launch.log_path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
    os.dup2(log, 1)
    os.dup2(log, 2)
    os.close(log)
    faulthandler.enable(sys.stderr)
    os.environ["TMPDIR"] = str(launch.tmp_dir)
    tempfile.tempdir = None
    from fmuid.jobs.run import main

    sys.exit(main([launch.job_id, *launch.args]))
