"""Pick the engine for a stage: dask when given a client, else local workers or this process."""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from fmuid.engine.cluster import DaskEngine
from fmuid.engine.count import CountingEngine
from fmuid.engine.local import PoolEngine, SerialEngine
from fmuid.engine.task import Engine
from fmuid.model.fmu import FmuModel


@contextmanager
def open_engine(
    model: FmuModel,
    *,
    workers: int | None = 1,
    executor: Any = None,
    at_most: int | None = None,
    preload: Sequence[str] = (),
) -> Iterator[Engine]:
    """Yield the engine that runs tasks simulating ``model``; end its workers on leaving.

    The tasks' simulations count in this process as their results come back
    (:class:`~fmuid.engine.count.CountingEngine`).

    Parameters
    ----------
    model
        The FMU (with the interface the tasks drive) that the workers parse once.
    workers
        Local worker processes (``None`` or 0: the CPU count); 1 runs the tasks in this process.
    executor
        A ``dask.distributed.Client``, or an engine already open (a diagnosis's, whose workers
        have started: its tasks' simulations are counted by it); overrides ``workers``.
    at_most
        The number of tasks, when known: no more workers are started.
    preload
        Modules the local workers' forkserver imports once (those defining the tasks).

    """
    if isinstance(executor, Engine):
        yield executor
        return
    if executor is not None:
        yield CountingEngine(DaskEngine(executor, model))
        return
    n = workers or os.cpu_count() or 1
    if at_most is not None:
        n = min(n, at_most)
    if n <= 1:
        yield CountingEngine(SerialEngine())
        return
    with PoolEngine.open(model, n, preload) as engine:
        yield CountingEngine(engine)
