"""Refits of the optimum a profile walks from: once before the walks, and at a restart."""

from __future__ import annotations

import logging
import time

import numpy as np

from fmuid.engine.count import counting
from fmuid.estimation.optimize import FitOptions, jacobian, make_fit_result, refine
from fmuid.estimation.problem import Problem
from fmuid.estimation.result import Cost, FitResult

log = logging.getLogger(__name__)


def descend(problem: Problem, fit: FitResult, settle: FitOptions) -> FitResult:
    """Refine a fit of a non-smooth objective once before the walks; keep the lower.

    A trust region on a non-smooth chi2 (a clip, an event, a switch) stops short of the
    minimum, by a few units of chi2 on a threshold's level; the walks' re-fits would then
    find chi2 below the optimum at their first points and restart every profile, up to
    :data:`~fmuid.profiling.engine.MAX_RESTARTS` times, each as costly as the first. One
    re-fit at the raised difference step, polished by Powell's method (``settle``), costs a
    fraction of a round.
    """
    refitted = refit_optimum(problem, fit.z_estimate(), fit, settle)
    if refitted.chi2 >= fit.chi2:
        return fit
    log.info(
        "non-smooth objective: the fit refined from chi2 %.6g to %.6g", fit.chi2, refitted.chi2
    )
    return refitted


def refit_optimum(problem: Problem, z0: np.ndarray, fit: FitResult, walk: FitOptions) -> FitResult:
    """Refine from ``z0`` at ``walk``'s difference step (polished where ``walk`` says so)."""
    t_refit = time.perf_counter()
    with counting() as count:
        options = FitOptions(polish=walk.polish, diff_step=walk.diff_step)
        z, chi2, message = refine(problem, z0, options=options)
        jac = jacobian(problem, z)
    cost = Cost(count.simulations, time.perf_counter() - t_refit)
    return make_fit_result(problem, z, chi2, jac, message, fit.global_search, cost)
