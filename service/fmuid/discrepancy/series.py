"""What the diagnosis figures draw: model outputs and weighted residuals before and after.

The figures only draw (:mod:`fmuid.plots.diagnosis`); this stage simulates the base and the
augmented model at the diagnosis' parameter values once and hands the series over.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fmuid.discrepancy.augment import FINE
from fmuid.discrepancy.catalogue import study_catalogue
from fmuid.discrepancy.locate import residual_series
from fmuid.discrepancy.residual_tests import Series
from fmuid.discrepancy.result import Diagnosis
from fmuid.discrepancy.scan import augmented
from fmuid.estimation.problem import Problem


@dataclass(frozen=True)
class DiagnosisSeries:
    """Model outputs and weighted residuals of a diagnosis, before and after the augmentation.

    Attributes
    ----------
    problem
        The base problem (its data, masks, experiments, outputs and units).
    before, after
        Model outputs at every row of every experiment, by output name.
    residuals_before, residuals_after
        Weighted residual series per experiment and output.

    """

    problem: Problem
    before: list[dict[str, np.ndarray]]
    after: list[dict[str, np.ndarray]]
    residuals_before: list[Series]
    residuals_after: list[Series]


def augmented_problem_of(problem: Problem, diagnosis: Diagnosis) -> Problem:
    """Rebuild the augmented problem of a diagnosis (the base problem if nothing was added).

    Parameters
    ----------
    problem
        The base problem that was diagnosed.
    diagnosis
        Its diagnosis; the candidates whose parameters it added are switched on, on the fine
        step the diagnosis settled on.
    """
    if not diagnosis.added_parameters:
        return problem
    cands = study_catalogue(problem, diagnosis.parameters_before)
    added = set(diagnosis.added_parameters)
    chosen = [c for c in cands if set(c.names) <= added]
    fine = [s.steps_per_sample for s in diagnosis.effects if s.steps_per_sample]
    return augmented(problem, chosen, FINE / fine[-1] if fine else None)


def diagnosis_series(
    diagnosis: Diagnosis, problem_before: Problem, problem_after: Problem | None = None
) -> DiagnosisSeries:
    """Simulate what the diagnosis figures draw.

    Parameters
    ----------
    diagnosis
        The result of ``fmuid.diagnose``.
    problem_before
        The base problem (spec's free parameters).
    problem_after
        The augmented problem; rebuilt from the diagnosis when ``None``.
    """
    after = problem_after or augmented_problem_of(problem_before, diagnosis)
    before_values = {n: diagnosis.parameters_before[n] for n in problem_before.names}
    after_values = {n: diagnosis.parameters_after[n] for n in after.names}
    y_before, y_after = problem_before.predict(before_values), after.predict(after_values)
    return DiagnosisSeries(
        problem_before,
        y_before,
        y_after,
        residual_series(problem_before, before_values, y_before),
        residual_series(after, after_values, y_after),
    )
