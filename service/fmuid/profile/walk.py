"""One branch of a profile likelihood: one parameter walked in one direction (Raue et al. 2009)."""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from fmuid.errors import FmuidError
from fmuid.fit.optimize import FitOptions, refine
from fmuid.fit.problem import Problem

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class WalkOptions:
    """Settings of the profile walk.

    Attributes
    ----------
    rise_per_step
        Target chi2 rise per step, as a fraction of the simultaneous threshold.
    margin
        Walk on until the profile exceeds the simultaneous threshold times ``1 + margin``.
    min_step, max_step
        Step limits, as fractions of the parameter's range in fitted coordinates.
    max_rise
        A step whose chi2 rise exceeds this multiple of the target is retried shorter.
    max_points
        Cap on points per branch.
    max_failures
        Consecutive failed points after which the branch stops.
    better_tol
        A chi2 this much below the optimum counts as a better optimum.
    refit
        Tolerances of the re-fit of the other parameters at each point.

    """

    rise_per_step: float = 0.15
    margin: float = 0.25
    min_step: float = 1e-4
    max_step: float = 0.08
    max_rise: float = 3.0
    max_points: int = 60
    max_failures: int = 3
    better_tol: float = 1e-3
    refit: FitOptions = field(
        default_factory=lambda: FitOptions(
            ftol=1e-6, xtol=1e-6, gtol=1e-6, diff_step=1e-6, max_nfev=150
        )
    )


@dataclass(frozen=True)
class WalkPoint:
    """A point of a branch in fitted coordinates (``z`` holds every free parameter)."""

    z: np.ndarray
    chi2: float
    error: str | None = None


@dataclass(frozen=True)
class BranchResult:
    """The points of one branch, from the estimate outwards (estimate not included)."""

    index: int
    direction: int
    points: list[WalkPoint]
    better: WalkPoint | None
    simulations: int


def walk_branch(
    problem: Problem,
    z_hat: np.ndarray,
    chi2_hat: float,
    index: int,
    direction: int,
    threshold: float,
    sd_z: float,
    options: WalkOptions = WalkOptions(),
    on_point: Callable[[int], None] | None = None,
) -> BranchResult:
    """Walk parameter ``index`` from the estimate in ``direction`` (+1 or -1).

    At each point the profiled parameter is fixed and the others are re-fitted, warm-started
    from a linear extrapolation of their path over the last two points. The step aims at a
    chi2 rise of ``rise_per_step * threshold``, starting from the quadratic (Fisher)
    approximation ``sd_z`` and adapted from the rise actually seen.

    Parameters
    ----------
    problem
        The estimation problem (its FMU instance is per process).
    z_hat, chi2_hat
        The optimum in fitted coordinates and its chi2.
    index, direction
        Which parameter, and which way.
    threshold
        The simultaneous chi2 threshold; the walk ends past ``threshold * (1 + margin)``.
    sd_z
        Asymptotic standard deviation of the parameter in fitted coordinates (may be inf).
    options
        Step settings.
    on_point
        Called with the number of points done after each point.

    Returns
    -------
    BranchResult

    """
    sims0 = problem.simulations
    lo, hi = problem.z_lower[index], problem.z_upper[index]
    span = hi - lo
    free = np.ones(problem.n_free, bool)
    free[index] = False
    target = options.rise_per_step * threshold
    step = np.sqrt(target) * sd_z if np.isfinite(sd_z) else options.max_step * span
    step = float(np.clip(step, options.min_step * span, options.max_step * span))
    path: list[WalkPoint] = [WalkPoint(z_hat.copy(), chi2_hat)]
    points: list[WalkPoint] = []
    failures = 0
    retries = 0
    last_ok = path[0]
    while len(points) < options.max_points:
        zi = last_ok.z[index] + direction * step
        at_edge = zi <= lo or zi >= hi
        zi = float(np.clip(zi, lo, hi))
        if abs(zi - last_ok.z[index]) < 1e-12 * max(1.0, span):
            break
        guess = _extrapolate(path, index, zi)
        guess = np.clip(guess, problem.z_lower, problem.z_upper)
        try:
            z, chi2, _ = refine(problem, guess, free=free, options=options.refit)
        except FmuidError as exc:
            z, chi2 = guess, float("nan")
            points.append(WalkPoint(guess, chi2, str(exc)))
        else:
            points.append(WalkPoint(z, chi2))
        if on_point:
            on_point(len(points))
        point = points[-1]
        if point.error:
            failures += 1
            if failures >= options.max_failures or at_edge:
                break
            step = min(step * 1.5, options.max_step * span)
            last_ok = WalkPoint(point.z, last_ok.chi2)
            continue
        failures = 0
        if point.chi2 < chi2_hat - options.better_tol * max(1.0, threshold):
            return BranchResult(index, direction, points, point, problem.simulations - sims0)
        rise = point.chi2 - last_ok.chi2
        if rise > options.max_rise * target and step > options.min_step * span and retries < 8:
            points.pop()
            retries += 1
            step = max(step * max(np.sqrt(target / rise), 0.1), options.min_step * span)
            continue
        retries = 0
        path.append(point)
        last_ok = point
        if at_edge or point.chi2 - chi2_hat > threshold * (1.0 + options.margin):
            break
        factor = np.sqrt(target / max(rise, 1e-12 * target)) if rise > 0 else 2.0
        step = float(
            np.clip(
                step * np.clip(factor, 0.5, 2.0), options.min_step * span, options.max_step * span
            )
        )
    return BranchResult(index, direction, points, None, problem.simulations - sims0)


def _extrapolate(path: list[WalkPoint], index: int, zi: float) -> np.ndarray:
    """Linear extrapolation of all parameters along the path to ``z[index] = zi``."""
    last = path[-1].z
    guess = last.copy()
    if len(path) >= 2:
        prev = path[-2].z
        dz = last[index] - prev[index]
        if abs(dz) > 0:
            guess = last + (last - prev) * (zi - last[index]) / dz
    guess[index] = zi
    return guess
