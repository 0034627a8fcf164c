"""The walk of a profile branch: one parameter stepped in one direction (Raue et al. 2009)."""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from fmuid.errors import FmuidError
from fmuid.estimation.optimize import FitOptions
from fmuid.estimation.problem import Problem
from fmuid.profiling.checks import CheckOptions
from fmuid.profiling.ends import rise_root
from fmuid.profiling.points import WalkPoint
from fmuid.profiling.refit import BranchRefit

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class WalkOptions:
    """Settings of the profile walk.

    Attributes
    ----------
    rise_per_step
        Chi2 rise of the first step from the optimum, as a fraction of the simultaneous
        threshold: the walk steps in equal rises of the root ``sqrt(chi2 - chi2_hat)`` (linear
        in the parameter where the profile is parabolic), each landing just past a threshold
        it would otherwise step over.
    margin
        Walk on until the profile exceeds the simultaneous threshold times ``1 + margin``.
    min_step, max_step
        Step limits, as fractions of the parameter's range in fitted coordinates.
    max_rise
        A step whose rise of the root exceeds ``sqrt(max_rise)`` times the target is retried
        shorter.
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
#: A step that would pass a threshold lands where the root of the rise is this factor of the
#: threshold's root (the crossing is then bracketed closely, and located in one or two re-fits).
LANDING = 1.05


def first_step(sd_z: float, threshold: float, span: float, options: WalkOptions) -> float:
    """First step from the estimate: the quadratic (Fisher) guess for the first rise."""
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
    refit: BranchRefit | None = None,
    landings: Sequence[float] = (),
) -> tuple[list[WalkPoint], WalkPoint | None]:
    """Walk parameter ``index`` outwards in ``direction`` (+1 or -1) from the end of ``path``.

    At each point the profiled parameter is fixed and the others are re-fitted, warm-started
    from a linear extrapolation of their path over the last two points. Each step aims at a
    rise of the root ``r = sqrt(chi2 - chi2_hat)`` of ``sqrt(rise_per_step * threshold)``
    (``step`` is taken to make it, later steps follow the slope of ``r`` over the last step), or
    just past the next of ``threshold`` and ``landings`` when it would step over it; a step
    that rises much more is retried shorter.

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
    refit
        The branch's re-fits (they hand their Jacobians on); a new one by default.
    landings
        Other chi2 rises (e.g. the pointwise threshold) the walk lands just past.

    Returns
    -------
    points, better
        The new points (failed ones included) and the first point below the optimum, if any
        (the walk stops there).

    """
    lo, hi = problem.z_lower[index], problem.z_upper[index]
    span = hi - lo
    refit = refit or BranchRefit(problem, index, options.refit)
    target = np.sqrt(options.rise_per_step * threshold)
    roots = sorted(np.sqrt([threshold, *landings]))
    slope = target / step
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
            z, chi2 = refit(guess)
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
        r_last, r_new = rise_root(last_ok.chi2, chi2_hat), rise_root(point.chi2, chi2_hat)
        rise = r_new - r_last
        steep = rise > np.sqrt(options.max_rise) * target and step > options.min_step * span
        if reach is None and steep and retries < 8:
            points.pop()
            retries += 1
            step = max(step * max(target / rise, 0.1), options.min_step * span)
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
        aim = r_new + target
        ahead = [LANDING * root for root in roots if root > r_new]
        if ahead and ahead[0] < aim:
            aim = ahead[0]
        if rise > 0:
            slope = rise / step
        nxt = (aim - r_new) / slope if rise > 0 else 2.0 * step
        step = float(
            np.clip(
                np.clip(nxt, 0.1 * step, 2.0 * step),
                options.min_step * span,
                options.max_step * span,
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
