"""Design evaluations side by side: in this process, local worker processes or a dask cluster.

The executors are those of the profile engine (:mod:`fmuid.profiling.parallel`): a ``forkserver``
process pool whose workers die with its owner, or a ``dask.distributed.Client`` whose workers
get the FMU's bytes with each task. One evaluation is one task; each finished one is handed to
the caller in this process (to checkpoint it and report progress) as soon as it is back.
"""

from __future__ import annotations

import os
import pickle
from collections.abc import Callable, Sequence
from concurrent.futures import Future, as_completed
from typing import Any, TypeVar

from fmuid.model.fmu import FmuFile, FmuModel, load_model
from fmuid.model.registry import get_simulator, mark_reset_unreliable
from fmuid.profiling.parallel import PickledTask
from fmuid.profiling.pool_guard import die_with_pool_owner
from fmuid.profiling.worker_pool import local_pool

T = TypeVar("T")
R = TypeVar("R")


def run_evaluations(
    evaluate: Callable[[T], R],
    tasks: Sequence[T],
    model: FmuModel,
    interface: str,
    *,
    workers: int | None = 1,
    executor: Any = None,
    on_done: Callable[[int, R], None] | None = None,
) -> list[R]:
    """Evaluate every task and return the results in the order of ``tasks``.

    Parameters
    ----------
    evaluate
        A picklable function of one task (a module-level function or a bound method of a
        picklable object); it must not depend on the process it runs in, so that every executor
        gives the same numbers.
    tasks
        The evaluations.
    model, interface
        The FMU the evaluations simulate and its FMI interface.
    workers
        Local worker processes (``None``: the CPU count), at most one per task; 1 evaluates in
        this process.
    executor
        A ``dask.distributed.Client``; overrides ``workers``.
    on_done
        Called in this process with ``(index in tasks, result)`` for each finished evaluation.
        If it raises, the evaluations not started are cancelled and the error propagates.

    """
    if not tasks:
        return []
    results: dict[int, R] = {}

    def finished(k: int, result: R) -> None:
        results[k] = result
        if on_done is not None:
            on_done(k, result)

    model = model.with_interface(interface)
    unreliable = get_simulator(model).reset_reliable is False
    if executor is not None:
        _run_dask(evaluate, tasks, model, unreliable, executor, finished)
    elif min(workers or os.cpu_count() or 1, len(tasks)) <= 1:
        for k, task in enumerate(tasks):
            finished(k, evaluate(task))
    else:
        n = min(workers or os.cpu_count() or 1, len(tasks))
        _run_pool(evaluate, tasks, model, unreliable, n, finished)
    return [results[k] for k in range(len(tasks))]


def _init_worker(owner: int, fmu: FmuFile, unreliable: bool) -> None:
    """Die with the pool's owner; parse the FMU once; know its verdict on the FMU's reset."""
    die_with_pool_owner(owner)
    model = load_model(fmu)
    if unreliable:
        mark_reset_unreliable(model)


def _run_pool(
    evaluate: Callable[[T], R],
    tasks: Sequence[T],
    model: FmuModel,
    unreliable: bool,
    n: int,
    finished: Callable[[int, R], None],
) -> None:
    initargs = (os.getpid(), model.file, unreliable)
    with local_pool(n, _init_worker, initargs, preload=[__name__]) as pool:
        futures: dict[Future[R], int] = {pool.submit(evaluate, t): k for k, t in enumerate(tasks)}
        for future in as_completed(futures):
            finished(futures[future], future.result())


def _run_dask(
    evaluate: Callable[[T], R],
    tasks: Sequence[T],
    model: FmuModel,
    unreliable: bool,
    client: Any,
    finished: Callable[[int, R], None],
) -> None:
    from distributed import as_completed as dask_completed

    # the FMU's bytes travel with each task (see fmuid.profiling.parallel._run_dask)
    blob = model.path.read_bytes()
    futures = [
        client.submit(
            evaluate_anywhere,
            PickledTask(model.file, pickle.dumps((evaluate, t))),
            blob,
            unreliable,
            pure=False,
        )
        for t in tasks
    ]
    index = {f.key: k for k, f in enumerate(futures)}
    try:
        for future in dask_completed(futures):
            finished(index[future.key], future.result())
    finally:
        client.cancel([f for f in futures if not f.done()])


def evaluate_anywhere(job: PickledTask, fmu_bytes: bytes, reset_unreliable: bool) -> Any:
    """Evaluate a pickled ``(evaluate, task)`` on a worker that may not see the FMU file."""
    model, (evaluate, task) = job.load(fmu_bytes)
    if reset_unreliable:
        mark_reset_unreliable(model)
    return evaluate(task)
