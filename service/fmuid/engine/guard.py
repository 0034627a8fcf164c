"""Pool processes that die with the process that owns the pool (``PR_SET_PDEATHSIG``).

The local pool of :mod:`fmuid.engine.pool` uses multiprocessing's forkserver. The server
preloads :mod:`fmuid.engine.forkserver_guard`, which ties it to the process that started it
(named in :data:`POOL_PARENT_ENV`); the workers it forks call :func:`die_with_pool_owner` in
their initializer. When the owner dies, so does the server, and then its workers. Without this
the server outlives the job, kept alive by the workers, and they by it.
"""

from __future__ import annotations

import os

from fmuid.processes import die_with_parent, is_alive

POOL_PARENT_ENV = "FMUID_POOL_PARENT"


def die_with_pool_owner(owner: int) -> None:
    """Die with the parent (the forkserver), and exit now if the pool's owner is gone already."""
    die_with_parent()
    if not is_alive(owner):
        os._exit(1)
