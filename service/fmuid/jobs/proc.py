"""Process hygiene of job processes: start them tagged, find them again, end them for sure.

Every job process (the leader) is started in a new session, so it leads its own process group,
with two environment variables that its children inherit (its pool workers, a forkserver, any
process the FMU forks): :data:`JOB_DB_ENV` (the job store's database) and :data:`JOB_ID_ENV`.
A service that restarts after a crash finds every process carrying its database's tag in
``/proc/<pid>/environ`` and kills it, whatever its parent or group, before it queues the
interrupted jobs again.

The leader asks the kernel to kill it when the supervisor thread that started it dies
(``PR_SET_PDEATHSIG``) as the first thing it does, before importing anything heavy, and exits
at once if the service is already gone by then.
"""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

from fmuid.jobs.reaper import kill_tree
from fmuid.processes import is_alive, kill_group

JOB_NICENESS = 5
"""Job and report drawing processes run at this lower priority, so that on a machine whose cores
they fill the service still answers health and polls at once (checking processes run lower
still, :data:`fmuid.intake.vet.NICENESS`)."""
JOB_DB_ENV = "FMUID_JOB_DB"
JOB_ID_ENV = "FMUID_JOB_ID"
PARENT_ENV = "FMUID_JOB_PARENT"

BOOTSTRAP = f"""\
import ctypes, os, signal, sys
ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL, 0, 0, 0)
os.nice({JOB_NICENESS})
if os.getppid() != int(os.environ["FMUID_JOB_PARENT"]):
    sys.exit("fmuid.jobs.run: the service that started this job is gone")
import runpy
sys.argv[0] = "fmuid.jobs.run"
runpy.run_module("fmuid.jobs.run", run_name="__main__", alter_sys=True)
"""
"""``python -c`` program of a job process: die with the parent, then run :mod:`fmuid.jobs.run`.

``1`` is ``PR_SET_PDEATHSIG``; the priority is lowered (:data:`JOB_NICENESS`) before the
imports. The module name stays in the command line, so ``pgrep -f
fmuid.jobs.run`` finds job processes.
"""


def job_command(python: str, job_id: str, args: list[str]) -> list[str]:
    """Return the command line of the job process of ``job_id`` (see :data:`BOOTSTRAP`)."""
    return [python, "-c", BOOTSTRAP, job_id, *args]


def job_environment(db_path: Path, job_id: str) -> dict[str, str]:
    """Return the environment of a job process: this one's plus its tags and parent pid."""
    return dict(
        os.environ,
        PYTHONFAULTHANDLER="1",
        **{JOB_DB_ENV: str(db_path), JOB_ID_ENV: job_id, PARENT_ENV: str(os.getpid())},
    )


def end_job(pid: int) -> None:
    """Kill a live job leader, every process below it (:mod:`fmuid.jobs.reaper`) and its group."""
    kill_tree(pid)
    kill_group(pid)


def _environ(pid: int) -> dict[str, str]:
    try:
        raw = Path(f"/proc/{pid}/environ").read_bytes()
    except OSError:
        return {}
    pairs = (item.split(b"=", 1) for item in raw.split(b"\0") if b"=" in item)
    return {k.decode(errors="replace"): v.decode(errors="replace") for k, v in pairs}


def find_job_processes(db_path: Path, job_id: str | None = None) -> list[int]:
    """Return the pids of live processes tagged with ``db_path`` (and ``job_id`` when given).

    Parameters
    ----------
    db_path
        The job store's database: processes of other services on this machine are left alone.
    job_id
        Only the processes of this job.

    """
    found = []
    own = os.getpid()
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == own:
            continue
        env = _environ(int(entry.name))
        if env.get(JOB_DB_ENV) != str(db_path):
            continue
        if job_id is None or env.get(JOB_ID_ENV) == job_id:
            found.append(int(entry.name))
    return found


def end_processes(pids: list[int], timeout: float = 10.0) -> list[int]:
    """SIGKILL ``pids`` and wait until they are gone; return those still there at ``timeout``.

    A killed process whose parent is not this one stays a zombie until that parent reaps it;
    zombies count as gone (they hold no memory and no files).
    """
    for pid in pids:
        try:
            os.kill(pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
    deadline = time.monotonic() + timeout
    left = pids
    while left:
        left = [pid for pid in left if is_alive(pid)]
        if not left or time.monotonic() > deadline:
            break
        time.sleep(0.05)
    return left
