"""What the engines run (a task with ``execute(report)``) and what they share."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
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


def label(task: Task[Any]) -> str:
    """Return a task's name for logs and dask keys: its ``label``, else its class name."""
    return str(getattr(task, "label", type(task).__name__))


class Engine(ABC):
    """Runs tasks and returns their results in the order given."""

    @abstractmethod
    def run(
        self,
        tasks: Sequence[Task[R]],
        *,
        on_done: OnDone | None = None,
        on_event: OnEvent | None = None,
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

        Returns
        -------
        list
            The results, in the order of ``tasks``.

        """

    def map(self, fn: Callable[..., R], *iterables: Sequence[Any]) -> list[R]:
        """Return ``[fn(*args) for args in zip(*iterables)]``, the calls run as tasks."""
        return self.run([Call(fn, args) for args in zip(*iterables, strict=True)])
