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


@contextmanager
def candidate_pool(problem: Problem, workers: int, executor: Any = None) -> Iterator[Mapper]:
    """Yield a :data:`~fmuid.discrepancy.scan.Mapper` over a dask client or local processes.

    ``executor`` (a ``dask.distributed.Client``) when given, else ``workers`` local processes
    (1: this one).
    """
    with open_engine(
        problem.model, workers=workers, executor=executor, preload=["fmuid.discrepancy.scan"]
    ) as engine:
        yield engine.map
