"""Run profile branches side by side: local worker processes or a dask.distributed cluster."""

from __future__ import annotations

import logging
import multiprocessing
import os
import pickle
import queue
import tempfile
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, wait
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from fmuid.errors import FmuError
from fmuid.estimation.problem import Problem
from fmuid.model.fmu import FmuFile, FmuModel, load_model
from fmuid.model.registry import get_simulator, mark_reset_unreliable
from fmuid.profiling.branch import BranchResult, settle_branch
from fmuid.profiling.pool_guard import die_with_pool_owner
from fmuid.profiling.walk import WalkOptions
from fmuid.profiling.worker_pool import local_pool

log = logging.getLogger(__name__)

_PROGRESS_QUEUE: Any = None


@dataclass(frozen=True)
class BranchTask:
    """Everything a worker needs to walk one branch."""

    problem: Problem
    z_hat: np.ndarray
    chi2_hat: float
    index: int
    direction: int
    threshold: float
    sd_z: float
    options: WalkOptions
    pointwise: float | None = None
    valleys: tuple[np.ndarray, ...] = ()
    thorough: bool = False
    seed: int = 0

    def walk(self, on_point: Callable[[int], None]) -> BranchResult:
        """Walk and settle the branch, calling ``on_point`` with the walk points done."""
        thresholds = {"simultaneous": self.threshold}
        if self.pointwise is not None:
            thresholds["pointwise"] = self.pointwise
        return settle_branch(
            self.problem,
            self.z_hat,
            self.chi2_hat,
            self.index,
            self.direction,
            thresholds,
            self.sd_z,
            self.options,
            valleys=self.valleys,
            thorough=self.thorough,
            seed=self.seed,
            on_point=on_point,
        )


def run_branch(task: BranchTask) -> BranchResult:
    """Walk one branch, reporting points to the parent process when it listens."""

    def on_point(n: int) -> None:
        if _PROGRESS_QUEUE is not None:
            _PROGRESS_QUEUE.put((task.index, task.direction, n))

    return task.walk(on_point)


def _init_worker(progress_queue: Any, owner: int, fmu: FmuFile, unreliable: bool) -> None:
    """Set up a pool worker: die with the parent, parse the FMU once, know the reset verdict.

    The worker parses the FMU here, from the file and checksum the parent hands it; the tasks'
    pickled problems then find this model (:func:`fmuid.model.fmu.load_model`). Forkserver
    workers do not inherit the owner's verdict on the FMU's reset: it is passed.
    """
    global _PROGRESS_QUEUE
    die_with_pool_owner(owner)
    model = load_model(fmu)
    if unreliable:
        mark_reset_unreliable(model)
    _PROGRESS_QUEUE = progress_queue


PointCallback = Callable[[int, int, int], None]


def run_branches(
    tasks: Sequence[BranchTask],
    *,
    workers: int | None = None,
    executor: Any = None,
    on_point: PointCallback | None = None,
) -> list[BranchResult]:
    """Walk every branch and return their results in the order of ``tasks``.

    Parameters
    ----------
    tasks
        The branches.
    workers
        Local worker processes (default: the CPU count, at most one per branch); 1 walks the
        branches in this process.
    executor
        A ``dask.distributed.Client``: branches run as dask tasks on its workers, each worker
        keeping its FMU instance warm between tasks. Overrides ``workers``.
    on_point
        Called with ``(parameter index, direction, points done in that branch)``.

    """
    if executor is not None:
        return _run_dask(tasks, executor, on_point)
    n = min(workers or os.cpu_count() or 1, len(tasks))
    if n <= 1:
        out = []
        for task in tasks:

            def report(k: int, task: BranchTask = task) -> None:
                if on_point:
                    on_point(task.index, task.direction, k)

            out.append(task.walk(report))
        return out
    model = tasks[0].problem.model
    unreliable = get_simulator(model).reset_reliable is False
    progress_queue = multiprocessing.get_context("forkserver").Queue()
    initargs = (progress_queue, os.getpid(), model.file, unreliable)
    with local_pool(n, _init_worker, initargs, preload=[__name__]) as pool:
        futures: list[Future[BranchResult]] = [pool.submit(run_branch, t) for t in tasks]
        pending = set(futures)
        try:
            while pending:
                _, pending = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
                _drain(progress_queue, on_point)
        except KeyboardInterrupt:
            log.warning(
                "profile interrupted: %d of %d branches had finished; nothing is kept",
                len(futures) - len(pending),
                len(futures),
            )
            raise
        _drain(progress_queue, on_point)
        return [f.result() for f in futures]


def _drain(progress_queue: Any, on_point: PointCallback | None) -> None:
    while True:
        try:
            item = progress_queue.get_nowait()
        except queue.Empty:
            return
        if on_point:
            on_point(*item)


def _run_dask(
    tasks: Sequence[BranchTask], client: Any, on_point: PointCallback | None
) -> list[BranchResult]:
    from distributed import as_completed

    model = tasks[0].problem.model
    # the FMU's bytes travel with each task, not scattered: a task whose worker dies is run
    # again elsewhere, while scattered data lost with its worker cancels the tasks that need it;
    # the task travels pickled, to be read once the FMU is in place on the worker
    fmu_blob = model.path.read_bytes()
    unreliable = get_simulator(model).reset_reliable is False
    futures = [
        client.submit(
            run_branch_anywhere,
            PickledTask(model.file, pickle.dumps(t)),
            model.sha256,
            fmu_blob,
            unreliable,
            pure=False,
        )
        for t in tasks
    ]
    index = {f.key: k for k, f in enumerate(futures)}
    results: list[BranchResult | None] = [None] * len(tasks)
    for future in as_completed(futures):
        k = index[future.key]
        result = future.result()
        results[k] = result
        if on_point:
            on_point(tasks[k].index, tasks[k].direction, len(result.points))
    return [r for r in results if r is not None]


@dataclass(frozen=True)
class PickledTask:
    """A pickled task and the FMU its problem needs, loaded before the task is unpickled."""

    fmu: FmuFile
    task: bytes

    def load(self, fmu_bytes: bytes) -> tuple[FmuModel, Any]:
        """Parse the FMU once on this worker (from ``fmu_bytes`` if needed); then the task."""
        return load_here(self.fmu, fmu_bytes), pickle.loads(self.task)


def run_branch_anywhere(
    task: BranchTask | PickledTask, sha256: str, fmu_bytes: bytes, reset_unreliable: bool = False
) -> BranchResult:
    """Walk a branch on a worker that may not see the FMU file: use a local copy if needed.

    ``task`` is a task, or one pickled (as dask sends it: its problem's model is found once the
    FMU is in place). ``reset_unreliable`` carries the submitting process's verdict on the
    FMU's reset (its workers do not inherit it, as forked local workers do).
    """
    branch: BranchTask = task.load(fmu_bytes)[1] if isinstance(task, PickledTask) else task
    model = branch.problem.model
    if model.sha256 != sha256:
        raise FmuError(f"{model.path}: sha256 {model.sha256[:12]}..., expected {sha256[:12]}...")
    if reset_unreliable:
        mark_reset_unreliable(model)
    return run_branch(branch)


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
