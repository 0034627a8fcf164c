"""The walk of a profile branch: one parameter stepped in one direction (Raue et al. 2009)."""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from fmuid.errors import FmuidError
from fmuid.estimation.optimize import FitOptions, refine
from fmuid.estimation.problem import Problem
from fmuid.profiling.checks import CheckOptions
from fmuid.profiling.ends import confirm, rise_root
from fmuid.profiling.points import WalkPoint
from fmuid.profiling.quasi import Secant, quasi_refit

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class WalkOptions:
    """Settings of the profile walk.

    Attributes
    ----------
    rise_per_step
        The first step aims at a chi2 rise of this fraction of the simultaneous threshold;
        every later step at the same rise of the signed root ``sqrt(chi2 - chi2_hat)`` (linear
        in the parameter for a parabolic profile, so the steps stay equal and about
        ``1 / sqrt(rise_per_step)`` points reach the threshold).
    margin
        Walk on until the profile exceeds the simultaneous threshold times ``1 + margin``.
    min_step, max_step
        Step limits, as fractions of the parameter's range in fitted coordinates.
    max_rise
        A step whose signed-root rise exceeds this multiple of the target is retried shorter.
    max_points
        Cap on points per branch.
    max_failures
        Consecutive failed points after which the branch stops.
    better_tol
        A chi2 this much below the optimum (a fraction of the simultaneous threshold, at least
        1) counts as a better optimum; on a non-smooth objective, when not ``thorough``, at
        least the largest jump of chi2 the health check measured (a lower point within the
        jumps is not resolved; the thorough profile restarts for it, its ends measured from
        the lowest optimum found).
    refit
        Tolerances of the re-fit of the other parameters at the ends and at each point (where
        ``ftol`` is raised to the walk's own tolerance: :func:`walk_refit`).
    end_tolerance
        CI ends are located to this fraction of their half-width.
    checks
        Settings of the right-valley checks at the ends and jumps.
    quasi_tol
        The walk's points are re-fitted by Gauss-Newton steps on a carried Jacobian
        (:mod:`fmuid.profiling.quasi`) until the next step would lower chi2 by less than this
        fraction of the simultaneous threshold (0, or polished re-fits for a non-smooth
        objective: full re-fits at every point).
    overshoot
        Past the first point over the simultaneous threshold, walk on until the distance from
        the estimate is ``1 + overshoot`` times that point's, in ``OVERSHOOT_STEPS`` equal steps
        (for a non-smooth objective, where the profile may cross back under the threshold;
        0: stop at the first point over it).
    thorough
        Whether a non-smooth objective (found by the health check) gets the thorough profile:
        re-fits polished by Powell's method (up to 60 runs per free parameter each), checks
        at every end and an overshoot of 1. Without it, only the finite-difference step is
        raised above the noise floor (the diagnosis's profiles: a clip or a switching FMU
        makes its objective non-smooth, and polished re-fits of a slow FMU cost minutes each).

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
    quasi_tol: float = 2e-4
    thorough: bool = True


#: Consecutive points where the Gauss-Newton re-fit did not settle after which the walk
#: re-fits by trust region only (a strongly nonlinear profile).
MAX_MISSES = 2
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
    jacobian: np.ndarray | None = None,
) -> tuple[list[WalkPoint], WalkPoint | None]:
    """Walk parameter ``index`` outwards in ``direction`` (+1 or -1) from the end of ``path``.

    At each point the profiled parameter is fixed and the others are re-fitted, warm-started
    from a quadratic extrapolation of their path over the last three points (over two and the
    path's Gauss-Newton tangent at the optimum, or along that tangent alone, when there are
    fewer; linear without ``jacobian``). Given ``jacobian``, the re-fits are Gauss-Newton steps
    on that Jacobian carried along the walk (:func:`fmuid.profiling.quasi.quasi_refit`; a full
    re-fit where they do not settle, and for the rest of the walk after ``MAX_MISSES`` in a
    row; a point they put over the stop threshold is re-fitted afresh before it ends the walk:
    :func:`fmuid.profiling.ends.confirm`). The step aims at a
    rise of the signed root ``sqrt(chi2 - chi2_hat)`` by ``sqrt(rise_per_step * threshold)``,
    starting from ``step`` and adapted from the rise actually seen (a parabolic profile is
    walked in equal steps); a step that overshoots is retried shorter.

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
    jacobian
        The fit's Jacobian at ``path[0]``, the optimum (:attr:`FitResult.jacobian`: of the
        weighted model outputs, the residuals' with the opposite sign; fitted coordinates);
        ``None``: linear warm starts and full re-fits.

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
    target = float(np.sqrt(options.rise_per_step * threshold))
    path = list(path)
    points: list[WalkPoint] = []
    failures = 0
    retries = 0
    last_ok = path[-1]
    reach: float | None = None
    tangent = None if jacobian is None or len(path) > 1 else path_tangent(jacobian, index)
    secant = None
    misses = 0
    if jacobian is not None and options.quasi_tol > 0 and not options.refit.polish:
        secant = Secant(-np.array(jacobian, dtype=float), path[-1].z.copy())
    stop = threshold * (1.0 + options.margin)
    settle = walk_refit(options, threshold, chi2_hat)
    if last_ok.chi2 - chi2_hat > stop and options.overshoot <= 0:
        return points, None
    while len(points) < options.max_points:
        zi = last_ok.z[index] + direction * step
        at_edge = zi <= lo or zi >= hi
        zi = float(np.clip(zi, lo, hi))
        if abs(zi - last_ok.z[index]) < 1e-12 * max(1.0, span):
            break
        guess = _extrapolate(path, index, zi, tangent)
        guess = np.clip(guess, problem.z_lower, problem.z_upper)
        cheap = None
        if secant is not None:
            cheap = quasi_refit(
                problem, guess, free, secant, options.quasi_tol * threshold, options.refit.diff_step
            )
        carried = False
        try:
            if cheap is not None and cheap[2]:
                z, chi2 = cheap[0], cheap[1]
                misses = 0
                carried = True
                if chi2 - chi2_hat > stop:  # a rise read on the carried Jacobian: confirm it
                    sure = confirm(
                        problem, index, WalkPoint(z, chi2), options.refit, threshold, secant
                    )
                    if sure is not None:
                        z, chi2, carried = sure.z, sure.chi2, False
            else:
                misses += 1
                if misses >= MAX_MISSES:
                    secant = None
                start = guess if cheap is None else cheap[0]
                z, chi2, _ = refine(problem, start, free=free, options=settle)
        except FmuidError as exc:
            z, chi2 = guess, float("nan")
            points.append(WalkPoint(guess, chi2, str(exc)))
        else:
            points.append(WalkPoint(z, chi2, carried=carried))
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
        rise = rise_root(point.chi2, chi2_hat) - rise_root(last_ok.chi2, chi2_hat)
        steep = rise > options.max_rise * target and step > options.min_step * span
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
        if reach is None and point.chi2 - chi2_hat > stop:
            if options.overshoot <= 0:
                break
            reach = (1.0 + options.overshoot) * distance
            step = (reach - distance) / OVERSHOOT_STEPS
            continue
        if reach is not None:
            continue
        factor = target / max(rise, 1e-12 * target) if rise > 0 else 2.0
        step = float(
            np.clip(
                step * np.clip(factor, 0.5, 2.0), options.min_step * span, options.max_step * span
            )
        )
    return points, None


