"""Engines in this machine: one task after the other here, or a pool of worker processes.

A pool worker parses the FMU once, from the file and checksum its owner hands it, and keeps
its instance warm across the tasks; the tasks' pickled problems then find that model
(:func:`fmuid.model.fmu.load_model`). The owner's verdict on the FMU's reset is passed to the
workers (forkserver workers do not inherit it). A task's progress events reach the owner
through a pipe each worker is given when it starts (a pipe cannot travel with a task), tagged
with the task's index; an event is written before its task returns, so that the owner reads a
task's events before its result.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
from collections.abc import Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from contextlib import contextmanager
from typing import Any, TypeVar

from fmuid.engine.guard import die_with_pool_owner
from fmuid.engine.pool import local_pool, stop_pool
from fmuid.engine.task import Engine, OnDone, OnEvent, Task, Until, first_stop
from fmuid.model.fmu import FmuFile, FmuModel, load_model
from fmuid.model.registry import close_at_exit, get_simulator, mark_reset_unreliable

log = logging.getLogger(__name__)

R = TypeVar("R")

_POLL = 0.2
"""Seconds between looks at the progress queue while tasks run."""

_events: Any = None
"""In a pool worker: the pipe to the owner (set by :func:`_init_worker`)."""
_model: FmuModel | None = None
"""In a pool worker: the FMU its tasks simulate (set by :func:`_init_worker`)."""


class SerialEngine(Engine):
    """Run the tasks one after the other in this process."""

    @property
    def parallel(self) -> bool:
        """False: the tasks run here, one after the other."""
        return False

    def run(
        self,
        tasks: Sequence[Task[R]],
        *,
        on_done: OnDone | None = None,
        on_event: OnEvent | None = None,
        until: Until | None = None,
    ) -> list[R]:
        """Execute the tasks in order (see :meth:`Engine.run`)."""
        results = []
        for k, task in enumerate(tasks):

            def report(event: Any, k: int = k) -> None:
                if on_event is not None:
                    on_event(k, event)

            result = task.execute(report)
            results.append(result)
            if on_done is not None:
                on_done(k, result)
            if until is not None and until(k, result):
                break
        return results


def _init_worker(events: Any, owner: int, fmu: FmuFile) -> None:
    """Set up a pool worker: die with the owner, parse the FMU once.

    The worker's FMU registry is closed when the worker ends (its simulators' files deleted).
    The owner's verdict on the FMU's reset comes with every task (:func:`_execute`).
    """
    global _events, _model
    die_with_pool_owner(owner)
    close_at_exit()
    _model = load_model(fmu)
    _events = events


def _execute(run: int, k: int, task: Task[R], unreliable: bool) -> R:
    """Execute task ``k`` of run ``run`` in a pool worker; its events go to the owner tagged.

    The run's number in the tag keeps a task of a run stopped early, still reporting, out of a
    later run's events. ``unreliable``: the owner's verdict on the FMU's reset when the run
    began (a health check may have found it unreliable since the pool started).
    """
    if unreliable and _model is not None:
        mark_reset_unreliable(_model)
    return task.execute(lambda event: _events.put((run, k, event)))


class PoolEngine(Engine):
    """Run the tasks in ``workers`` local worker processes (open it with :meth:`open`)."""

    def __init__(
        self, pool: ProcessPoolExecutor, events: Any, workers: int, model: FmuModel
    ) -> None:
        self._pool = pool
        self._model = model
        self._events = events
        self.workers = workers
        self._abandoned: list[Future[Any]] = []
        self._runs = 0

    @classmethod
    @contextmanager
    def open(
        cls, model: FmuModel, workers: int, preload: Sequence[str] = ()
    ) -> Iterator[PoolEngine]:
        """Yield an engine over ``workers`` processes that simulate ``model``.

        ``preload`` names modules the pool's forkserver imports once (those of the tasks).
        On any exception the workers are ended at once (:func:`fmuid.engine.pool.local_pool`);
        so are they on leaving while tasks of a run stopped early still run.
        """
        events = multiprocessing.get_context("forkserver").SimpleQueue()
        initargs = (events, os.getpid(), model.file)
        with local_pool(workers, _init_worker, initargs, preload=[__name__, *preload]) as pool:
            engine = cls(pool, events, workers, model)
            yield engine
            if any(not f.done() for f in engine._abandoned):
                stop_pool(pool, logging.INFO)

    def run(
        self,
        tasks: Sequence[Task[R]],
        *,
        on_done: OnDone | None = None,
        on_event: OnEvent | None = None,
        until: Until | None = None,
    ) -> list[R]:
        """Execute the tasks in the workers (see :meth:`Engine.run`).

        Raises
        ------
        KeyboardInterrupt
            On Ctrl-C, after logging how many tasks had finished; leaving :meth:`open` then
            ends the workers.

        """
        self._runs += 1
        unreliable = get_simulator(self._model).reset_reliable is False
        futures: dict[Future[R], int] = {
            self._pool.submit(_execute, self._runs, k, task, unreliable): k
            for k, task in enumerate(tasks)
        }
        results: dict[int, R] = {}
        pending = set(futures)
        asked = 0
        try:
            while pending:
                done, pending = wait(pending, timeout=_POLL, return_when=FIRST_COMPLETED)
                self._drain(on_event)
                for future in sorted(done, key=futures.__getitem__):
                    k = futures[future]
                    results[k] = future.result()
                    if on_done is not None:
                        on_done(k, results[k])
                asked, stop = first_stop(results, asked, until)
                if stop is not None:
                    self._abandoned += [f for f in pending if not f.cancel()]
                    return [results[k] for k in range(stop + 1)]
        except KeyboardInterrupt:
            log.warning(
                "interrupted: %d of %d tasks had finished; nothing is kept",
                len(results),
                len(tasks),
            )
            raise
        self._drain(on_event)
        return [results[k] for k in range(len(tasks))]

    def _drain(self, on_event: OnEvent | None) -> None:
        """Hand every event of the current run in the pipe to ``on_event``."""
        while not self._events.empty():
            run, k, event = self._events.get()
            if on_event is not None and run == self._runs:
                on_event(k, event)
