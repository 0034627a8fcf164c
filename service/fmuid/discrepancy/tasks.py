"""Candidates screened and fitted side by side: local worker processes or a dask cluster.

The local pool is the one the profiles use (:func:`fmuid.profiling.worker_pool.local_pool`:
forkserver workers that never import the caller's script and stop at once on Ctrl-C); each
worker parses the FMU once, from the file and checksum the owner hands it, and keeps its
instance warm across the diagnosis. A screen or a fit depends only on its candidate and the
fitted model it augments, so the results are those of one process. On a ``dask.distributed``
cluster each task carries the FMU's bytes, as a profile branch does
(:class:`fmuid.profiling.parallel.PickledTask`): a worker that cannot see the file parses a
local copy once.
"""

from __future__ import annotations

import os
import pickle
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from fmuid.discrepancy.scan import Mapper, serial
from fmuid.errors import FmuError
from fmuid.estimation.problem import Problem
from fmuid.model.fmu import FmuFile, load_model
from fmuid.model.registry import get_simulator, mark_reset_unreliable
from fmuid.profiling.parallel import PickledTask
from fmuid.profiling.pool_guard import die_with_pool_owner
from fmuid.profiling.worker_pool import local_pool


def _init_worker(owner: int, fmu: FmuFile, unreliable: bool) -> None:
    """Die with the owner, parse the FMU once, know the owner's verdict on its reset."""
    die_with_pool_owner(owner)
    model = load_model(fmu)
    if unreliable:
        mark_reset_unreliable(model)


def run_anywhere(task: PickledTask, sha256: str, fmu_bytes: bytes, unreliable: bool) -> Any:
    """Run a pickled ``(fn, args)`` on a worker that may not see the FMU file."""
    model, (fn, args) = task.load(fmu_bytes)
    if model.sha256 != sha256:
        raise FmuError(f"{model.path}: sha256 {model.sha256[:12]}..., expected {sha256[:12]}...")
    if unreliable:
        mark_reset_unreliable(model)
    return fn(*args)


def dask_mapper(client: Any, problem: Problem) -> Mapper:
    """Return a mapper whose calls run as tasks of a ``dask.distributed.Client``."""
    model = problem.model
    blob = model.path.read_bytes()
    unreliable = get_simulator(model).reset_reliable is False

    def mapper(fn: Callable[..., Any], *iterables: Sequence[Any]) -> list[Any]:
        futures = [
            client.submit(
                run_anywhere,
                PickledTask(model.file, pickle.dumps((fn, args))),
                model.sha256,
                blob,
                unreliable,
                pure=False,
            )
            for args in zip(*iterables, strict=True)
        ]
        return list(client.gather(futures))

    return mapper


@contextmanager
def candidate_pool(problem: Problem, workers: int, executor: Any = None) -> Iterator[Mapper]:
    """Yield a :data:`~fmuid.discrepancy.scan.Mapper` over a dask client or local processes.

    ``executor`` (a ``dask.distributed.Client``) when given, else ``workers`` local processes
    (1: this one).
    """
    if executor is not None:
        yield dask_mapper(executor, problem)
        return
    if workers <= 1:
        yield serial
        return
    unreliable = get_simulator(problem.model).reset_reliable is False
    initargs = (os.getpid(), problem.model.file, unreliable)
    with local_pool(workers, _init_worker, initargs, preload=["fmuid.discrepancy.scan"]) as pool:

        def mapper(fn: Any, *iterables: Sequence[Any]) -> list[Any]:
            return list(pool.map(fn, *iterables))

        yield mapper
