"""Process hygiene in one room: die with the parent, adopt orphans, end a group, cap memory.

Every process fmuid starts (a job and its pool workers and forkserver, a checking process, a
report drawing) calls these; the trees of processes below a job are ended by
:mod:`fmuid.jobs.reaper`, which builds on them. Two places spell the calls out because they run
where fmuid is not imported: the job's ``python -c`` bootstrap (:data:`fmuid.jobs.proc.BOOTSTRAP`,
before any import) and the FMU probe (``intake/probe_fmu.py``, run with ``python -I``).
"""

from __future__ import annotations

import ctypes
import os
import resource
import signal
from collections.abc import Iterator
from pathlib import Path

PR_SET_PDEATHSIG = 1
PR_SET_CHILD_SUBREAPER = 36
MIB = 1024 * 1024


def _prctl(option: int, value: int) -> bool:
    """Call Linux ``prctl(option, value)``; whether the kernel agreed."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return int(libc.prctl(option, value, 0, 0, 0)) == 0
    except (OSError, AttributeError):
        return False


def die_with_parent(sig: int = signal.SIGKILL) -> None:
    """Ask the kernel to send ``sig`` to this process when the thread that forked it ends."""
    _prctl(PR_SET_PDEATHSIG, sig)


def become_subreaper() -> bool:
    """Make orphaned descendants of this process its children; whether the kernel agreed.

    ``PR_SET_CHILD_SUBREAPER`` (Linux 3.4+): see :mod:`fmuid.jobs.reaper`.
    """
    return _prctl(PR_SET_CHILD_SUBREAPER, 1)


def kill_group(pgid: int, sig: int = signal.SIGKILL) -> None:
    """Send ``sig`` to the process group ``pgid``, if it is still there and ours to signal."""
    try:
        os.killpg(pgid, sig)
    except (ProcessLookupError, PermissionError):
        pass


def limit_memory(memory_mb: int) -> None:
    """Cap this process's address space at ``memory_mb`` MiB and switch off core dumps.

    ``RLIMIT_AS`` makes allocations past the limit fail (``MemoryError`` in Python, ``NULL``
    from ``malloc`` in an FMU) instead of exhausting the machine.
    """
    limit = memory_mb * MIB
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


def memory_limit_mb() -> int:
    """Return this process's address-space limit [MiB] (set by :func:`limit_memory`)."""
    return resource.getrlimit(resource.RLIMIT_AS)[0] // MIB


def is_alive(pid: int) -> bool:
    """Whether process ``pid`` exists and is neither a zombie nor dead."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] not in ("Z", "X")


def process_stats() -> Iterator[tuple[int, list[str]]]:
    """Yield each live process's pid and the fields of its ``/proc`` stat after the command.

    The fields start with the state, then the parent's pid, the process group and the session.
    """
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        yield int(entry.name), stat[stat.rindex(")") + 2 :].split()


def kill_session(sid: int) -> None:
    """Send SIGKILL to every process whose session id is ``sid``."""
    for pid, fields in process_stats():
        if int(fields[3]) == sid:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass


def allow_cpu_seconds(seconds: float) -> None:
    """Let this process use ``seconds`` more CPU time, then get ``SIGXCPU`` (soft limit)."""
    used = sum(resource.getrusage(resource.RUSAGE_SELF)[:2])
    soft = int(used + seconds) + 1
    resource.setrlimit(resource.RLIMIT_CPU, (soft, resource.RLIM_INFINITY))
