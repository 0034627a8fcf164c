"""Profile likelihood of every free parameter: walks, intervals, labels, structural check."""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy.stats import chi2 as chi2_dist

from fmuid.fit.optimize import jacobian, make_fit_result, refine
from fmuid.fit.problem import Problem
from fmuid.fit.result import Cost, FitResult
from fmuid.profile.intervals import ci_end, label
from fmuid.profile.parallel import BranchTask, run_branches
from fmuid.profile.result import ParameterProfile, ProfilePoint, ProfileResult
from fmuid.profile.structural import structural_check
from fmuid.profile.walk import BranchResult, WalkOptions
from fmuid.progress import Progress, ProgressCallback

log = logging.getLogger(__name__)

#: How often a better optimum found on a profile may restart the profiles.
MAX_RESTARTS = 3


def thresholds(confidence: float, n_free: int) -> dict[str, float]:
    """Chi-square quantiles at ``confidence``: df = 1 (pointwise) and df = n_free (simultaneous)."""
    return {
        "pointwise": float(chi2_dist.ppf(confidence, 1)),
        "simultaneous": float(chi2_dist.ppf(confidence, n_free)),
    }


def profile_problem(
    problem: Problem,
    fit: FitResult,
    *,
    only: Sequence[str] | None = None,
    workers: int | None = None,
    executor: Any = None,
    progress: ProgressCallback | None = None,
    options: WalkOptions = WalkOptions(),
) -> ProfileResult:
    """Profile likelihoods of the free parameters around a fit.

    Every parameter is walked in both directions (branches run in parallel), its pointwise and
    simultaneous confidence intervals are read where the profile crosses the thresholds, and it
    is labelled. If a profile finds a lower chi2 than the optimum, the fit is refined from there
    and the profiles are redone (``better_optimum_found``).

    Parameters
    ----------
    problem
        The estimation problem.
    fit
        The best fit of ``problem``.
    only
        Profile only these parameters (default: all free parameters).
    workers
        Local worker processes; 1 runs in this process.
    executor
        A ``dask.distributed.Client`` to run branches on instead of local processes.
    progress
        Receives ``Progress("profile", done, total, detail)`` after every point.
    options
        Walk settings.

    Returns
    -------
    ProfileResult

    """
    t0 = time.perf_counter()
    sims = fit.cost.simulations
    conf = problem.spec.confidence
    thr = thresholds(conf, problem.n_free)
    names = list(only) if only is not None else list(problem.names)
    better_found = False
    for _ in range(MAX_RESTARTS + 1):
        branches, branch_sims = _walk_all(
            problem, fit, names, thr, workers, executor, progress, options
        )
        sims += branch_sims
        better = [b.better for b in branches if b.better is not None]
        if not better:
            break
        better_found = True
        best = min(better, key=lambda p: p.chi2)
        log.info("profile found chi2 %.6g below the optimum %.6g; refitting", best.chi2, fit.chi2)
        sims0, t_refit = problem.simulations, time.perf_counter()
        z, chi2, message = refine(problem, best.z)
        jac = jacobian(problem, z)
        fit = make_fit_result(problem, z, chi2, jac, message, fit.global_search, t_refit, sims0)
        sims += fit.cost.simulations
    z_hat = fit.z_estimate()
    sd = fit.fisher_sd_z()
    profiles = {}
    for name in names:
        i = problem.names.index(name)
        sides = [b for b in branches if b.index == i]
        profiles[name] = _assemble(problem, fit, i, z_hat, sides, thr, sd[name])
    check = structural_check(
        fit.jacobian, problem.names, problem.scales, [fit.estimates[n] for n in problem.names]
    )
    return ProfileResult(
        fit=fit,
        confidence=conf,
        thresholds=thr,
        parameters=profiles,
        better_optimum_found=better_found,
        structural_check=check,
        cost=Cost(sims, time.perf_counter() - t0 + fit.cost.seconds),
    )


