"""The fine grid's step, chosen by what it does to chi2, and the check of the step kept.

Effects on the fine grid (:mod:`.augment`) approximate on its step: feedback terms are closed
around the FMU by an explicit coupling (:mod:`fmuid.model.feedback`: second order in the step,
from a linear extrapolation of the terms over the last step), clipping acts at the grid points.
The default step (the median sample interval over :data:`~.augment.FINE`) can be too coarse for
sharp or strong terms: a smooth sign narrower than the rate's change over a step (Coulomb
friction), or a feedback whose own time constant is near the step. A coupling error left in the
fit is enough for a second, spurious effect to absorb.

**The rule** (:func:`settle_step`): a model with fine-grid effects is accepted at a step only
when halving the step moves its chi2 at the fitted values by at most :data:`COUPLING_CHI2`
times the fit's :func:`dispersion`; otherwise the step is halved and the model re-fitted from
its estimates, down to :data:`FINEST` (a later step of the forward selection starts from the
step of the model it augments, so the bound holds for the whole selection). For a second-order
coupling the error of the kept step is then about a third of that change: under a quarter of
what a test of the family can see (a one-parameter likelihood ratio at the 0.5 % level needs
7.9). Halving stops when the change is that small, not when it is zero: below it, the change
is the FMU's own step error and the fit's rounding.

The dispersion (chi2 per degree of freedom, where above 1) is the unit of chi2 a fit can
resolve when the model leaves much of the record unexplained: a textbook model of a real
record, its sigmas the sensors' noise (EMPS: about 10,000 per degree of freedom), reads a
change below one such unit as part of its misfit, not as a coupling error worth a 16-fold
longer simulation. The kept step therefore does not depend on the scale of the sigmas.

At :data:`FINEST` the step stays, whatever the change: :func:`coupling_error` reports what is
left, in sigmas of the predictions, and the verdict warns above one sigma.
"""

from __future__ import annotations

import copy
import logging
from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from fmuid.discrepancy.augment import AugmentedPredictor
from fmuid.discrepancy.effects import Effect
from fmuid.discrepancy.scan import CandidateFit, Scanner
from fmuid.errors import FmuidError
from fmuid.estimation.optimize import FitOptions
from fmuid.estimation.problem import Problem

log = logging.getLogger(__name__)

COUPLING_CHI2 = 1.0
"""Largest change of chi2 at the fitted values, when the step is halved, of a step kept."""

MAX_HALVINGS = 4
"""Halvings of the fine step at most, over every step of the forward selection (the finest
step is the default one over 16: 64 steps per median sample interval)."""

FINEST = 2.0**-MAX_HALVINGS
"""The finest step scale."""


def acts_on_fine_grid(effect: Effect) -> bool:
    """Whether the effect acts on the fine grid (feedback, input effects, output lags)."""
    return effect.side in ("feedback", "input") or effect.effect == "output_lag"


def on_fine_grid(problem: Problem) -> AugmentedPredictor | None:
    """Return the problem's predictor when an effect of it acts on the fine grid, else None."""
    predictor = problem.predictor
    if not isinstance(predictor, AugmentedPredictor):
        return None
    return predictor if any(map(acts_on_fine_grid, predictor.effects)) else None


def at_step(problem: Problem, step_scale: float) -> Problem:
    """Return the problem with its fine step scaled by ``step_scale`` (1: the default step)."""
    predictor = problem.predictor
    assert isinstance(predictor, AugmentedPredictor)
    finer = copy.copy(problem)
    finer.predictor = AugmentedPredictor(predictor.base, predictor.effects, step_scale)
    return finer


def settle_step(scanner: Scanner, fit: CandidateFit, options: FitOptions) -> CandidateFit:
    """Return ``fit`` on the coarsest step that :data:`COUPLING_CHI2` accepts (module docstring).

    ``scanner`` is the model ``fit`` augments; each re-fit starts from the last estimates. A
    simulation or re-fit that fails keeps the last fit (its step is then reported by
    :func:`coupling_error`).
    """
    while True:
        predictor = on_fine_grid(fit.problem)
        if predictor is None or predictor.step_scale <= FINEST:
            return fit
        finer = at_step(fit.problem, predictor.step_scale / 2)
        try:
            moved = abs(finer.chi2(fit.z) - fit.chi2)
        except FmuidError as exc:
            log.info("%s: halved step not simulated (%s)", fit.candidate.label, exc)
            return fit
        if moved <= COUPLING_CHI2 * dispersion(fit):
            return fit
        log.info(
            "%s: halving the fine step moves chi2 by %.3g; step scale %g -> %g",
            fit.candidate.label,
            moved,
            predictor.step_scale,
            predictor.step_scale / 2,
        )
        refitted = scanner.fit(replace(fit, problem=finer, fitted=False), options)
        if not refitted.fitted:
            return fit
        fit = refitted


def dispersion(fit: CandidateFit) -> float:
    """Return the fit's chi2 per degree of freedom where above 1, else 1 (module docstring)."""
    dof = max(fit.problem.n_data - fit.problem.n_free, 1)
    return max(fit.chi2 / dof, 1.0)


def step_scale(problem: Problem) -> float:
    """Return the problem's fine step over the default one (1 without fine-grid effects)."""
    predictor = problem.predictor
    return predictor.step_scale if isinstance(predictor, AugmentedPredictor) else 1.0


def coupling_error(problem: Problem, values: Mapping[str, float]) -> float | None:
    """Largest change, in sigmas, of the fit's predictions when the fine step is halved.

    None when the model has no effect that acts on a fine grid (nothing to check).
    """
    predictor = on_fine_grid(problem)
    if predictor is None:
        return None
    half = at_step(problem, predictor.step_scale / 2).predictor
    worst = 0.0
    for i, exp in enumerate(problem.experiments):
        a = problem.simulate(dict(values), exp)
        b = problem.simulate(dict(values), exp, predictor=half)
        for j, o in enumerate(problem.outputs):
            mask = problem.masks[i][j]
            if mask.any():
                sigma = problem.sigma[i][o][mask]
                worst = max(worst, float(np.max(np.abs(a[mask, j] - b[mask, j]) / sigma)))
    return worst
