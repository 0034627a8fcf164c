"""Candidates screened and fitted side by side, by the task engine (:mod:`fmuid.engine`).

A screen or a fit depends only on its candidate and the fitted model it augments, so the
results are those of one process, whichever engine runs them; a local pool's workers keep
their FMU instance warm across the diagnosis.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from fmuid.discrepancy.scan import Mapper
from fmuid.engine.run import open_engine
from fmuid.estimation.problem import Problem

PRELOAD = (
    "fmuid.discrepancy.scan",
    "fmuid.profiling.branch",
    "fmuid.experiment_design.discriminate",
)
"""Modules of the diagnosis's tasks (:func:`candidate_pool`)."""


@contextmanager
def candidate_pool(problem: Problem, workers: int, executor: Any = None) -> Iterator[Mapper]:
    """Yield a :data:`~fmuid.discrepancy.scan.Mapper` over a dask client or local processes.

    ``executor`` (a ``dask.distributed.Client``) when given, else ``workers`` local processes
    (1: this one). The first local pool of a process starts its forkserver, and only that
    pool's modules are preloaded: the scan's pool also preloads those of the diagnosis's later
    pools (the profiles, the search for a settling test), whose workers then start with them.
    """
    with open_engine(problem.model, workers=workers, executor=executor, preload=PRELOAD) as engine:
        yield engine.map
