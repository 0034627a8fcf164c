"""What the engines run (a task with ``execute(report)``) and what they share."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Generic, Protocol, TypeVar

R = TypeVar("R")
R_co = TypeVar("R_co", covariant=True)

Report = Callable[[Any], None]
"""Called by a running task with each of its progress events (picklable values)."""

OnDone = Callable[[int, Any], None]
"""Called in the owner with ``(index in tasks, result)`` as each task finishes."""

OnEvent = Callable[[int, Any], None]
"""Called in the owner with ``(index in tasks, event)`` for each event a task reports."""

Until = Callable[[int, Any], bool]
"""Asked in the owner with ``(index in tasks, result)``, in the order of the tasks: True stops
the run there (see :meth:`Engine.run`)."""


class Task(Protocol[R_co]):
    """A unit of work: picklable, and the same result in whichever process runs it."""

    def execute(self, report: Report) -> R_co:
        """Do the work, calling ``report`` with progress events; return the result."""
        ...


@dataclass(frozen=True)
class Call(Generic[R]):
    """A plain call ``fn(*args)`` as a task that reports nothing."""

    fn: Callable[..., R]
    args: tuple[Any, ...]

    def execute(self, report: Report) -> R:
        """Return ``fn(*args)``."""
        return self.fn(*self.args)

    @property
    def label(self) -> str:
        """The function's name (names the task on a dask dashboard)."""
        return str(getattr(self.fn, "__qualname__", "call"))


def first_stop(
    results: Mapping[int, Any], start: int, until: Until | None
) -> tuple[int, int | None]:
    """Ask ``until`` of the done results from index ``start`` on, in order, up to a gap.

    Returns the next index to ask and the index whose result stopped the run (None: none yet).
    """
    k = start
    while until is not None and k in results:
        if until(k, results[k]):
            return k, k
        k += 1
    return k, None


def label(task: Task[Any]) -> str:
    """Return a task's name for logs and dask keys: its ``label``, else its class name."""
    return str(getattr(task, "label", type(task).__name__))


class Engine(ABC):
    """Runs tasks and returns their results in the order given."""

    @property
    def parallel(self) -> bool:
        """Whether the tasks run side by side, not one after the other in this process."""
        return True

    @abstractmethod
    def run(
        self,
        tasks: Sequence[Task[R]],
        *,
        on_done: OnDone | None = None,
        on_event: OnEvent | None = None,
        until: Until | None = None,
    ) -> list[R]:
        """Execute every task and return the results in the order of ``tasks``.

        Parameters
        ----------
        tasks
            The tasks; they do not depend on one another.
        on_done
            Called in this process with ``(index, result)`` for each finished task. If it
            raises, the tasks not started are cancelled and the error propagates.
        on_event
            Called in this process with ``(index, event)`` for each event the task reports,
            in order and before its ``on_done``: as it happens in this process or a local
            worker, when the task is back on dask.
        until
            Asked with ``(index, result)`` of each task once every earlier task is done, in
            the order of ``tasks``; at the first True the run stops: the tasks after it are
            cancelled (those running finish unseen, or are ended with the engine). Which task
            stops the run depends only on the results, not on the engine or its timing.

        Returns
        -------
        list
            The results, in the order of ``tasks``; with ``until``, those up to the task that
            stopped the run.

        """

    def map(self, fn: Callable[..., R], *iterables: Sequence[Any]) -> list[R]:
        """Return ``[fn(*args) for args in zip(*iterables)]``, the calls run as tasks."""
        return self.run([Call(fn, args) for args in zip(*iterables, strict=True)])
