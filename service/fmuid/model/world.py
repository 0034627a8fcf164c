"""The FMU world of a process: the parsed models, the simulators per thread, the parse count.

One :class:`FmuRegistry` per process holds what used to be module globals: the models parsed
here (by checksum and by file), the simulator of each model and thread, the models whose reset
was found unreliable, and how many FMU files were parsed. The process's entry points (the CLI,
the service, a job process, a pool worker) own it: they open it (:func:`open_registry`) and
close it on the way out, which closes its simulators (unloading their libraries and deleting
their extracted files). A forked child starts with a registry of its own: the parent's models
and reset verdicts, no simulators (those belong to the parent), no parses counted yet.

This module knows the models and simulators only as values; :mod:`fmuid.model.fmu` parses,
:mod:`fmuid.model.registry` makes the simulators.
"""

from __future__ import annotations

import atexit
import logging
import multiprocessing.util
import os
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Protocol, TypeVar, cast

if TYPE_CHECKING:
    from fmuid.model.fmu import FmuModel

log = logging.getLogger(__name__)

FILE_MODELS = 16
"""Models kept by checksum and by file (each; the oldest is dropped first)."""

ModelKey = tuple[str, str, str]
"""What identifies a model's simulators: checksum, resolved file, interface."""
FileKey = tuple[str, int, int, str | None]
"""A file as last seen: resolved path, modification time [ns], size, interface asked for."""


class Closable(Protocol):
    """A simulator as the registry sees it."""

    def close(self) -> None:
        """Free the FMU instance and its files."""


S = TypeVar("S", bound=Closable)


class FmuRegistry:
    """The FMU world of one process.

    Attributes
    ----------
    parses
        FMU files read, hashed and parsed in this process (counted by
        :class:`~fmuid.model.fmu.FmuModel`); a forked child starts at 0.

    """

    def __init__(self) -> None:
        self.parses = 0
        self._lock = threading.RLock()
        self._by_checksum: dict[tuple[str, str], FmuModel] = {}
        self._by_file: dict[FileKey, FmuModel] = {}
        self._simulators: dict[tuple[ModelKey, int], Closable] = {}
        self._unreliable: set[ModelKey] = set()

    def count_parse(self) -> None:
        """Count one FMU file parsed in this process."""
        with self._lock:
            self.parses += 1

    def model(self, key: tuple[str, str], parse: Callable[[], FmuModel]) -> FmuModel:
        """Return the model of checksum and interface ``key``, parsing it on first request.

        A model whose file is gone (deleted or moved since it was parsed) is parsed again by
        ``parse``: its simulators could not be made from it.
        """
        with self._lock:
            model = _existing(self._by_checksum.get(key))
            if model is None:
                model = parse()
                _keep(self._by_checksum, key, model)
            return model

    def file_model(self, key: FileKey, parse: Callable[[], FmuModel]) -> FmuModel:
        """Return the model of a file as last seen (``key``), parsing it when it changed.

        A model parsed here is also found by its checksum (:meth:`model`), unless a model of
        the same checksum whose file still exists was parsed before.
        """
        with self._lock:
            model = self._by_file.get(key)
            if model is None:
                model = parse()
                _keep(self._by_file, key, model)
                if _existing(self._by_checksum.get((model.sha256, model.interface))) is None:
                    _keep(self._by_checksum, (model.sha256, model.interface), model)
            return model

    def mark_reset_unreliable(self, key: ModelKey) -> None:
        """Record that the reset of the model ``key`` is unreliable."""
        with self._lock:
            self._unreliable.add(key)

    def reset_unreliable(self, key: ModelKey) -> bool:
        """Whether the reset of the model ``key`` was found unreliable here (or in the parent)."""
        return key in self._unreliable

    def simulator(self, key: ModelKey, make: Callable[[], S], keep: Callable[[S], bool]) -> S:
        """Return this thread's simulator of the model ``key``, made by ``make`` on first use.

        A simulator that ``keep`` rejects is closed and made again; so are this thread's
        simulators of an earlier file at the same path (a rebuilt FMU). Simulators are made one
        at a time in the process (under the registry's lock).
        """
        thread = threading.get_ident()
        with self._lock:
            simulator = cast(S | None, self._simulators.get((key, thread)))
            if simulator is not None and not keep(simulator):
                self._simulators.pop((key, thread)).close()
                simulator = None
            if simulator is None:
                stale = [k for k in self._simulators if k[0][1:] == key[1:] and k[1] == thread]
                for old in stale:
                    self._simulators.pop(old).close()
                simulator = make()
                self._simulators[(key, thread)] = simulator
            return simulator

    def forked(self) -> FmuRegistry:
        """Return the registry of a forked child: the models and verdicts, no simulators."""
        child = FmuRegistry()
        child._by_checksum = dict(self._by_checksum)
        child._by_file = dict(self._by_file)
        child._unreliable = set(self._unreliable)
        return child

    def close(self) -> None:
        """Close every simulator (unload its library, delete its files) and forget the models."""
        with self._lock:
            simulators = list(self._simulators.values())
            self._simulators.clear()
            self._by_checksum.clear()
            self._by_file.clear()
        for simulator in simulators:
            try:
                simulator.close()
            except Exception as exc:  # noqa: BLE001 - one bad FMU must not keep the rest open
                log.warning("closing a simulator failed: %s", exc)


K = TypeVar("K")


def _existing(model: FmuModel | None) -> FmuModel | None:
    """Return ``model`` if its file still exists, else None."""
    return model if model is not None and os.path.exists(model.path) else None


def _keep(table: dict[K, FmuModel], key: K, model: FmuModel) -> None:
    """Add ``model`` to ``table``, dropping the oldest entry past :data:`FILE_MODELS`."""
    table.pop(key, None)
    if len(table) >= FILE_MODELS:
        table.pop(next(iter(table)))
    table[key] = model


_current = FmuRegistry()


def registry() -> FmuRegistry:
    """Return this process's registry."""
    return _current


@contextmanager
def open_registry() -> Iterator[FmuRegistry]:
    """Give this process a fresh registry for the block; close it when the block ends.

    The entry points of a process (the CLI, the service, a job process) run in this block. The
    registry that was current before comes back after it (if no block opened since is still open).
    """
    global _current
    previous = _current
    mine = _current = FmuRegistry()
    try:
        yield mine
    finally:
        mine.close()
        if _current is mine:
            _current = previous


def close_at_exit() -> None:
    """Close this process's registry when the process ends.

    For a process that no :func:`open_registry` block spans, e.g. a pool worker: at
    interpreter exit, or at the end of a multiprocessing worker (which skips ``atexit``).
    """
    atexit.register(_close_current)
    multiprocessing.util.Finalize(None, _close_current, exitpriority=0)


def _close_current() -> None:
    _current.close()


def _after_fork_in_child() -> None:
    global _current
    _current = _current.forked()


os.register_at_fork(after_in_child=_after_fork_in_child)
