"""One branch settled: walk, exact ends, right-valley checks and re-walks from a lower valley."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np

from fmuid.engine.count import counting
from fmuid.estimation.problem import Problem
from fmuid.profiling.checks import (
    basins,
    bound_flips,
    diverse_starts,
    flip_starts,
    jumps,
    refit_from,
    same_basin,
    switches,
)
from fmuid.profiling.ends import End, Located, locate
from fmuid.profiling.points import WalkPoint, lower_envelope
from fmuid.profiling.result import ProfileQuality
from fmuid.profiling.rewalk import Memo, refit_once, rewalk
from fmuid.profiling.walk import WalkOptions, first_step, path_tangent, walk


@dataclass(frozen=True)
class BranchResult:
    """The points of one branch, from the estimate outwards (estimate not included).

    ``ends`` maps ``"pointwise"`` and ``"simultaneous"`` to the located crossings; ``better``
    is a point below the optimum when one was met (the branch stops there); ``minima`` are
    the minima its checks' re-fits reached (parameter ``index`` held at a check's site).
    """

    index: int
    direction: int
    points: list[WalkPoint]
    better: WalkPoint | None
    ends: dict[str, End] = field(default_factory=dict)
    quality: ProfileQuality = ProfileQuality()
    minima: tuple[WalkPoint, ...] = ()


@dataclass
class _Counts:
    checks: int = 0
    starts: int = 0
    jumps: int = 0
    lower: int = 0
    rewalks: int = 0
    unsettled: list[str] = field(default_factory=list)
    check_sims: int = 0


def settle_branch(
    problem: Problem,
    z_hat: np.ndarray,
    chi2_hat: float,
    index: int,
    direction: int,
    thresholds: dict[str, float],
    sd_z: float,
    options: WalkOptions,
    valleys: Sequence[np.ndarray] = (),
    thorough: bool = False,
    seed: int = 0,
    on_point: Callable[[int], None] | None = None,
    jacobian: np.ndarray | None = None,
) -> BranchResult:
    """Walk one branch, locate its CI ends exactly and check that it follows the lowest valley.

    After the walk, each threshold's crossing is located by root-finding on re-fits
    (:func:`fmuid.profiling.ends.locate`). At each end and at each jump of the profile the
    other parameters are re-fitted from the other ``valleys`` of the fit check and, where the
    profile jumps or bends, the Fisher deviation is infinite, an end's bound flip (below)
    reached another minimum than the walked one, or ``thorough`` is set, from diverse starts:
    seeded Latin-hypercube points at the first such site, and at later
    sites the distinct basins those starts reached (:func:`fmuid.profiling.checks.basins`),
    moved to the site. An end where other parameters sit on a bound (there or at a point of the
    walk) is re-fitted once more per such parameter, from the end with it moved to its other bound
    (:func:`fmuid.profiling.checks.bound_flips`): the valley on the other side of that bound
    is found by the profile's shape, not by the diverse starts' luck. A flip starts from the
    minimum an earlier flip of the same parameter to the same bound reached at another end of
    the branch (in any round) where that left the walked valley
    (:func:`fmuid.profiling.checks.flip_starts`). A check's re-fit that
    enters the basin of a minimum it already knows (the checked point, the check's earlier
    re-fits) ends there (:func:`fmuid.profiling.checks.refit_from`). A lower chi2 there means
    the walk followed a higher valley: the stretch towards the estimate is re-walked from the
    lower valley, the walk goes on outwards from it, the branch keeps the lower envelope of the
    re-walk and the walk before it (:func:`fmuid.profiling.points.lower_envelope`), and the
    ends are located again (brackets the re-walk left as they were are not located again:
    :class:`fmuid.profiling.ends.Located`).

    Parameters
    ----------
    problem
        The estimation problem.
    z_hat, chi2_hat
        The optimum in fitted coordinates and its chi2.
    index, direction
        Which parameter, and which way.
    thresholds
        ``"simultaneous"`` (required: the walk's stop) and optionally ``"pointwise"``.
    sd_z
        Quadratic (Fisher) standard deviation in fitted coordinates (may be inf).
    options
        Walk and check settings.
    valleys
        Other minima (all parameters, fitted coordinates) found by the fit check.
    thorough
        Check every end from diverse starts (the FMU's objective is non-smooth).
    seed
        Seed of the diverse starts.
    on_point
        Called with the number of walk points done after each point.
    jacobian
        Weighted residual Jacobian at the optimum: the walk's warm starts and cheap re-fits.

    Returns
    -------
    BranchResult

    """
    thr = thresholds["simultaneous"]
    span = float(problem.z_upper[index] - problem.z_lower[index])
    estimate = WalkPoint(z_hat.copy(), chi2_hat)
    points, better = walk(
        problem,
        [estimate],
        chi2_hat,
        index,
        direction,
        thr,
        first_step(sd_z, thr, span, options),
        options,
        on_point,
        jacobian,
    )
    counts = _Counts()
    ends: dict[str, End] = {}
    known: list[WalkPoint] = []
    fresh = True
    checks = options.checks
    tangent = None if jacobian is None else path_tangent(jacobian, index)
    located = Located()
    behind: dict[tuple[int, float], WalkPoint] = {}
    minima: list[WalkPoint] = []
    memo: Memo = {}

    def end_of(kind: str, side: list[WalkPoint]) -> End:
        if kind not in ends:
            ends[kind] = locate(
                problem,
                index,
                chi2_hat,
                float(z_hat[index]),
                thresholds[kind],
                side,
                options.refit,
                options.end_tolerance,
                outermost=options.overshoot > 0,
                tangent=tangent,
                located=located,
            )
        return ends[kind]

    side = [estimate] + points
    for round_ in range(checks.max_rewalks + 1):
        if better is not None:
            break
        side = [estimate] + points
        ends.clear()
        kinks = switches(side, index, problem.z_lower, problem.z_upper, tangent)
        bends = jumps(side, index, chi2_hat, thr)
        counts.jumps = max(counts.jumps, len(kinks) + len(bends))
        sites = _sites(
            problem,
            index,
            side,
            (kinks, bends),
            end_of,
            thresholds,
            sd_z,
            thorough or checks.always,
        )
        lower = None
        for site, diverse, near, why in sites:
            bound = why == "end" and bool(near)
            starts = (
                flip_starts(near, site.z, behind) if bound else [(None, start) for start in near]
            )
            if not valleys and not diverse and not starts:
                continue
            zi = float(site.z[index])
            settled = [] if site.carried else [site]
            tol = checks.lower_tol * thr
            with counting() as checked:
                found = refit_from(
                    problem, index, zi, valleys, checks.refit, settled, tol, checks.near
                )
                reached = False
                for key, start in starts:
                    got = refit_once(
                        memo,
                        problem,
                        index,
                        zi,
                        start,
                        checks.refit,
                        [*settled, *found],
                        tol,
                        checks.near,
                    )
                    found += got
                    back = not got or same_basin(problem, got[0].z, site.z)
                    reached = reached or (bound and not back)
                    if key is not None and got and not back:
                        behind[key] = got[0]
                others: list[np.ndarray] = []
                if diverse or reached:
                    others = (
                        list(diverse_starts(problem, checks.end_starts, (seed, index, round_)))
                        if fresh
                        else [p.z for p in known]
                    )
                    fresh = False
                from_others = refit_from(
                    problem, index, zi, others, checks.refit, [*settled, *found], tol, checks.near
                )
                if others:
                    known = basins(problem, from_others, [site, *found], checks.end_starts)
            found = found + from_others
            minima += [p for p in found if p is not site]
            counts.check_sims += checked.simulations
            counts.checks += 1
            counts.starts += len(valleys) + len(others) + len(starts)
            if not found:
                continue
            best = min(found, key=lambda p: p.chi2)
            if best.chi2 < chi2_hat - options.better_tol * max(1.0, thr):
                better = best
                break
            if best.chi2 < site.chi2 - checks.lower_tol * thr:
                lower = best
                break
        if better is not None or lower is None:
            break
        counts.lower += 1
        if round_ == checks.max_rewalks:
            counts.unsettled.append("a lower valley was still found after the last re-walk")
            break
        counts.rewalks += 1
        points, better = rewalk(
            problem, side, lower, chi2_hat, index, direction, thr, options, memo
        )
        points = lower_envelope(
            points, side[1:], index, float(z_hat[index]), checks.lower_tol * thr
        )
    if better is None or ends:  # as when the ends were located before the round's checks
        for kind in thresholds:
            end_of(kind, side)
    for kind, end in ends.items():
        if not end.settled:
            counts.unsettled.append(f"the {kind} end was not located to the tolerance")
        if end.beyond:
            counts.unsettled.append(
                f"the profile is back under the {kind} threshold where the walk ended, beyond "
                "its outermost crossing: the end may lie further out"
            )
    quality = ProfileQuality(
        checks=counts.checks,
        starts=counts.starts,
        jumps=counts.jumps,
        lower_valleys=counts.lower,
        rewalks=counts.rewalks,
        end_refits=sum(e.refits for e in ends.values()),
        unsettled=tuple(counts.unsettled),
        check_simulations=counts.check_sims,
    )
    return BranchResult(index, direction, points, better, ends, quality, tuple(minima))


def _sites(
    problem: Problem,
    index: int,
    side: list[WalkPoint],
    marks: tuple[list[int], list[int]],
    end_of: Callable[[str, list[WalkPoint]], End],
    thresholds: dict[str, float],
    sd_z: float,
    thorough: bool,
) -> Iterator[tuple[WalkPoint, bool, list[np.ndarray], str]]:
    """Points to check: ``(point, with diverse starts, neighbours' starts, why)``.

    ``marks`` are the positions in ``side`` after a switch of valley
    (:func:`fmuid.profiling.checks.switches`) and where the chi2 path jumps or bends
    (:func:`fmuid.profiling.checks.jumps`). The diverse starts are marked where the chi2 path
    jumps or bends, the Fisher deviation is infinite or ``thorough`` is set; at an end with
    bound flips the caller adds them when a flip reached another minimum (a second valley on
    the far side of the bound).

    First the point before each switch of valley, re-fitted from the valley the walk switched
    to (one re-fit from a nearby minimum; the point after it needs none: its re-fit started
    from the old valley and descended out of it); then the outermost end, the other end and the
    jumps of the chi2 path. An end is located (``end_of``) only when its turn comes: a check
    before it that finds a lower valley re-walks the branch, and the ends are located on the
    re-walked one. An end where other parameters sit on a bound (there or at a point of the
    walk) is also re-fitted once per such parameter with it moved to its other bound
    (:func:`fmuid.profiling.checks.bound_flips`, :func:`fmuid.profiling.checks.flip_starts`).
    """
    kinks, bends = marks
    for k in kinks:
        before = max(j for j in range(k) if side[j].ok)
        yield side[before], False, [side[k].z], "switch"
    diverse = thorough or not np.isfinite(sd_z) or bool(bends)
    path = [p.z for p in side if p.ok]
    for kind in ("simultaneous", "pointwise"):
        if kind not in thresholds:
            continue
        end = end_of(kind, side)
        if end.point is None or end.z is None:
            continue
        yield end.point, diverse, bound_flips(problem, end.point.z, index, path), "end"
    for k in bends:
        yield side[k], True, [], "jump"


@dataclass(frozen=True)
class BranchTask:
    """Everything a worker needs to walk one branch: a task of :mod:`fmuid.engine`."""

    problem: Problem
    z_hat: np.ndarray
    chi2_hat: float
    index: int
    direction: int
    threshold: float
    sd_z: float
    options: WalkOptions
    pointwise: float | None = None
    valleys: tuple[np.ndarray, ...] = ()
    thorough: bool = False
    seed: int = 0
    jacobian: np.ndarray | None = None

    def execute(self, report: Callable[[int], None]) -> BranchResult:
        """Walk and settle the branch, calling ``report`` with the walk points done."""
        thresholds = {"simultaneous": self.threshold}
        if self.pointwise is not None:
            thresholds["pointwise"] = self.pointwise
        return settle_branch(
            self.problem,
            self.z_hat,
            self.chi2_hat,
            self.index,
            self.direction,
            thresholds,
            self.sd_z,
            self.options,
            valleys=self.valleys,
            thorough=self.thorough,
            seed=self.seed,
            on_point=report,
            jacobian=self.jacobian,
        )
