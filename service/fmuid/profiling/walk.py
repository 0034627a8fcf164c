"""The walk of a profile branch: one parameter stepped in one direction (Raue et al. 2009)."""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from fmuid.errors import FmuidError
from fmuid.estimation.optimize import FitOptions, refine
from fmuid.estimation.problem import Problem
from fmuid.profiling.checks import CheckOptions
from fmuid.profiling.points import WalkPoint

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
        Tolerances of the re-fit of the other parameters at each point (and at the ends).
    end_tolerance
        CI ends are located to this fraction of their half-width.
    checks
        Settings of the right-valley checks at the ends and jumps.
    overshoot
        Past the first point over the simultaneous threshold, walk on until the distance from
        the estimate is ``1 + overshoot`` times that point's, in ``OVERSHOOT_STEPS`` equal steps
        (for a non-smooth objective, where the profile may cross back under the threshold;
        0: stop at the first point over it).

    """

    rise_per_step: float = 0.15
    margin: float = 0.0
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
    end_tolerance: float = 1e-3
    checks: CheckOptions = field(default_factory=CheckOptions)
    overshoot: float = 0.0


#: Points walked past the first crossing when ``overshoot`` is set.
OVERSHOOT_STEPS = 6


def first_step(sd_z: float, threshold: float, span: float, options: WalkOptions) -> float:
    """First step from the estimate: the quadratic (Fisher) guess for the target rise."""
    target = options.rise_per_step * threshold
    step = np.sqrt(target) * sd_z if np.isfinite(sd_z) else options.max_step * span
    return float(np.clip(step, options.min_step * span, options.max_step * span))


def walk(
    problem: Problem,
    path: list[WalkPoint],
    chi2_hat: float,
    index: int,
    direction: int,
    threshold: float,
    step: float,
    options: WalkOptions = WalkOptions(),
    on_point: Callable[[int], None] | None = None,
) -> tuple[list[WalkPoint], WalkPoint | None]:
    """Walk parameter ``index`` outwards in ``direction`` (+1 or -1) from the end of ``path``.

    At each point the profiled parameter is fixed and the others are re-fitted, warm-started
    from a linear extrapolation of their path over the last two points. The step aims at a
    chi2 rise of ``rise_per_step * threshold``, starting from ``step`` and adapted from the
    rise actually seen; a step that overshoots is retried shorter.

    Parameters
    ----------
    problem
        The estimation problem (its FMU instance is per process).
    path
        The good points so far, from the estimate outwards (at least the estimate).
    chi2_hat
        Chi2 at the optimum.
    index, direction
        Which parameter, and which way.
    threshold
        The simultaneous chi2 threshold; the walk ends past ``threshold * (1 + margin)``.
    step
        The first step in fitted coordinates.
    options
        Step settings.
    on_point
        Called with the number of points done after each point.

    Returns
    -------
    points, better
        The new points (failed ones included) and the first point below the optimum, if any
        (the walk stops there).

    """
    lo, hi = problem.z_lower[index], problem.z_upper[index]
    span = hi - lo
    free = np.ones(problem.n_free, bool)
    free[index] = False
    target = options.rise_per_step * threshold
    path = list(path)
    points: list[WalkPoint] = []
    failures = 0
    retries = 0
    last_ok = path[-1]
    reach: float | None = None
    if last_ok.chi2 - chi2_hat > threshold * (1.0 + options.margin) and options.overshoot <= 0:
        return points, None
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
            return points, point
        rise = point.chi2 - last_ok.chi2
        steep = rise > options.max_rise * target and step > options.min_step * span
        if reach is None and steep and retries < 8:
            points.pop()
            retries += 1
            step = max(step * max(np.sqrt(target / rise), 0.1), options.min_step * span)
            continue
        retries = 0
        path.append(point)
        last_ok = point
        distance = abs(zi - path[0].z[index])
        if at_edge or (reach is not None and distance >= reach * (1 - 1e-9)):
            break
        if reach is None and point.chi2 - chi2_hat > threshold * (1.0 + options.margin):
            if options.overshoot <= 0:
                break
            reach = (1.0 + options.overshoot) * distance
            step = (reach - distance) / OVERSHOOT_STEPS
            continue
        if reach is not None:
            continue
        factor = np.sqrt(target / max(rise, 1e-12 * target)) if rise > 0 else 2.0
        step = float(
            np.clip(
                step * np.clip(factor, 0.5, 2.0), options.min_step * span, options.max_step * span
            )
        )
    return points, None


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
