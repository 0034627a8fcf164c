"""Pool processes that die with the process that owns the pool (``PR_SET_PDEATHSIG``).

The local pool of :mod:`fmuid.profiling.parallel` uses multiprocessing's forkserver. The server
preloads :mod:`fmuid.profiling.forkserver_guard`, which ties it to the process that started it
(named in :data:`POOL_PARENT_ENV`); the workers it forks call :func:`die_with_pool_owner` in
their initializer. When the owner dies, so does the server, and then its workers. Without this
the server outlives the job, kept alive by the workers, and they by it.
"""

from __future__ import annotations

import ctypes
import os
import signal
from pathlib import Path

POOL_PARENT_ENV = "FMUID_POOL_PARENT"
_PR_SET_PDEATHSIG = 1


def die_with_parent() -> None:
    """Ask the kernel to SIGKILL this process when the thread that forked it ends."""
    ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)


def die_with_pool_owner(owner: int) -> None:
    """Die with the parent (the forkserver), and exit now if the pool's owner is gone already."""
    die_with_parent()
    if not _alive(owner):
        os._exit(1)


def _alive(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] not in ("Z", "X")
