"""Simulations counted as they run: counts open around a stage, tasks that bring theirs back.

A stage opens a count around its work (:func:`counting`); every simulation run in this process
adds to every count open (:func:`counted`, called by
:class:`fmuid.estimation.problem.Problem`), so nested stages each see their own cost. A task of
the engine runs apart (its simulations go to its own count only, whichever process runs it) and
its count is added to the counts open in the owner when its result comes back
(:class:`CountingEngine`): a stage costs the same in this process, in local workers and on dask.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from fmuid.engine.task import Engine, OnDone, OnEvent, Report, Task, Until, label

R = TypeVar("R")


@dataclass
class Count:
    """The simulations run while this count was open."""

    simulations: int = 0


_OPEN: ContextVar[tuple[Count, ...]] = ContextVar("fmuid_open_counts", default=())


@contextmanager
def counting(*, apart: bool = False) -> Iterator[Count]:
    """Yield a count of the simulations run in this block.

    Parameters
    ----------
    apart
        Hide the block's simulations from the counts already open (a task's: its owner adds
        the count when the result comes back).

    """
    count = Count()
    token = _OPEN.set((count,) if apart else (*_OPEN.get(), count))
    try:
        yield count
    finally:
        _OPEN.reset(token)


def counted(simulations: int = 1) -> None:
    """Add ``simulations`` to every count open."""
    for count in _OPEN.get():
        count.simulations += simulations


@dataclass(frozen=True)
class Counted(Generic[R]):
    """A task run apart, returning its result and the simulations it ran."""

    task: Task[R]

    def execute(self, report: Report) -> tuple[R, int]:
        """Execute the task; return its result and its count."""
        with counting(apart=True) as count:
            result = self.task.execute(report)
        return result, count.simulations

    @property
    def label(self) -> str:
        """The task's label."""
        return label(self.task)


class CountingEngine(Engine):
    """An engine whose tasks' simulations count in this process as their results come back."""

    def __init__(self, engine: Engine) -> None:
        self._engine = engine

    @property
    def parallel(self) -> bool:
        """Whether the wrapped engine runs its tasks side by side."""
        return self._engine.parallel

    def run(
        self,
        tasks: Sequence[Task[R]],
        *,
        on_done: OnDone | None = None,
        on_event: OnEvent | None = None,
        until: Until | None = None,
    ) -> list[R]:
        """Execute the tasks on the wrapped engine (see :meth:`Engine.run`), counting them."""

        def done(k: int, pair: tuple[Any, int]) -> None:
            counted(pair[1])
            if on_done is not None:
                on_done(k, pair[0])

        stop = None if until is None else lambda k, pair: until(k, pair[0])
        pairs = self._engine.run(
            [Counted(t) for t in tasks], on_done=done, on_event=on_event, until=stop
        )
        return [result for result, _ in pairs]
