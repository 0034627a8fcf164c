"""The branches checked against each other: a point of one profile proves another's end short.

Every point a branch evaluated (its walk, its located ends, the minima its checks reached) is a
feasible point of the whole problem with a known chi2, so it bounds every other parameter's
profile from above at its own value of that parameter. A point beyond a branch's CI end (further
from the estimate along the branch's parameter) with a chi2 under that end's threshold proves
the profile under the threshold there: the walk followed a higher valley at its end, or the
profile dips under the threshold again beyond a first crossing. A re-fit at the end from that
point (:func:`fmuid.profiling.checks.refit_from`) tells the two apart: when it comes out lower
than the end, the branch is settled again with it as one more valley to start its checks from
(the checks then re-walk from the lower valley as for any valley they find). No simulation is
made when no point lies beyond an end.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from fmuid.engine.count import counting
from fmuid.estimation.problem import Problem
from fmuid.estimation.schema import Written
from fmuid.profiling.branch import BranchResult
from fmuid.profiling.checks import refit_from
from fmuid.profiling.points import WalkPoint
from fmuid.profiling.schema import CrossCheckOut
from fmuid.profiling.walk import WalkOptions

log = logging.getLogger(__name__)

#: Re-fits at one end, from the lowest points beyond it and the farthest one.
PROBES = 2


@dataclass
class CrossRecord(Written):
    """What the cross-check did: ends with points beyond them, re-fits, branches settled again.

    ``to_dict`` writes :class:`~fmuid.profiling.schema.CrossCheckOut` (``checks.cross``).
    """

    schema = CrossCheckOut

    ends: int = 0
    probes: int = 0
    resettled: int = 0
    simulations: int = 0


def beyond_end(
    branches: Sequence[BranchResult],
    branch: BranchResult,
    kind: str,
    chi2_hat: float,
    threshold: float,
    tol: float,
) -> list[WalkPoint]:
    """Points of the other parameters' branches beyond ``branch``'s ``kind`` end, under it.

    Beyond: further from the estimate along ``branch``'s parameter than the end; under: a chi2
    below ``chi2_hat + threshold - tol``. Empty for an open end.
    """
    end = branch.ends.get(kind)
    if end is None or end.z is None:
        return []
    i, d = branch.index, branch.direction
    level = chi2_hat + threshold - tol
    return [
        p
        for other in branches
        if other.index != i
        for p in _evaluated(other)
        if p.ok and (p.z[i] - end.z) * d > 0 and p.chi2 < level
    ]


def cross_check(
    problem: Problem,
    branches: list[BranchResult],
    chi2_hat: float,
    thresholds: dict[str, float],
    options: WalkOptions,
    settle: Callable[..., list[BranchResult]],
    record: CrossRecord,
) -> list[BranchResult]:
    """Return ``branches`` with those another branch proved short settled again.

    ``settle(again=...)`` walks the given branches (``(index, direction)`` -> a point) again
    with the point as one more valley, returning them in any order. ``record`` is updated.
    """
    tol = options.checks.lower_tol * thresholds["simultaneous"]
    redo: dict[tuple[int, int], np.ndarray] = {}
    with counting() as spent:
        for branch in branches:
            for kind in ("simultaneous", "pointwise"):
                if kind not in thresholds or (branch.index, branch.direction) in redo:
                    continue
                beyond = beyond_end(branches, branch, kind, chi2_hat, thresholds[kind], tol)
                if not beyond:
                    continue
                end = branch.ends[kind]
                assert end.z is not None and end.point is not None
                record.ends += 1
                i = branch.index
                starts = sorted(beyond, key=lambda p: p.chi2)[:PROBES]
                far = max(beyond, key=lambda p: abs(p.z[i] - end.z))  # type: ignore[operator]
                if all(p is not far for p in starts):
                    starts[-1] = far
                record.probes += len(starts)
                got = refit_from(
                    problem, i, end.z, [p.z for p in starts], options.checks.refit, [end.point], tol
                )
                lower = [p for p in got if p.chi2 < end.point.chi2 - tol]
                if lower:
                    redo[(i, branch.direction)] = min(lower, key=lambda p: p.chi2).z
    record.simulations += spent.simulations
    if not redo:
        return branches
    log.info(
        "points of other profiles lie under the threshold beyond %d branch end(s): "
        "settling %s again",
        len(redo),
        sorted(redo),
    )
    record.resettled += len(redo)
    again = {(b.index, b.direction): b for b in settle(again=redo)}
    return [again.get((b.index, b.direction), b) for b in branches]


def _evaluated(branch: BranchResult) -> list[WalkPoint]:
    """Return the points a branch evaluated: its walk, located ends and checks' minima."""
    ends = [e.point for e in branch.ends.values() if e.point is not None]
    return [*branch.points, *ends, *branch.minima]
