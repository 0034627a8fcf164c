"""Profile likelihood of every free parameter: walks, intervals, labels, structural check."""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import replace
from functools import partial
from typing import Any

import numpy as np
from scipy.stats import chi2 as chi2_dist

from fmuid.engine.count import counting
from fmuid.engine.run import open_engine
from fmuid.engine.task import Engine
from fmuid.estimation.optimize import jacobian
from fmuid.estimation.problem import Problem
from fmuid.estimation.result import Cost, FitResult
from fmuid.estimation.space import z_to_value
from fmuid.model.registry import fmu_summary
from fmuid.profiling.branch import BranchResult
from fmuid.profiling.branches import walk_all
from fmuid.profiling.checks import check_fit, distinct_valleys
from fmuid.profiling.cross import CrossRecord, cross_check
from fmuid.profiling.health import NOISY_FRACTION, Health, check_health
from fmuid.profiling.intervals import is_flat, label, noise_limited, open_reason, profile_noise
from fmuid.profiling.optimum import descend, refit_optimum
from fmuid.profiling.points import WalkPoint
from fmuid.profiling.result import ParameterProfile, ProfilePoint, ProfileQuality, ProfileResult
from fmuid.profiling.structural import structural_check
from fmuid.profiling.walk import WalkOptions
from fmuid.progress import ProgressCallback

log = logging.getLogger(__name__)

#: How often a better optimum found on a profile may restart the profiles.
MAX_RESTARTS = 3
#: The jumps of a walked profile are measured where it rises by at most this many simultaneous
#: thresholds (around its ends; further out the profile is steeper and its jumps larger).
NOISE_REACH = 1.5


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
    confidence: float | None = None,
    health: Health | None = None,
) -> ProfileResult:
    """Profile likelihoods of the free parameters around a fit.

    A health check of the objective comes first (non-smooth FMUs get larger finite-difference
    steps and, with ``options.thorough``, polished re-fits and checks at every end, and each
    branch walks as far again past its first crossing, the outermost crossing being the end;
    where chi2 jumps by a tenth of
    the pointwise threshold or more, no end is labelled ``identifiable``); a fit without
    global search is checked from diverse starts (full studies only, ``only=None``). Every
    parameter is then walked in both directions (branches run in parallel), its pointwise and
    simultaneous CI ends are located by root-finding on re-fits, the ends are checked for a
    lower valley, and it is labelled. If a profile finds a lower chi2 than the optimum, the fit
    is refined from there and the profiles are redone (``better_optimum_found``). See
    ``docs/profiles.md``.

    Parameters
    ----------
    problem
        The estimation problem.
    fit
        The best fit of ``problem``.
    only
        Profile only these parameters (default: all free parameters; then the fit is also
        checked from diverse starts when it had no global search).
    workers
        Local worker processes; 1 runs in this process.
    executor
        A ``dask.distributed.Client`` to run branches on instead of local processes, or an
        engine already open (:class:`fmuid.engine.task.Engine`: a diagnosis's pool).
    progress
        Receives ``Progress("profile", done, total, detail)`` after every point.
    options
        Walk, end and check settings.
    confidence
        Level of the intervals (default: the spec's ``confidence``).
    health
        The health check of this objective at ``fit``'s estimate, where one was made already
        (a profile of the same model and data from the same fit: the diagnosis's profiles of
        the added parameters and of the original ones after); else it is made here.

    Returns
    -------
    ProfileResult

    """
    t0, fit0 = time.perf_counter(), fit
    conf = problem.spec.confidence if confidence is None else confidence
    names = list(only) if only is not None else list(problem.names)
    with (
        counting() as count,
        open_engine(
            problem.model,
            workers=workers,
            executor=executor,
            at_most=2 * len(names),
            preload=["fmuid.profiling.branch"],
        ) as engine,
    ):
        fit, profiles, better_found, check, checks = _profiles(
            problem, fit, only, engine, progress, options, conf, health
        )
    if fit.fmu_info:  # the health check may have found the reset unreliable since the fit
        fit = replace(fit, fmu_info=fmu_summary(problem.model))
    return ProfileResult(
        fit=fit,
        confidence=conf,
        thresholds=thresholds(conf, problem.n_free),
        parameters=profiles,
        better_optimum_found=better_found,
        structural_check=check,
        cost=Cost(
            fit0.cost.simulations + count.simulations,
            time.perf_counter() - t0 + fit0.cost.seconds,
        ),
        checks=checks,
    )


