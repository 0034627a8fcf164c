"""The dask engine: tasks of a ``dask.distributed.Client``, each carrying the FMU's bytes.

The FMU's bytes travel with each task, not scattered: a task whose worker dies is run again
elsewhere, while scattered data lost with its worker cancels the tasks that need it. The task
travels pickled, to be read once the FMU is in place on the worker (its problem's model is
found by :func:`fmuid.model.fmu.load_model`); a worker keeps its FMU instance warm between
tasks. A task's progress events come back with its result.
"""

from __future__ import annotations

import os
import pickle
import tempfile
import uuid
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, TypeVar

from fmuid.engine.task import Engine, OnDone, OnEvent, Task, Until, first_stop, label
from fmuid.errors import FmuError
from fmuid.model.fmu import FmuFile, FmuModel, load_model
from fmuid.model.registry import get_simulator, mark_reset_unreliable

R = TypeVar("R")


@dataclass(frozen=True)
class PickledTask:
    """A pickled task and the FMU its problem needs, loaded before the task is unpickled."""

    fmu: FmuFile
    task: bytes

    def load(self, fmu_bytes: bytes) -> tuple[FmuModel, Any]:
        """Parse the FMU once on this worker (from ``fmu_bytes`` if needed); then the task."""
        return load_here(self.fmu, fmu_bytes), pickle.loads(self.task)


def execute_anywhere(
    sent: PickledTask, sha256: str, fmu_bytes: bytes, reset_unreliable: bool = False
) -> tuple[Any, list[Any]]:
    """Execute a pickled task on a worker that may not see the FMU file; return its events too.

    ``reset_unreliable`` carries the submitting process's verdict on the FMU's reset.

    Returns
    -------
    tuple
        The task's result and the events it reported, in order.

    Raises
    ------
    FmuError
        If the FMU found for the task is not the one whose checksum is ``sha256``.

    """
    model, task = sent.load(fmu_bytes)
    if model.sha256 != sha256:
        raise FmuError(f"{model.path}: sha256 {model.sha256[:12]}..., expected {sha256[:12]}...")
    if reset_unreliable:
        mark_reset_unreliable(model)
    events: list[Any] = []
    return task.execute(events.append), events


def load_here(fmu: FmuFile, fmu_bytes: bytes) -> FmuModel:
    """Return this worker's model of ``fmu``: from its file, or from a local copy of the bytes.

    The FMU is parsed (and hashed) once per process: a worker that does not see the file, or
    sees another file at its path, writes ``fmu_bytes`` to a local copy and parses that.
    """
    try:
        return load_model(fmu)
    except FmuError:  # not on this machine, or another file at that path
        local = Path(tempfile.gettempdir()) / "fmuid-fmus" / fmu.sha256 / Path(fmu.path).name
    copy = replace(fmu, path=str(local))
    try:
        return load_model(copy)
    except FmuError:  # no copy yet, or a stale one
        local.parent.mkdir(parents=True, exist_ok=True)
        tmp = local.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_bytes(fmu_bytes)
        tmp.replace(local)
    return load_model(copy)


class DaskEngine(Engine):
    """Run the tasks on the workers of a ``dask.distributed.Client``."""

    def __init__(self, client: Any, model: FmuModel) -> None:
        self._client = client
        self._model = model
        self._blob = model.data

    def run(
        self,
        tasks: Sequence[Task[R]],
        *,
        on_done: OnDone | None = None,
        on_event: OnEvent | None = None,
        until: Until | None = None,
    ) -> list[R]:
        """Execute the tasks on dask (see :meth:`Engine.run`); cancel the rest on an error."""
        from distributed import as_completed

        model = self._model
        unreliable = get_simulator(model).reset_reliable is False  # the verdict of this run
        futures = [
            self._client.submit(
                execute_anywhere,
                PickledTask(model.file, pickle.dumps(task)),
                model.sha256,
                self._blob,
                unreliable,
                key=f"{label(task)}-{uuid.uuid4().hex}",
            )
            for task in tasks
        ]
        index = {f.key: k for k, f in enumerate(futures)}
        results: dict[int, R] = {}
        asked, stop = 0, None
        try:
            for future in as_completed(futures):
                k = index[future.key]
                results[k], events = future.result()
                if on_event is not None:
                    for event in events:
                        on_event(k, event)
                if on_done is not None:
                    on_done(k, results[k])
                asked, stop = first_stop(results, asked, until)
                if stop is not None:
                    break
        finally:
            self._client.cancel([f for f in futures if not f.done()])
        return [results[k] for k in range(len(tasks) if stop is None else stop + 1)]
