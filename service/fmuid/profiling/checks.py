"""Right-valley checks: re-fits from diverse seeded starts (Latin hypercube within the bounds)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import qmc

from fmuid.errors import FmuidError
from fmuid.estimation.optimize import FitOptions, refine
from fmuid.estimation.problem import Problem
from fmuid.estimation.space import BOUND_TOLERANCE
from fmuid.profiling.health import GRID_SIDE
from fmuid.profiling.points import WalkPoint


@dataclass(frozen=True)
class CheckOptions:
    """Settings of the multi-start checks.

    Attributes
    ----------
    fit_starts
        Latin-hypercube starts of the check of the fit itself (when it had no global search).
    end_starts
        Latin-hypercube starts of a check at a CI end or a jump.
    always
        Check every CI end from ``end_starts`` diverse starts; otherwise only ends whose profile
        jumps or bends, whose Fisher deviation is infinite, or where a re-fit with another
        parameter moved from its bound to its other bound reached another minimum than the
        walked one (and every end when the FMU health check found the objective non-smooth).
        Ends are always re-fitted from the other valleys the fit check found.
    lower_tol
        A re-fit lower than the walk's chi2 by this fraction of the simultaneous threshold
        counts as a lower valley.
    max_rewalks
        Re-walks per branch after which the branch is reported unsettled.
    refit
        Tolerances of the re-fits from diverse starts.
    near
        A check's re-fit this close to a known minimum (fraction of each range) is tested for a
        ridge between them, and minima of the fit check with no ridge between them are one
        valley (:func:`refit_from`, :func:`distinct_valleys`); 0 on a non-smooth objective,
        whose jumps of chi2 a halfway run cannot tell from a ridge.
    health_grid
        Grid points on each side of the estimate along each parameter in the health check
        (:func:`fmuid.profiling.health.check_health`): fewer make it shorter for slow FMUs
        (it logs how many runs it makes at the measured cost per run); below 3 it looks for
        no jumps.

    """

    fit_starts: int = 3
    end_starts: int = 3
    always: bool = False
    lower_tol: float = 2e-3
    max_rewalks: int = 3
    refit: FitOptions = field(
        default_factory=lambda: FitOptions(ftol=1e-6, xtol=1e-6, gtol=1e-6, max_nfev=150)
    )
    health_grid: int = GRID_SIDE
    near: float = 1e-2


#: Two minima share a basin when no parameter differs by more than this fraction of its range.
BASIN = 1e-3


def diverse_starts(problem: Problem, n: int, seed: Sequence[int]) -> np.ndarray:
    """Return ``n`` seeded Latin-hypercube points within the bounds, in fitted coordinates."""
    if n <= 0:
        return np.zeros((0, problem.n_free))
    rng = np.random.default_rng(list(seed))
    unit = qmc.LatinHypercube(d=problem.n_free, seed=rng).random(n)
    lo, hi = problem.z_lower, problem.z_upper
    return lo + unit * (hi - lo)


def refit_from(
    problem: Problem,
    index: int | None,
    z_fixed: float | None,
    starts: Sequence[np.ndarray],
    options: FitOptions,
    known: Sequence[WalkPoint] | None = None,
    tol: float = 0.0,
    near: float = 0.0,
) -> list[WalkPoint]:
    """Re-fit from each start, parameter ``index`` held at ``z_fixed`` (``None``: all free).

    ``known``: minima already re-fitted at the same ``z_fixed`` (the checked point itself, the
    check's earlier re-fits; each re-fit made here joins them; ``None``: every re-fit runs to
    its tolerance). A re-fit that evaluates a point
    in a known minimum's basin (every parameter within ``BASIN`` of its range) at a chi2 not
    below the minimum's by ``tol`` or more ends there with that minimum as its result: it would
    descend into the minimum (trust region converges within a basin), and a check learns only
    whether a start reaches a lower valley, not the same one again to full tolerance. So does a
    point within ``near`` of a known minimum with no ridge between them (:func:`_one_valley`, one
    run, made again for the same minimum only at half the distance): a re-fit that creeps
    towards a bound, or along a flat direction, reaches ``BASIN`` only after many runs. Failed
    re-fits are left out.
    """
    free = np.ones(problem.n_free, bool)
    if index is not None:
        free[index] = False
    seen = [] if known is None else list(known)
    landed: list[WalkPoint] = []
    span = problem.z_upper - problem.z_lower
    tested: dict[int, float] = {}

    def stop(z: np.ndarray, chi2: float) -> bool:
        for n, k in enumerate(seen):
            if chi2 < k.chi2 - tol:
                continue
            gap = float(np.max(np.abs(z - k.z) / span))
            close = gap <= near and gap <= 0.5 * tested.get(n, np.inf)
            if close and gap > BASIN:
                tested[n] = gap
            if gap <= BASIN or (close and _one_valley(problem, WalkPoint(z, chi2), k, tol)):
                landed.append(k)
                return True
        return False

    out = []
    for start in starts:
        z0 = np.array(start, dtype=float)
        if index is not None and z_fixed is not None:
            z0[index] = z_fixed
        landed.clear()
        tested.clear()
        try:
            z, chi2, _ = refine(
                problem, z0, free=free, options=options, stop=None if known is None else stop
            )
        except FmuidError:
            continue
        point = landed[0] if landed else WalkPoint(z, chi2)
        out.append(point)
        if not landed:
            seen.append(point)
    return out


def bound_flips(
    problem: Problem, z: np.ndarray, index: int, path: Sequence[np.ndarray] = ()
) -> list[np.ndarray]:
    """Return ``z`` with one other parameter moved to the far side of a bound, per parameter.

    A parameter is on a bound when it lies within ``BOUND_TOLERANCE`` (1e-6) of its span of
    the bound, in fitted coordinates (the level of :meth:`fmuid.estimation.space.
    ParameterSpace.at_bound`). A re-fit from ``z`` holds such a parameter there; the valley
    with the parameter on its other bound is reached only from the other side of the ridge
    between them, which the diverse starts cross by luck. A parameter on a bound at a point of
    ``path`` (the walk towards ``z``) and off it at ``z`` is moved to its other bound too:
    whether a re-fit lands on the bound or just beside it depends on the optimiser's
    tolerances, not on the valley. Parameter ``index`` (the profiled one) is left out; the
    other parameters stay as in ``z``. Empty when none was on a bound.
    """
    lo, hi = problem.z_lower, problem.z_upper
    tol = BOUND_TOLERANCE * (hi - lo)
    out = []
    for k in range(len(lo)):
        if k == index:
            continue
        held = [p[k] for p in (z, *path) if not lo[k] + tol[k] < p[k] < hi[k] - tol[k]]
        if not held:
            continue
        start = np.array(z, dtype=float)
        start[k] = hi[k] if held[0] <= lo[k] + tol[k] else lo[k]
        out.append(start)
    return out


def check_fit(
    problem: Problem, options: CheckOptions, seed: int, fit: WalkPoint, tol: float
) -> list[WalkPoint]:
    """Re-fit every parameter from ``options.fit_starts`` diverse seeded starts.

    A re-fit that reaches the basin of the ``fit`` (a chi2 not below it by ``tol``) ends there
    with the ``fit`` as its result (:func:`refit_from`).
    """
    starts = diverse_starts(problem, options.fit_starts, (seed, 12))
    return refit_from(problem, None, None, list(starts), options.refit, [fit], tol, options.near)


def distinct_valleys(
    points: Sequence[WalkPoint],
    problem: Problem,
    best: WalkPoint,
    ceiling: float,
    tol: float | None,
) -> list[np.ndarray]:
    """Minima below ``ceiling`` in other valleys than ``best``'s and each other's.

    Two minima lie in one valley when they share a basin (:func:`same_basin`) or when the chi2
    halfway between them is not above the higher of the two by more than ``tol``: no ridge
    parts them (a run of the fit that stopped short in a flat direction ends more than
    ``BASIN`` from the optimum it was descending to, and checking every profile point from it
    would re-fit the optimum again). One run per pair that ``same_basin`` does not settle;
    ``tol`` ``None``: ``same_basin`` alone.
    """
    kept: list[WalkPoint] = [best]
    for p in sorted(points, key=lambda q: q.chi2):
        if p.chi2 <= ceiling and not any(_one_valley(problem, p, k, tol) for k in kept):
            kept.append(p)
    return [k.z for k in kept[1:]]


def _one_valley(problem: Problem, a: WalkPoint, b: WalkPoint, tol: float | None) -> bool:
    """Whether no ridge parts minima ``a`` and ``b`` (see :func:`distinct_valleys`)."""
    if same_basin(problem, a.z, b.z):
        return True
    if tol is None:
        return False
    try:
        r = problem.residuals(0.5 * (a.z + b.z))
    except FmuidError:
        return False
    return float(r @ r) <= max(a.chi2, b.chi2) + tol


def basins(
    problem: Problem, found: Sequence[WalkPoint], seen: Sequence[WalkPoint], keep: int
) -> list[WalkPoint]:
    """Return the lowest ``keep`` re-fits of ``found`` in basins other than ``seen`` or each other.

    Two re-fits share a basin when no parameter differs by more than ``BASIN`` of its range. A
    check's diverse starts end in such basins; the checks further in along the same branch
    start from them (cheaper than new diverse starts, and they follow the same valleys).
    """
    kept: list[WalkPoint] = []
    for p in sorted(found, key=lambda q: q.chi2):
        if len(kept) < keep and not any(same_basin(problem, p.z, q.z) for q in [*seen, *kept]):
            kept.append(p)
    return kept


def same_basin(problem: Problem, a: np.ndarray, b: np.ndarray) -> bool:
    """Whether no parameter differs between ``a`` and ``b`` by more than ``BASIN`` of its range."""
    return bool(np.max(np.abs(a - b) / (problem.z_upper - problem.z_lower)) <= BASIN)


def flip_key(start: np.ndarray, z: np.ndarray) -> tuple[int, float]:
    """Return the parameter a bound flip of ``z`` moved and the bound it moved it to."""
    k = int(np.flatnonzero(start != z)[0])
    return k, float(start[k])


def flip_starts(
    flips: Sequence[np.ndarray], z: np.ndarray, behind: dict[tuple[int, float], WalkPoint]
) -> list[tuple[tuple[int, float], np.ndarray]]:
    """Return the bound flips of an end at ``z`` to re-fit, each as ``(key, start)``.

    ``key`` is :func:`flip_key` of the flip. ``behind`` holds, per key, the last minimum a
    flip of that key reached at an earlier end of the branch (in this round or an earlier one)
    other than that end's walked valley: the valley behind the bound. A flip whose key is there
    starts from that minimum (followed to this end from nearby rather than crossed to again
    from the far bound, where the model may be far off and the descent costs many runs); the
    others start from the far bound. Every end gets its flips: a valley behind a bound that
    is not lower at the outer end may still be lower at the inner one (the tractor's ramp
    10 Hz SNR 16.67, noise seed 1: ``C_air``'s pointwise lower end).
    """
    out = []
    for start in flips:
        key = flip_key(start, z)
        out.append((key, behind[key].z if key in behind else start))
    return out


def jumps(side: Sequence[WalkPoint], index: int, chi2_hat: float, threshold: float) -> list[int]:
    """Positions in ``side`` where the profile jumps, drops or bends unexpectedly.

    In the signed root ``r = sqrt(chi2 - chi2_hat)`` a smooth profile is close to a straight
    line; a step whose slope in ``r`` differs from the previous step's by more than a factor of
    three (once the profile has risen by a tenth of the threshold), or a drop of chi2 outwards
    by more than 1e-3 of the threshold, marks the point after it.
    """
    ok = [(k, p) for k, p in enumerate(side) if p.ok]
    out = []
    slope_prev = None
    for (_, p0), (k1, p1) in zip(ok, ok[1:]):
        dz = abs(p1.z[index] - p0.z[index])
        if dz == 0:
            continue
        if p1.chi2 < p0.chi2 - 1e-3 * threshold:
            out.append(k1)
            slope_prev = None
            continue
        r0 = np.sqrt(max(p0.chi2 - chi2_hat, 0.0))
        r1 = np.sqrt(max(p1.chi2 - chi2_hat, 0.0))
        slope = (r1 - r0) / dz
        risen = p1.chi2 - chi2_hat > 0.1 * threshold
        if slope_prev is not None and risen and slope_prev > 0 and slope > 0:
            ratio = slope / slope_prev
            if ratio > 3.0 or ratio < 1.0 / 3.0:
                out.append(k1)
        slope_prev = slope if risen else None
    return out


#: A step along which the other parameters' rate of change (per unit of the profiled one, in
#: fractions of their ranges) changes by more than this multiple of the previous step's rate
#: is a switch of valley...
SWITCH_RATIO = 1.0
#: ...when the change is also at least this large (a range per range: slow drifts are smooth).
SWITCH_FLOOR = 0.5


def switches(
    side: Sequence[WalkPoint],
    index: int,
    lower: np.ndarray,
    upper: np.ndarray,
    tangent: np.ndarray | None = None,
) -> list[int]:
    """Positions in ``side`` where the re-fit of the other parameters jumped to another valley.

    Along one valley the other parameters move smoothly with the profiled one; their rate of
    change per step (span-normalised) changes by a small fraction of itself from one step to
    the next. A change larger than ``SWITCH_RATIO`` times the previous rate and than
    ``SWITCH_FLOOR`` marks the point after it: the walk may have left the valley it followed
    there (or joined a lower one), whatever its chi2 path looks like. Parameters on a bound
    (``lower``, ``upper``: fitted coordinates) at either step are left out: their rate stops.
    The first step is compared with the path's ``tangent`` at ``side[0]`` when given.
    """
    span = upper - lower
    ok = [(k, p) for k, p in enumerate(side) if p.ok]
    out: list[int] = []
    rate_prev: np.ndarray | None = None
    free_prev = np.ones(len(span), bool)
    for (_, p0), (k1, p1) in zip(ok, ok[1:]):
        dz = (p1.z - p0.z) / span
        if dz[index] == 0:
            continue
        if rate_prev is None and tangent is not None and p0 is side[0]:
            rate_prev = tangent / span * span[index] * np.sign(dz[index])
        inside = np.ones(len(span), bool)
        inside[index] = False
        for p in (p0, p1):
            inside &= (p.z > lower + 1e-6 * span) & (p.z < upper - 1e-6 * span)
        rate = dz / abs(dz[index])
        if rate_prev is not None:
            keep = inside & free_prev
            if keep.any():
                change = float(np.max(np.abs(rate - rate_prev)[keep]))
                if change > max(
                    SWITCH_FLOOR, SWITCH_RATIO * float(np.max(np.abs(rate_prev[keep])))
                ):
                    out.append(k1)
        rate_prev, free_prev = rate, inside
    return out
