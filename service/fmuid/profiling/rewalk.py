"""A branch re-walked from a lower valley, and the branch's re-fits made once."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from fmuid.estimation.optimize import FitOptions
from fmuid.estimation.problem import Problem
from fmuid.profiling.checks import refit_from
from fmuid.profiling.points import WalkPoint
from fmuid.profiling.walk import WalkOptions, walk

#: Re-fits of a branch by held value, start and tolerances (see :func:`_refit`).
Memo = dict[tuple[float, bytes, FitOptions], list[WalkPoint]]


def refit_once(
    memo: Memo,
    problem: Problem,
    index: int,
    zi: float,
    start: np.ndarray,
    options: FitOptions,
    known: Sequence[WalkPoint] | None = None,
    tol: float = 0.0,
    near: float = 0.0,
) -> list[WalkPoint]:
    """:func:`fmuid.profiling.checks.refit_from` from one start, made once per branch.

    The same held value, start and tolerances give the same re-fit: a re-walk re-fits each
    point further in from the point after it, and the next round's check of a valley switch
    there re-fits the same point from the same start (a re-fit that ended in a known basin
    stands for the same minimum).
    """
    key = (zi, np.asarray(start, dtype=float).tobytes(), options)
    if key not in memo:
        memo[key] = refit_from(problem, index, zi, [start], options, known, tol, near)
    return memo[key]


def rewalk(
    problem: Problem,
    side: list[WalkPoint],
    lower: WalkPoint,
    chi2_hat: float,
    index: int,
    direction: int,
    threshold: float,
    options: WalkOptions,
    memo: Memo,
) -> tuple[list[WalkPoint], WalkPoint | None]:
    """Re-walk inwards from a lower valley while it stays lower, then walk on outwards."""
    z_hat_i = float(side[0].z[index])
    reach = abs(lower.z[index] - z_hat_i)
    inner = [p for p in side[1:] if abs(p.z[index] - z_hat_i) < reach]
    prev = lower
    tol = options.checks.lower_tol * threshold
    for k in range(len(inner) - 1, -1, -1):
        p = inner[k]
        if not p.ok:
            continue
        [q] = refit_once(memo, problem, index, float(p.z[index]), prev.z, options.refit) or [p]
        if q.chi2 < chi2_hat - options.better_tol * max(1.0, threshold):
            return inner[k:] + [lower], q
        if q.chi2 >= p.chi2 - tol:
            break
        inner[k] = q
        prev = q
    good = [side[0]] + [p for p in inner if p.ok] + [lower]
    step = abs(good[-1].z[index] - good[-2].z[index]) or options.min_step
    more, better = walk(problem, good, chi2_hat, index, direction, threshold, step, options)
    return inner + [lower] + more, better
