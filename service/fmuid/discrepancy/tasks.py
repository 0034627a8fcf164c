"""Candidates screened and fitted side by side, in local worker processes.

The pool is the one the profiles use (:func:`fmuid.profiling.worker_pool.local_pool`: forkserver
workers that never import the caller's script and stop at once on Ctrl-C); each worker parses
the FMU once, from the file and checksum the owner hands it, and keeps its instance warm across
the diagnosis. A screen or a fit depends only on its candidate and the fitted model it augments,
so the results are those of one process.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from fmuid.discrepancy.scan import Mapper, serial
from fmuid.estimation.problem import Problem
from fmuid.model.fmu import FmuFile, load_model
from fmuid.model.registry import get_simulator, mark_reset_unreliable
from fmuid.profiling.pool_guard import die_with_pool_owner
from fmuid.profiling.worker_pool import local_pool


def _init_worker(owner: int, fmu: FmuFile, unreliable: bool) -> None:
    """Die with the owner, parse the FMU once, know the owner's verdict on its reset."""
    die_with_pool_owner(owner)
    model = load_model(fmu)
    if unreliable:
        mark_reset_unreliable(model)


@contextmanager
def candidate_pool(problem: Problem, workers: int) -> Iterator[Mapper]:
    """Yield a :data:`~fmuid.discrepancy.scan.Mapper` over ``workers`` processes (1: this one)."""
    if workers <= 1:
        yield serial
        return
    unreliable = get_simulator(problem.model).reset_reliable is False
    initargs = (os.getpid(), problem.model.file, unreliable)
    with local_pool(workers, _init_worker, initargs, preload=["fmuid.discrepancy.scan"]) as pool:

        def mapper(fn: Any, *iterables: Sequence[Any]) -> list[Any]:
            return list(pool.map(fn, *iterables))

        yield mapper
