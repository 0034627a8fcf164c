"""Run profile branches side by side: local worker processes or a dask.distributed cluster."""

from __future__ import annotations

import functools
import hashlib
import multiprocessing
import os
import queue
import tempfile
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fmuid.estimation.problem import Problem
from fmuid.model.simulator import get_simulator, mark_reset_unreliable, register_fmu_copy
from fmuid.profiling.branch import BranchResult, settle_branch
from fmuid.profiling.pool_guard import POOL_PARENT_ENV, die_with_pool_owner
from fmuid.profiling.walk import WalkOptions

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


def _init_worker(progress_queue: Any, owner: int, problem: Problem, unreliable: bool) -> None:
    """Set up a pool worker: die with the parent, report points, know the reset verdict.

    Forkserver workers do not inherit the owner's verdict on the FMU's reset: it is passed.
    """
    global _PROGRESS_QUEUE
    die_with_pool_owner(owner)
    if unreliable:
        mark_reset_unreliable(problem.fmu_path, problem.spec.interface)
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
    # forkserver, not fork: this process may have threads (BLAS, a job's watchdog); the server
    # dies with this process, and its workers with it (see fmuid.profiling.pool_guard)
    problem = tasks[0].problem
    unreliable = get_simulator(problem.fmu_path, problem.spec.interface).reset_reliable is False
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(["fmuid.profiling.forkserver_guard", __name__])
    os.environ[POOL_PARENT_ENV] = str(os.getpid())
    progress_queue = ctx.Queue()
    with ProcessPoolExecutor(
        n,
        mp_context=ctx,
        initializer=_init_worker,
        initargs=(progress_queue, os.getpid(), problem, unreliable),
    ) as pool:
        futures: list[Future[BranchResult]] = [pool.submit(run_branch, t) for t in tasks]
        pending = set(futures)
        while pending:
            _, pending = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
            _drain(progress_queue, on_point)
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

    problem = tasks[0].problem
    # the FMU's bytes travel with each task, not scattered: a task whose worker dies is run
    # again elsewhere, while scattered data lost with its worker cancels the tasks that need it
    fmu_blob = Path(problem.fmu_path).read_bytes()
    unreliable = get_simulator(problem.fmu_path, problem.spec.interface).reset_reliable is False
    futures = [
        client.submit(
            run_branch_anywhere, t, problem.model.sha256, fmu_blob, unreliable, pure=False
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


def run_branch_anywhere(
    task: BranchTask, sha256: str, fmu_bytes: bytes, reset_unreliable: bool = False
) -> BranchResult:
    """Walk a branch on a worker that may not see the FMU file: use a local copy if needed.

    ``reset_unreliable`` carries the submitting process's verdict on the FMU's reset (its
    workers do not inherit it, as forked local workers do).
    """
    use_fmu_here(task.problem.fmu_path, sha256, fmu_bytes)
    if reset_unreliable:
        mark_reset_unreliable(task.problem.fmu_path, task.problem.spec.interface)
    return run_branch(task)


def use_fmu_here(fmu_path: str | Path, sha256: str, fmu_bytes: bytes) -> None:
    """Make ``fmu_path`` open the FMU of ``sha256`` on this worker: a local copy if it differs."""
    path = Path(fmu_path)
    if _file_sha256(path) != sha256:
        local = Path(tempfile.gettempdir()) / "fmuid-fmus" / sha256 / path.name
        if _file_sha256(local) != sha256:
            local.parent.mkdir(parents=True, exist_ok=True)
            tmp = local.with_suffix(f".{os.getpid()}.tmp")
            tmp.write_bytes(fmu_bytes)
            tmp.replace(local)
        register_fmu_copy(path, local)


@functools.lru_cache(maxsize=64)
def _sha256_cached(path: str, mtime_ns: int, size: int) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _file_sha256(path: Path) -> str | None:
    try:
        st = path.stat()
    except OSError:
        return None
    return _sha256_cached(str(path), st.st_mtime_ns, st.st_size)
