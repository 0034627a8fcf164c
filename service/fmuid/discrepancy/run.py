"""The state of one diagnosis and its scan rounds: options, progress, the cost of each stage."""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from fmuid.discrepancy import decide
from fmuid.discrepancy.effects import Effect
from fmuid.discrepancy.knowledge import AddedParameter
from fmuid.discrepancy.result import AddedEstimate, CandidateScore, StageCost
from fmuid.discrepancy.scan import CandidateFit, Mapper, Scanner, scan, serial
from fmuid.engine.count import Count, counting
from fmuid.estimation.optimize import jacobian, make_fit_result, refine
from fmuid.estimation.problem import Problem
from fmuid.estimation.result import Cost, FitResult
from fmuid.profiling.engine import profile_problem
from fmuid.profiling.result import ProfileResult
from fmuid.progress import Progress, ProgressCallback

if TYPE_CHECKING:
    from fmuid.discrepancy.engine import DiagnoseOptions

log = logging.getLogger(__name__)


def fit_of(problem: Problem, z: np.ndarray, chi2: float) -> FitResult:
    """Return a fit result at ``z`` (its Jacobian computed here, its cost)."""
    t0 = time.perf_counter()
    with counting() as count:
        jac = jacobian(problem, z)
    cost = Cost(count.simulations, time.perf_counter() - t0)
    return make_fit_result(problem, z, chi2, jac, "", False, cost)


def score(f: CandidateFit, p_adjusted: float) -> CandidateScore:
    """Return a scored candidate's summary for the result."""
    return CandidateScore(
        effect=f.candidate.effect,
        parameters=f.values,
        chi2=f.chi2,
        p_value=f.p_value,
        bic=f.bic,
        stage=f.stage,
        statistic=f.statistic,
        p_adjusted=p_adjusted,
        fitted=f.fitted,
    )


def added_estimates(
    prof: ProfileResult, added: Sequence[AddedParameter], confidence: float
) -> dict[str, AddedEstimate]:
    """Estimates, intervals and off-value checks of the added parameters from their profiles."""
    return {
        p.name: AddedEstimate.of(
            prof.fit.estimates[p.name], p, prof.parameters[p.name].ci_pointwise, confidence
        )
        for p in added
    }


class Run:
    """State of one diagnosis: the problem, options, progress and the cost of each stage.

    ``count`` is open around the whole diagnosis (:func:`fmuid.engine.count.counting`): it
    counts what this process simulates and the counts of the tasks run elsewhere. ``mapper``
    and ``executor``: the ``map`` of the diagnosis's task engine and the engine itself, which
    the profiles run their branches on (:func:`fmuid.discrepancy.tasks.candidate_pool`).
    """

    def __init__(
        self,
        problem: Problem,
        opts: DiagnoseOptions,
        progress: ProgressCallback | None,
        count: Count,
        mapper: Mapper = serial,
        executor: Any = None,
    ):
        self.problem = problem
        self.mapper = mapper
        self.executor = executor
        self.opts = opts
        self.progress = progress
        self.count = count
        self._t_lap = time.perf_counter()
        self._sims_lap = count.simulations
        self.stages: list[StageCost] = []
        self.done = 0
        self.total = 1

    def lap(self, stage: str) -> None:
        """Close ``stage``: what was spent since the previous stage closed (or the start)."""
        now, sims = time.perf_counter(), self.count.simulations
        self.stages.append(StageCost(stage, sims - self._sims_lap, now - self._t_lap))
        self._t_lap, self._sims_lap = now, sims

    def report(self, detail: str) -> None:
        """Count a stage done and tell the progress callback."""
        self.done += 1
        if self.progress:
            self.progress(Progress("diagnose", self.done, max(self.total, self.done), detail))

    def scan_round(
        self, scanner: Scanner, pool: list[Effect], stage: int
    ) -> tuple[list[CandidateFit], list[float]]:
        """Scan a pool of candidates on a scanner; return the fits and min-P adjusted p."""

        def seen(f: CandidateFit) -> None:
            self.report(f"round {stage}: {f.candidate.label} chi2 {f.chi2:.4g}")

        fits = scan(
            scanner,
            pool,
            screen_level=self.opts.screen_level,
            min_fits=self.opts.min_fits,
            options=self.opts.fit,
            stage=stage,
            on_candidate=seen,
            mapper=self.mapper,
        )
        own, adjusted = decide.calibrate(fits, self.problem.spec.seed + stage)
        return [replace(f, p_value=p) for f, p in zip(fits, own)], adjusted

    def finish(self, stage: str) -> tuple[Cost, tuple[StageCost, ...]]:
        """Close the last stage; return the total cost and the stages' (they sum to it)."""
        self.lap(stage)
        sims = sum(s.simulations for s in self.stages)
        return Cost(sims, sum(s.seconds for s in self.stages)), tuple(self.stages)


def tie_intervals(run: Run, tie: CandidateFit) -> dict[str, object]:
    """Profile-likelihood intervals of an equally good candidate's added parameters."""
    tie_fit = fit_of(tie.problem, tie.z, tie.chi2)
    prof = profile_problem(
        tie.problem,
        tie_fit,
        only=list(tie.candidate.names),
        workers=run.opts.workers,
        executor=run.executor,
        options=run.opts.walk,
        confidence=run.opts.ci_confidence,
    )
    estimates = added_estimates(prof, tie.candidate.parameters, run.opts.ci_confidence)
    return {name: e.to_dict() for name, e in estimates.items()}


def recheck_base(run: Run, fit: FitResult, best: CandidateFit) -> FitResult | None:
    """Re-fit the base model from the best candidate's base parameters; a lower chi2 wins."""
    names = run.problem.names
    start = run.problem.to_z({n: best.problem.from_z(best.z)[n] for n in names})
    z, chi2, _ = refine(run.problem, start, options=run.opts.fit)
    if chi2 < fit.chi2 - 1e-6 * max(1.0, fit.chi2):
        log.info("base fit improved from %.6g to %.6g by a candidate's start", fit.chi2, chi2)
        return fit_of(run.problem, z, chi2)
    return None


def scan_base(
    run: Run, fit: FitResult, cands: list[Effect]
) -> tuple[FitResult, Scanner, list[CandidateFit], list[float]]:
    """Scan the catalogue on the base fit (once more if a candidate revealed a better base)."""
    for _ in range(2):
        scanner = Scanner(run.problem, fit.z_estimate(), fit.jacobian)
        fits, adjusted = run.scan_round(scanner, cands, 1)
        best = fits[0]
        if not best.fitted or best.p_value >= run.opts.screen_level:
            break
        better = recheck_base(run, fit, best)
        if better is None:
            break
        fit = better
    return fit, scanner, fits, adjusted