def _profiles(
    problem: Problem,
    fit: FitResult,
    only: Sequence[str] | None,
    engine: Engine,
    progress: ProgressCallback | None,
    options: WalkOptions,
    conf: float,
    known: Health | None,
) -> tuple[FitResult, dict[str, ParameterProfile], bool, dict[str, Any], dict[str, Any]]:
    """Run :func:`profile_problem`'s steps; return the fit, profiles, better-found and checks."""
    thr = thresholds(conf, problem.n_free)
    names = list(only) if only is not None else list(problem.names)
    better_found = False
    health = (
        replace(known, simulations=0)
        if known is not None
        else check_health(
            problem,
            fit.z_estimate(),
            fit.jacobian,
            progress,
            options.checks.health_grid,
            engine.map if engine.parallel else None,
        )
    )
    if health.diff_step > options.refit.diff_step:
        options = replace(options, refit=replace(options.refit, diff_step=health.diff_step))
    settle = options.refit
    if not health.smooth:
        options = _non_smooth(options, health, thr["simultaneous"])
        settle = replace(options.refit, polish=True)
        fit = descend(problem, fit, settle)
    pool: list[WalkPoint] = []
    fit_check: dict[str, Any] = {"starts": 0, "lower_found": False, "simulations": 0}
    if only is None and (not fit.global_search or not health.smooth) and options.checks.fit_starts:
        with counting() as checked:
            lower = options.better_tol * max(1.0, thr["simultaneous"])
            optimum = WalkPoint(fit.z_estimate(), fit.chi2)
            pool = check_fit(problem, options.checks, problem.spec.seed, optimum, lower)
            fit_check["starts"] = len(pool)
            best = min(pool, key=lambda p: p.chi2, default=None)
            if best is not None and best.chi2 < fit.chi2 - lower:
                log.info("the fit check found chi2 %.6g below the fit's %.6g", best.chi2, fit.chi2)
                fit_check["lower_found"] = True
                better_found = True
                pool.append(optimum)
                fit = refit_optimum(problem, best.z, fit, settle)
        fit_check["simulations"] = checked.simulations
    cross = CrossRecord()
    for attempt in range(MAX_RESTARTS + 1):
        valleys = distinct_valleys(
            pool,
            problem,
            WalkPoint(fit.z_estimate(), fit.chi2),
            fit.chi2 + thr["simultaneous"],
            options.checks.lower_tol * thr["simultaneous"] if options.checks.near else None,
        )
        walk = partial(
            walk_all,
            problem,
            fit,
            names,
            thr,
            engine,
            progress,
            options,
            valleys,
            restart=attempt < MAX_RESTARTS,
        )
        branches = walk()
        if all(b.better is None for b in branches):
            branches = cross_check(problem, branches, fit.chi2, thr, options, walk, cross)
        better = [b.better for b in branches if b.better is not None]
        if not better:
            break
        better_found = True
        best = min(better, key=lambda p: p.chi2)
        log.info("profile found chi2 %.6g below the optimum %.6g; refitting", best.chi2, fit.chi2)
        pool.append(WalkPoint(fit.z_estimate(), fit.chi2))
        fit = refit_optimum(problem, best.z, fit, settle)
    check = structural_check(
        fit.jacobian, problem.names, problem.scales, [fit.estimates[n] for n in problem.names]
    )
    sd = fit.fisher_sd_z()
    profiles = {}
    for name in names:
        i = problem.names.index(name)
        sides = [b for b in branches if b.index == i]
        floor = health.chi2_noise.get(name, 0.0) if options.overshoot else None
        profiles[name] = _assemble(problem, fit, i, sides, thr, sd[name], check, floor)
    fit_check["valleys"] = len(valleys)
    checks = {"health": health.to_dict(), "fit": fit_check, "cross": cross.to_dict()}
    return fit, profiles, better_found, check, checks


def _non_smooth(options: WalkOptions, health: Health, threshold: float) -> WalkOptions:
    """Return the walk settings for a non-smooth objective (see :class:`WalkOptions`).

    Thorough: polished re-fits, checks at every end and an overshoot of 1. Otherwise a lower
    point within the jumps of chi2 the health check measured is not a better optimum. Both make
    no ridge tests (:attr:`fmuid.profiling.checks.CheckOptions.near`); the caller has raised the
    difference step to the health check's, as for any objective.
    """
    checks = replace(options.checks, near=0.0)
    if options.thorough:
        log.info("the objective is not smooth (%s): thorough checks", health.to_dict())
        checks = replace(checks, always=True)
        refit = replace(options.refit, polish=True)
        return replace(options, refit=refit, checks=checks, overshoot=1.0)
    log.info("the objective is not smooth (%s): larger difference steps", health.to_dict())
    noise = max(health.chi2_noise.values(), default=0.0) / max(1.0, threshold)
    return replace(options, checks=checks, better_tol=max(options.better_tol, noise))


