"""Every branch of a profile walked on an engine (local workers, this process or dask)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from fmuid.engine.task import Engine
from fmuid.estimation.problem import Problem
from fmuid.estimation.result import FitResult
from fmuid.profiling.branch import BranchResult, BranchTask
from fmuid.profiling.walk import WalkOptions
from fmuid.progress import Progress, ProgressCallback


def walk_all(
    problem: Problem,
    fit: FitResult,
    names: Sequence[str],
    thr: dict[str, float],
    engine: Engine,
    progress: ProgressCallback | None,
    options: WalkOptions,
    valleys: Sequence[np.ndarray],
    restart: bool,
    again: dict[tuple[int, int], np.ndarray] | None = None,
) -> list[BranchResult]:
    """Walk every branch of ``names`` on ``engine``; return the branches in the order of the tasks.

    With ``restart`` (a lower point will restart the profiles) the walks stop at the first
    branch, in that order, that found one: the branches before it and that one are returned.
    ``again`` (``(index, direction)`` -> a point): walk only those branches, each with its
    point as one more valley (:func:`fmuid.profiling.cross.cross_check`).
    """
    z_hat = fit.z_estimate()
    sd = fit.fisher_sd_z()
    seed = problem.spec.seed
    index = {n: problem.names.index(n) for n in names}
    tasks = [
        BranchTask(
            problem,
            z_hat,
            fit.chi2,
            index[n],
            d,
            thr["simultaneous"],
            sd[n],
            options,
            pointwise=thr["pointwise"],
            valleys=tuple(valleys) + (() if again is None else (again[(index[n], d)],)),
            seed=seed,
            jacobian=fit.jacobian,
        )
        for n in names
        for d in (-1, 1)
        if again is None or (index[n], d) in again
    ]
    expected = int(np.ceil(np.sqrt((1.0 + options.margin) / options.rise_per_step))) + 1
    done: dict[tuple[int, int], int] = {}

    def on_point(k: int, n: int) -> None:
        done[(tasks[k].index, tasks[k].direction)] = n
        if progress:
            per_branch = {
                (t.index, t.direction): max(done.get((t.index, t.direction), 0), expected)
                for t in tasks
            }
            total = sum(per_branch.values())
            parts = []
            for name in names:
                i = index[name]
                got = done.get((i, -1), 0) + done.get((i, 1), 0)
                planned = per_branch.get((i, -1), 0) + per_branch.get((i, 1), 0)
                if planned:
                    parts.append(f"{name} {got}/{planned}")
            progress(Progress("profile", sum(done.values()), total, ", ".join(parts)))

    return engine.run(tasks, on_event=on_point, until=_found_lower if restart else None)


def _found_lower(k: int, branch: BranchResult) -> bool:
    """Whether a branch found a point below the optimum (which restarts the profiles)."""
    return branch.better is not None