def walk_refit(options: WalkOptions, threshold: float, chi2_hat: float) -> FitOptions:
    """Tolerances of a walk point's trust-region re-fit: it stops at the walk's own tolerance.

    A walk point only has to decide where the next step goes and which side of a threshold it
    lies on (the ends are located by their own re-fits); trust region in a curved valley takes
    many short steps, each with a finite-difference Jacobian, so ``ftol`` is raised until a
    step that lowers chi2 by less than ``quasi_tol`` of the threshold ends it (the Gauss-Newton
    points' tolerance; unchanged where ``quasi_tol`` is 0).
    """
    if options.quasi_tol <= 0.0:
        return options.refit
    ftol = options.quasi_tol * threshold / max(chi2_hat, 1.0)
    return replace(options.refit, ftol=max(options.refit.ftol, ftol))


def path_tangent(jacobian: np.ndarray, index: int) -> np.ndarray | None:
    """Return the Gauss-Newton direction of parameter ``index``'s profile path at an optimum.

    With ``C = (J'J)^-1`` the other parameters move by ``C[:, i] / C[i, i]`` per unit of
    parameter ``i`` (``None`` when ``C[i, i]`` is not positive and finite).
    """
    cov = np.linalg.pinv(jacobian.T @ jacobian, rcond=1e-12)
    cii = float(cov[index, index])
    if not np.isfinite(cii) or cii <= 0.0:
        return None
    return cov[:, index] / cii


def _extrapolate(
    path: list[WalkPoint], index: int, zi: float, tangent: np.ndarray | None = None
) -> np.ndarray:
    """Extrapolate all parameters along the path to ``z[index] = zi`` (see :func:`walk`)."""
    s = np.array([p.z[index] for p in path[-3:]])
    zs = [p.z for p in path[-3:]]
    if len(path) >= 3 and np.min(np.abs(np.diff(s))) > 0:
        guess = sum(
            zk * np.prod([(zi - s[m]) / (s[k] - s[m]) for m in range(3) if m != k])
            for k, zk in enumerate(zs)
        )
    elif tangent is not None and len(path) <= 2:
        d = zi - path[0].z[index]
        guess = path[0].z + tangent * d
        if len(path) == 2 and path[1].z[index] != path[0].z[index]:
            d1 = path[1].z[index] - path[0].z[index]
            curve = (path[1].z - path[0].z - tangent * d1) / d1**2
            guess = guess + curve * d**2
    elif len(path) >= 2 and path[-1].z[index] != path[-2].z[index]:
        last, prev = path[-1].z, path[-2].z
        guess = last + (last - prev) * (zi - last[index]) / (last[index] - prev[index])
    else:
        guess = path[-1].z.copy()
    guess = np.array(guess, dtype=float)
    guess[index] = zi
    return guess
