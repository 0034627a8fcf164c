"""Candidates screened and fitted side by side, by the task engine (:mod:`fmuid.engine`).

A screen or a fit depends only on its candidate and the fitted model it augments, so the
results are those of one process, whichever engine runs them; a local pool's workers keep
their FMU instance warm across the diagnosis.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from fmuid.engine.run import open_engine
from fmuid.engine.task import Engine
from fmuid.estimation.problem import Problem

PRELOAD = (
    "fmuid.discrepancy.scan",
    "fmuid.profiling.branch",
    "fmuid.experiment_design.discriminate",
)
"""Modules of the diagnosis's tasks (:func:`candidate_pool`)."""


@contextmanager
def candidate_pool(problem: Problem, workers: int, executor: Any = None) -> Iterator[Engine]:
    """Yield the diagnosis's task engine over a dask client or local processes.

    ``executor`` (a ``dask.distributed.Client``) when given, else ``workers`` local processes
    (1: this one). Its ``map`` is the scan's :data:`~fmuid.discrepancy.scan.Mapper`, and the
    diagnosis's profiles and search for a settling test run on it too: a local pool's workers
    start once and keep their FMU instance warm across the diagnosis (a pool per profile
    started its processes anew: about 1 s of a diagnosis with look-alikes to profile). The
    pool preloads the modules of all those tasks.
    """
    with open_engine(problem.model, workers=workers, executor=executor, preload=PRELOAD) as engine:
        yield engine