def _assemble(
    problem: Problem,
    fit: FitResult,
    index: int,
    sides: list[BranchResult],
    thr: dict[str, float],
    sd_z: float,
    check: dict[str, Any],
    floor: float | None = None,
) -> ParameterProfile:
    """Put one parameter's profile together from its branches and label it.

    ``floor`` (the health check's chi2 noise along the parameter; None for a smooth objective)
    is raised to the largest jump of the walked profile; when that is comparable to the
    pointwise threshold, the label says how far the noise could move the ends.
    """
    name = problem.names[index]
    estimate_point = ProfilePoint(
        value=fit.estimates[name],
        chi2=float(fit.chi2),
        params={n: v for n, v in fit.estimates.items() if n != name},
        at_bound=_point(problem, index, fit.z_estimate(), fit.chi2, None).at_bound,
    )
    by_dir = {b.direction: b for b in sides}
    walks: dict[int, list[tuple[float, ProfilePoint]]] = {}
    ends: dict[str, list[float | None]] = {"pointwise": [None, None], "simultaneous": [None, None]}
    limited: set[str] = set()
    quality = ProfileQuality()
    for k, d in enumerate((-1, 1)):
        branch = by_dir.get(d)
        if branch is None:
            walks[d] = []
            continue
        quality = quality + branch.quality
        extra = [e.point for e in branch.ends.values() if e.point is not None]
        pts = {float(p.z[index]): p for p in branch.points + extra}
        walks[d] = sorted(
            ((z, _point(problem, index, p.z, p.chi2, p.error)) for z, p in pts.items()),
            key=lambda zp: abs(zp[0] - fit.z_estimate()[index]),
        )
        for kind, end in branch.ends.items():
            ends[kind][k] = None if end.z is None else z_to_value(end.z, problem.scales[index])
            if kind == "simultaneous" and end.point is not None:
                limited.update(_point(problem, index, end.point.z, end.point.chi2, None).at_bound)
    points = [p for _, p in reversed(walks[-1])] + [estimate_point] + [p for _, p in walks[1]]
    sim = (ends["simultaneous"][0], ends["simultaneous"][1])
    bounds = (float(problem.lower[index]), float(problem.upper[index]))
    why_open = tuple(
        open_reason([estimate_point] + [p for _, p in walks[d]], bounds[k])
        if sim[k] is None
        else ""
        for k, d in enumerate((-1, 1))
    )
    flat = is_flat(points, fit.chi2, thr["simultaneous"])
    partners, meaning = _null_direction(problem, name, check, flat, walks)
    status, reason = label(name, flat, sim, (why_open[0], why_open[1]), partners, meaning)
    if floor is not None:
        near = NOISE_REACH * thr["simultaneous"]
        good = [
            (z, p.chi2)
            for d in (-1, 1)
            for z, p in walks[d]
            if p.error is None and p.chi2 - fit.chi2 <= near
        ]
        good.append((float(fit.z_estimate()[index]), float(fit.chi2)))
        noise = max(floor, profile_noise([z for z, _ in good], [c for _, c in good], fit.chi2))
        if noise >= NOISY_FRACTION * thr["pointwise"]:
            status, reason = noise_limited(
                status, reason, noise, thr["simultaneous"], sim, fit.estimates[name]
            )
    return ParameterProfile(
        name=name,
        estimate=fit.estimates[name],
        lower=float(problem.lower[index]),
        upper=float(problem.upper[index]),
        scale=problem.scales[index],
        ci_simultaneous=sim,
        ci_pointwise=(ends["pointwise"][0], ends["pointwise"][1]),
        status=status,
        points=tuple(points),
        limited_by=tuple(sorted(limited)),
        fisher_sd_z=sd_z,
        status_reason=reason,
        quality=quality,
    )


def _null_direction(
    problem: Problem,
    name: str,
    check: dict[str, Any],
    flat: bool,
    walks: dict[int, list[tuple[float, ProfilePoint]]],
) -> tuple[list[str] | None, str]:
    """Find a null direction of the noise-free sensitivities that involves ``name``.

    Looked for at the estimate and, for a flat profile, at the outermost good points of its
    profile. Returns the other parameters of the direction and its meaning, or ``(None, "")``.
    """
    combos = list(check["non_identifiable_combinations"])
    if flat and not any(name in c["parameters"] for c in combos):
        for side in walks.values():
            ok = [p for _, p in side if p.error is None and np.isfinite(p.chi2)]
            if not ok:
                continue
            values = {name: ok[-1].value, **ok[-1].params}
            z = problem.to_z(values)
            local = structural_check(
                jacobian(problem, z),
                problem.names,
                problem.scales,
                [values[n] for n in problem.names],
            )
            combos += local["non_identifiable_combinations"]
    for c in combos:
        if name in c["parameters"]:
            return [n for n in c["parameters"] if n != name], str(c["meaning"])
    return None, ""


def _point(
    problem: Problem, index: int, z: np.ndarray, chi2: float, error: str | None
) -> ProfilePoint:
    values = problem.from_z(z)
    return ProfilePoint(
        value=values[problem.names[index]],
        chi2=float(chi2),
        params={n: v for n, v in values.items() if n != problem.names[index]},
        at_bound=problem.space.at_bound(z, skip=index),
        error=error,
    )
