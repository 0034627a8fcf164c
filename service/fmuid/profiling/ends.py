"""Exact confidence-interval ends: root-finding on re-fits once a crossing is bracketed."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from fmuid.errors import FmuidError
from fmuid.estimation.optimize import FitOptions, refine
from fmuid.estimation.problem import Problem
from fmuid.profiling.checks import switches
from fmuid.profiling.points import WalkPoint
from fmuid.profiling.quasi import Secant, quasi_refit

#: Most re-fits spent locating one crossing.
MAX_REFITS = 12
#: A re-fit at a guess of a crossing stops when its next Gauss-Newton step would lower chi2 by
#: less than this fraction of the threshold (moving the end by about half that fraction of its
#: half-width, well inside ``end_tolerance``).
END_TOL = 1e-5
#: A walk point's confirming re-fit stops when its next Gauss-Newton step would lower chi2 by
#: less than this fraction of the threshold (the walk's own tolerance: it only decides a side).
CONFIRM_TOL = 2e-4


@dataclass(frozen=True)
class End:
    """Where the profile crosses a threshold on one side of the estimate.

    Attributes
    ----------
    z
        The profiled parameter's fitted coordinate at the crossing; ``None`` when the profile
        does not cross inside the bounds (an open end).
    point
        The re-fitted point nearest the crossing (``None`` for an open end).
    refits
        Re-fits spent locating it.
    settled
        ``False`` when the root-finding ran out of re-fits or a re-fit failed before the
        crossing was located to the tolerance.
    why_open
        For an open end: ``"bound"`` (the profile stays under the threshold up to the
        parameter's bound) or ``"walk stopped"`` (failed points or the point cap ended the walk).
    beyond
        The crossing is the outermost one walked, but the profile was back under the threshold
        where the walk ended (a non-smooth objective): the end may lie further out.

    """

    z: float | None
    point: WalkPoint | None = None
    refits: int = 0
    settled: bool = True
    why_open: str = ""
    beyond: bool = False


@dataclass
class Located:
    """The root-findings and confirmations made on one branch, kept across its rounds.

    A crossing bracketed by the same two points (with the same valley split) is the same
    crossing, and a point confirmed once is confirmed: a branch that locates its ends again
    after a re-walk re-fits only the brackets the re-walk changed. Keyed by the points'
    identities (the values keep the points alive, so an identity is never reused).
    """

    roots: dict[tuple[float, int, int, bool], tuple[tuple[WalkPoint, WalkPoint], End, bool]] = (
        field(default_factory=dict)
    )
    confirmed: dict[tuple[float, int], tuple[WalkPoint, WalkPoint | None]] = field(
        default_factory=dict
    )


def rise_root(chi2: float, chi2_hat: float) -> float:
    """Return ``sqrt(chi2 - chi2_hat)``: linear in ``z`` for a parabolic profile."""
    return float(np.sqrt(max(chi2 - chi2_hat, 0.0)))


def bracket(
    side: Sequence[WalkPoint],
    index: int,
    chi2_hat: float,
    threshold: float,
    outermost: bool = False,
) -> tuple[WalkPoint, WalkPoint] | None:
    """Return the first (or outermost) pair of consecutive good points rising over the threshold.

    ``side`` runs from the estimate outwards (estimate first); failed points are skipped.
    """
    ok = [p for p in side if p.error is None and np.isfinite(p.chi2)]
    pairs = [
        (p0, p1)
        for p0, p1 in zip(ok, ok[1:])
        if p0.chi2 - chi2_hat < threshold <= p1.chi2 - chi2_hat
    ]
    if not pairs:
        return None
    return pairs[-1] if outermost else pairs[0]


def locate(
    problem: Problem,
    index: int,
    chi2_hat: float,
    z_hat_i: float,
    threshold: float,
    side: Sequence[WalkPoint],
    options: FitOptions,
    tolerance: float = 1e-3,
    outermost: bool = False,
    tangent: np.ndarray | None = None,
    located: Located | None = None,
) -> End:
    """Locate the crossing of ``chi2_hat + threshold`` on one side by root-finding on re-fits.

    The function whose root is sought is the signed root ``sqrt(chi2(z) - chi2_hat)`` minus
    ``sqrt(threshold)``, where ``chi2(z)`` re-fits the other parameters with parameter
    ``index`` fixed at ``z``, warm-started on the straight line between the bracketing
    points. When the walk switched valley between them
    (:func:`fmuid.profiling.checks.switches`), a start on that line mixes two valleys and its
    re-fit may land in the higher one: ``chi2(z)`` is then the lower of the re-fits from each
    bracketing point's valley (the profile is the lower envelope of the valleys). Regula falsi
    with the Illinois modification keeps the bracket; the first guess is
    the signed-root interpolation, exact for a parabolic profile, and every guess is confirmed
    by a re-fit. It stops when the next correction is below ``tolerance`` times the
    half-width ``|z - z_hat|``.

    Parameters
    ----------
    problem
        The estimation problem.
    index
        The profiled parameter.
    chi2_hat, z_hat_i
        Chi2 at the optimum and the parameter's estimate in fitted coordinates.
    threshold
        Chi2 rise that bounds the interval.
    side
        Points from the estimate outwards, the estimate first.
    options
        Tolerances of the re-fits.
    tolerance
        Accuracy of the end, as a fraction of the half-width.
    outermost
        Locate the outermost crossing of the walked points rather than the first (a non-smooth
        objective); ``beyond`` tells whether the last good point is back under the threshold.
    tangent
        The path's Gauss-Newton direction at the estimate (:func:`fmuid.profiling.walk.
        path_tangent`): the switch test of the first step.
    located
        The branch's root-findings and confirmations so far (:class:`Located`, added to here).

    Returns
    -------
    End
        With ``z=None`` when ``side`` does not straddle the threshold.

    """
    side = list(side)
    confirms = 0
    located = Located() if located is None else located
    moved = switches(side, index, problem.z_lower, problem.z_upper, tangent)
    while True:
        pair = bracket(side, index, chi2_hat, threshold, outermost)
        if pair is None:
            return End(None, refits=confirms)
        apart = any(side[k] is pair[1] for k in moved)
        key = (threshold, id(pair[0]), id(pair[1]), apart)
        if key not in located.roots:
            located.roots[key] = (
                pair,
                *_root(
                    problem, index, chi2_hat, z_hat_i, threshold, pair, options, tolerance, apart
                ),
            )
        _, end, above = located.roots[key]
        end = replace(end, refits=end.refits + confirms)
        if above or not pair[1].carried:
            break
        if (threshold, id(pair[1])) not in located.confirmed:
            located.confirmed[(threshold, id(pair[1]))] = (
                pair[1],
                confirm(problem, index, pair[1], options, threshold),
            )
            confirms += 1
        confirmed = located.confirmed[(threshold, id(pair[1]))][1]
        if confirmed is not None and confirmed.chi2 - chi2_hat >= threshold:
            break
        k = next(k for k, p in enumerate(side) if p is pair[1])
        side[k] = confirmed or WalkPoint(pair[1].z, float("nan"), "the confirming re-fit failed")
    ok = [p for p in side if p.error is None and np.isfinite(p.chi2)]
    if outermost and ok[-1].chi2 - chi2_hat < threshold:
        return replace(end, beyond=True)
    return end


def confirm(
    problem: Problem,
    index: int,
    point: WalkPoint,
    options: FitOptions,
    threshold: float,
    secant: Secant | None = None,
) -> WalkPoint | None:
    """Re-fit a point afresh from itself (:func:`fresh_refit`): the lower of both points.

    For a point whose chi2 came from the Jacobian carried along the walk (``carried``), before
    a rise it reports over ``threshold`` ends a walk or brackets an end: Gauss-Newton stops
    when its next step would lower chi2 by less than ``CONFIRM_TOL`` of the threshold (a walk
    passes its carried ``secant``, renewed here). ``None`` when the re-fit fails.
    """
    free = np.ones(problem.n_free, bool)
    free[index] = False
    try:
        z, chi2, _ = fresh_refit(
            problem, point.z, free, options, CONFIRM_TOL * threshold, not options.polish, secant
        )
    except FmuidError:
        return None
    return WalkPoint(z, chi2) if chi2 < point.chi2 else replace(point, carried=False)


def _root(
    problem: Problem,
    index: int,
    chi2_hat: float,
    z_hat_i: float,
    threshold: float,
    pair: tuple[WalkPoint, WalkPoint],
    options: FitOptions,
    tolerance: float,
    apart: bool = False,
) -> tuple[End, bool]:
    """Regula falsi (Illinois) on re-fits inside the bracketing ``pair`` (see :func:`locate`).

    ``apart``: the pair lies in two valleys; each guess is re-fitted from both, until the
    lower re-fit replaces the bracket's point of the other valley (the bracket is then one
    valley's). ``MAX_REFITS`` bounds the guesses. Returns the end and whether a re-fit read
    the profile at or over the threshold (otherwise the crossing rests on ``pair[1]`` alone).
    """
    a, b = pair
    target = np.sqrt(threshold)
    free = np.ones(problem.n_free, bool)
    free[index] = False
    za, zb = float(a.z[index]), float(b.z[index])
    fa, fb = rise_root(a.chi2, chi2_hat) - target, rise_root(b.chi2, chi2_hat) - target
    best = b
    guess = _secant(za, fa, zb, fb)
    refits, guesses, last_side = 0, 0, 0
    above = False
    newton = not options.polish
    while guesses < MAX_REFITS:
        if abs(zb - za) <= tolerance * abs(guess - z_hat_i):
            return End(guess, best, refits), above
        w = (guess - za) / (zb - za)
        starts = [a.z.copy(), b.z.copy()] if apart else [(1.0 - w) * a.z + w * b.z]
        fits = []
        for origin, start in enumerate(starts):
            start[index] = guess
            try:
                z, chi2, more = fresh_refit(
                    problem, start, free, options, END_TOL * threshold, newton
                )
            except FmuidError:
                continue
            fits.append((chi2, origin, z, more))
        refits += len(starts)
        guesses += 1
        if not fits:
            return End(guess, best, refits, settled=False), above
        chi2, origin, z, newton = min(fits, key=lambda f: f[0])
        point = WalkPoint(z, chi2)
        fg = rise_root(chi2, chi2_hat) - target
        if abs(fg) <= abs(rise_root(best.chi2, chi2_hat) - target):
            best = point
        above = above or fg >= 0
        apart = apart and origin == (0 if fg < 0 else 1)
        if fg < 0:
            a, za, fa = point, guess, fg
            if last_side < 0:
                fb /= 2.0
            last_side = -1
        else:
            b, zb, fb = point, guess, fg
            if last_side > 0:
                fa /= 2.0
            last_side = 1
        nxt = _secant(za, fa, zb, fb)
        if abs(nxt - guess) <= tolerance * abs(nxt - z_hat_i):
            return End(nxt, best, refits), above
        guess = nxt
    return End(guess, best, refits, settled=False), above


def fresh_refit(
    problem: Problem,
    start: np.ndarray,
    free: np.ndarray,
    options: FitOptions,
    tolerance: float,
    newton: bool,
    secant: Secant | None = None,
) -> tuple[np.ndarray, float, bool]:
    """Re-fit at a guess of the crossing: Gauss-Newton on a fresh Jacobian, else trust-region.

    The Gauss-Newton steps (:func:`fmuid.profiling.quasi.quasi_refit`, when ``newton``) stop
    when the next would lower chi2 by less than ``tolerance``; where they do not settle,
    ``refine`` runs from the lowest point they reached. Returns the point, its chi2 and
    whether Gauss-Newton is worth trying at the next guess of this crossing (not after it
    failed here, nor for polished re-fits: a non-smooth objective, where finite differences
    mislead). ``secant``: the Jacobian carried along a walk, renewed here (a new one by
    default).
    """
    if newton:
        if secant is None:
            secant = Secant(np.zeros((problem.n_data, problem.n_free)), start)
        cheap = quasi_refit(problem, start, free, secant, tolerance, options.diff_step, fresh=True)
        if cheap is not None and cheap[2]:
            return cheap[0], cheap[1], True
        if cheap is not None:
            start = cheap[0]
    z, chi2, _ = refine(problem, start, free=free, options=options)
    return z, chi2, False


def _secant(za: float, fa: float, zb: float, fb: float) -> float:
    """Zero of the straight line through ``(za, fa)`` and ``(zb, fb)`` (with ``fa < 0 <= fb``)."""
    if fb == fa:
        return 0.5 * (za + zb)
    return za - fa * (zb - za) / (fb - fa)
