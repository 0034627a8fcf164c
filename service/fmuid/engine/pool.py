"""The local worker pool of the task engine: stops at once on Ctrl-C, never re-runs a script.

The tasks of :class:`fmuid.engine.local.PoolEngine` (profile branches, design evaluations,
diagnosis candidates) run in :class:`~concurrent.futures.ProcessPoolExecutor`
workers started by multiprocessing's forkserver (this process may have threads: BLAS, a job's
watchdog). Two habits of the standard pool are unwelcome here:

- A worker normally imports the caller's main script again (as ``__mp_main__``), so a script
  without an ``if __name__ == "__main__":`` guard runs its fit once more in every worker. Our
  workers never need the user's main module (their tasks are fmuid objects), so it is not
  imported: the workers are told the main module is ``__main__`` itself, which multiprocessing
  leaves alone.
- On an exception in the owner (``KeyboardInterrupt`` from Ctrl-C in a terminal, a notebook's
  interrupt button), leaving ``with ProcessPoolExecutor(...)`` waits for the running tasks to
  finish: tens of seconds. Here the workers are terminated at once and the exception goes on.

Workers ignore SIGINT: a terminal's Ctrl-C reaches the whole process group, and the owner alone
decides what happens (see :mod:`fmuid.engine.guard` for an owner that dies).
"""

from __future__ import annotations

import importlib.machinery
import logging
import os
import signal
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from multiprocessing import popen_forkserver
from multiprocessing.context import ForkServerContext, ForkServerProcess
from typing import Any

from fmuid.engine.guard import POOL_PARENT_ENV

log = logging.getLogger(__name__)

_STOP_WAIT = 1.0
"""Seconds a terminated worker gets before it is killed."""


class _Popen(popen_forkserver.Popen):
    """Forkserver launch that tells the worker not to import the owner's main script."""

    def _launch(self, process_obj: Any) -> None:
        # multiprocessing does not import a main module whose spec names ``__main__``
        # (spawn.prepare); a script's (``__file__``) or a ``python -m`` module's otherwise is
        main = sys.modules["__main__"]
        spec = getattr(main, "__spec__", None)
        main.__spec__ = importlib.machinery.ModuleSpec("__main__", None)
        try:
            super()._launch(process_obj)  # type: ignore[misc]  # typeshed lacks _launch
        finally:
            main.__spec__ = spec


class _Process(ForkServerProcess):
    @staticmethod
    def _Popen(process_obj: Any) -> _Popen:
        return _Popen(process_obj)


class _Context(ForkServerContext):
    Process = _Process  # type: ignore[assignment]


def _ignore_sigint_then(initializer: Callable[..., None], *initargs: Any) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    initializer(*initargs)


@contextmanager
def local_pool(
    workers: int,
    initializer: Callable[..., None],
    initargs: Sequence[Any],
    preload: Sequence[str] = (),
) -> Iterator[ProcessPoolExecutor]:
    """Yield a pool of ``workers`` forkserver processes; stop them at once on any exception.

    Parameters
    ----------
    workers
        Number of worker processes.
    initializer, initargs
        Run in each worker once it has started (after SIGINT is set to be ignored).
    preload
        Modules the forkserver imports once, so that workers start with them loaded
        (besides :mod:`fmuid.engine.forkserver_guard`).

    Notes
    -----
    On leaving normally the pool is shut down, waiting for its workers. On an exception
    (``KeyboardInterrupt`` included) queued tasks are cancelled, running workers terminated
    (killed after 1 s) and the exception re-raised.
    """
    ctx = _Context()
    ctx.set_forkserver_preload(["fmuid.engine.forkserver_guard", *preload])
    os.environ[POOL_PARENT_ENV] = str(os.getpid())
    pool = ProcessPoolExecutor(
        workers,
        mp_context=ctx,
        initializer=_ignore_sigint_then,
        initargs=(initializer, *initargs),
    )
    try:
        yield pool
    except BaseException:
        stop_pool(pool)
        raise
    pool.shutdown(wait=True)


def stop_pool(pool: ProcessPoolExecutor, level: int = logging.WARNING) -> None:
    """Cancel what is queued and end the pool's worker processes now (SIGTERM, then SIGKILL).

    ``level``: of the log record that says so (INFO when the tasks are no longer wanted).
    """
    workers = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in workers:
        process.terminate()
    deadline = time.monotonic() + _STOP_WAIT
    for process in workers:
        process.join(max(0.0, deadline - time.monotonic()))
        if process.is_alive():
            process.kill()
            process.join(_STOP_WAIT)
    log.log(level, "stopped %d worker process(es); their unfinished tasks are lost", len(workers))