def _walk_all(
    problem: Problem,
    fit: FitResult,
    names: Sequence[str],
    thr: dict[str, float],
    workers: int | None,
    executor: Any,
    progress: ProgressCallback | None,
    options: WalkOptions,
) -> tuple[list[BranchResult], int]:
    z_hat = fit.z_estimate()
    sd = fit.fisher_sd_z()
    tasks = [
        BranchTask(
            problem, z_hat, fit.chi2, problem.names.index(n), d, thr["simultaneous"], sd[n], options
        )
        for n in names
        for d in (-1, 1)
    ]
    expected = int(np.ceil((1.0 + options.margin) / options.rise_per_step)) + 1
    done: dict[tuple[int, int], int] = {}

    def on_point(index: int, direction: int, n: int) -> None:
        done[(index, direction)] = n
        if progress:
            per_branch = {
                (t.index, t.direction): max(done.get((t.index, t.direction), 0), expected)
                for t in tasks
            }
            total = sum(per_branch.values())
            parts = []
            for name in names:
                i = problem.names.index(name)
                got = done.get((i, -1), 0) + done.get((i, 1), 0)
                parts.append(f"{name} {got}/{per_branch[(i, -1)] + per_branch[(i, 1)]}")
            progress(Progress("profile", sum(done.values()), total, ", ".join(parts)))

    results = run_branches(tasks, workers=workers, executor=executor, on_point=on_point)
    return results, sum(r.simulations for r in results)


def _assemble(
    problem: Problem,
    fit: FitResult,
    index: int,
    z_hat: np.ndarray,
    sides: list[BranchResult],
    thr: dict[str, float],
    sd_z: float,
) -> ParameterProfile:
    name = problem.names[index]
    estimate_point = _point(problem, index, z_hat, fit.chi2, None)
    by_dir = {b.direction: b for b in sides}
    walks = {
        d: [(p.z[index], _point(problem, index, p.z, p.chi2, p.error)) for p in by_dir[d].points]
        if d in by_dir
        else []
        for d in (-1, 1)
    }
    start = [(float(z_hat[index]), estimate_point)]
    ends: dict[str, tuple[float | None, float | None]] = {}
    limited: set[str] = set()
    for kind in ("pointwise", "simultaneous"):
        lo_z, lo_lim = ci_end(start + walks[-1], fit.chi2, thr[kind])
        hi_z, hi_lim = ci_end(start + walks[1], fit.chi2, thr[kind])
        ends[kind] = (_value(problem, index, lo_z), _value(problem, index, hi_z))
        if kind == "simultaneous":
            limited.update(lo_lim if lo_z is not None else ())
            limited.update(hi_lim if hi_z is not None else ())
    points = [p for _, p in reversed(walks[-1])] + [estimate_point] + [p for _, p in walks[1]]
    status = label(points, fit.chi2, thr["simultaneous"], ends["simultaneous"])
    return ParameterProfile(
        name=name,
        estimate=fit.estimates[name],
        lower=float(problem.lower[index]),
        upper=float(problem.upper[index]),
        scale=problem.scales[index],
        ci_simultaneous=ends["simultaneous"],
        ci_pointwise=ends["pointwise"],
        status=status,
        points=tuple(points),
        limited_by=tuple(sorted(limited)),
        fisher_sd_z=sd_z,
    )


def _point(
    problem: Problem, index: int, z: np.ndarray, chi2: float, error: str | None
) -> ProfilePoint:
    values = problem.from_z(z)
    lo, hi = problem.z_lower, problem.z_upper
    tol = 1e-6 * (hi - lo)
    at_bound = tuple(
        n
        for k, n in enumerate(problem.names)
        if k != index and (z[k] <= lo[k] + tol[k] or z[k] >= hi[k] - tol[k])
    )
    return ProfilePoint(
        value=values[problem.names[index]],
        chi2=float(chi2),
        params={n: v for n, v in values.items() if n != problem.names[index]},
        at_bound=at_bound,
        error=error,
    )


def _value(problem: Problem, index: int, z: float | None) -> float | None:
    if z is None:
        return None
    return float(10.0**z) if problem.scales[index] == "log" else float(z)
