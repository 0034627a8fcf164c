"""Finished design evaluations on disk, so that a study interrupted by a restart resumes.

Each finished evaluation is one ``.npz`` file (arrays only, read without pickle), written to a
temporary name and renamed, so that a killed process leaves either the whole file or none. The
files live in a folder named by a hash of the FMU, the spec, the space and the number of
verified designs: a changed input starts an empty folder and never reuses stale work.
"""

from __future__ import annotations

import hashlib
import io
import logging
import os
import zipfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Generic, TypeVar

import numpy as np

from fmuid.data import Spec
from fmuid.engine.run import open_engine
from fmuid.engine.task import Call
from fmuid.experiment_design.space import Space
from fmuid.model.fmu import FmuModel

log = logging.getLogger(__name__)

FORMAT = "fmuid-design-checkpoint-1"
"""Part of the hash: a change of what an evaluation stores changes it."""

T = TypeVar("T")
R = TypeVar("R")
Arrays = dict[str, np.ndarray]


class Checkpoint:
    """The finished evaluations of one study (``directory/<hash of the inputs>/<name>.npz``).

    Parameters
    ----------
    directory
        Where the study keeps its checkpoints (e.g. the job's folder).
    key
        Hash of the study's inputs (:meth:`for_study`).

    """

    def __init__(self, directory: Path, key: str) -> None:
        self.folder = Path(directory) / key

    @classmethod
    def for_study(
        cls, directory: Path, model: FmuModel, spec: Spec, space: Space, verify_designs: int
    ) -> Checkpoint:
        """Return the checkpoint of a study, keyed by everything its evaluations depend on."""
        digest = hashlib.sha256()
        for part in (
            FORMAT,
            model.sha256,
            spec.model_dump_json(),
            space.model_dump_json(),
            str(verify_designs),
        ):
            digest.update(part.encode())
            digest.update(b"\0")
        return cls(directory, digest.hexdigest()[:32])

    def load(self, name: str) -> Arrays | None:
        """Return the arrays of a finished evaluation, or ``None`` if it is not (readably) there."""
        path = self.folder / f"{name}.npz"
        try:
            with np.load(path, allow_pickle=False) as data:
                return {k: data[k] for k in data.files}
        except FileNotFoundError:
            return None
        except (OSError, ValueError, zipfile.BadZipFile) as exc:
            log.warning("checkpoint %s unreadable, evaluated again: %s", path, exc)
            return None

    def save(self, name: str, arrays: Arrays) -> None:
        """Write a finished evaluation atomically."""
        self.folder.mkdir(parents=True, exist_ok=True)
        buffer = io.BytesIO()
        np.savez(buffer, **arrays)  # type: ignore[arg-type]  # (stubs: the allow_pickle kw)
        tmp = self.folder / f".{name}.{os.getpid()}.tmp"
        tmp.write_bytes(buffer.getvalue())
        tmp.replace(self.folder / f"{name}.npz")


@dataclass(frozen=True)
class Codec(Generic[R]):
    """How an evaluation's result is stored: to arrays and back, exactly."""

    encode: Callable[[R], Arrays]
    decode: Callable[[Arrays], R]


def evaluate_resumably(
    evaluate: Callable[[T], R],
    tasks: Sequence[T],
    names: Sequence[str],
    codec: Codec[R],
    checkpoint: Checkpoint | None,
    model: FmuModel,
    interface: str,
    *,
    workers: int | None = 1,
    executor: Any = None,
    on_done: Callable[[int, int], None] | None = None,
) -> list[R]:
    """Evaluate the tasks not in the checkpoint, saving each as it finishes; return all results.

    ``names`` name each task's file; ``on_done(done, total)`` follows every finished (or
    reloaded) evaluation, after it was saved. ``evaluate`` is a picklable function of one task
    (a module-level function or a bound method of a picklable object) that gives the same
    numbers in any process; ``workers`` local processes (``None``: the CPU count) or the dask
    ``executor`` run the evaluations (:func:`fmuid.engine.run.open_engine`).
    """
    results: list[R | None] = [None] * len(tasks)
    todo = []
    for k, name in enumerate(names):
        stored = checkpoint.load(name) if checkpoint is not None else None
        if stored is None:
            todo.append(k)
        else:
            results[k] = codec.decode(stored)
    done = len(tasks) - len(todo)
    if todo:
        log.info("%d of %d evaluations taken from the checkpoint", done, len(tasks))
    if on_done is not None and done:
        on_done(done, len(tasks))

    def finished(j: int, result: R) -> None:
        nonlocal done
        k = todo[j]
        results[k] = result
        if checkpoint is not None:
            checkpoint.save(names[k], codec.encode(result))
        done += 1
        if on_done is not None:
            on_done(done, len(tasks))

    with open_engine(
        model.with_interface(interface),
        workers=workers,
        executor=executor,
        at_most=len(todo),
        preload=[evaluate.__module__],
    ) as engine:
        engine.run([Call(evaluate, (tasks[k],)) for k in todo], on_done=finished)
    return [r for r in results if r is not None]
