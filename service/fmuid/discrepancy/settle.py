"""Settle a tie: the feasible test that best tells the named effect from an equally good one.

When the data cannot tell two candidates apart, each fitted candidate becomes a hypothesis of
:mod:`fmuid.experiment_design.discriminate` (its augmented parameters, its fitted values, its
effects) and the tests of :func:`fmuid.experiment_design.discriminate.default_space` (steps, chirps
and multisines like the study's data: its input amplitude, longest record, rate and noise) are
searched for the one whose expected likelihood-ratio statistic between the two is largest.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

from scipy import stats

from fmuid.discrepancy.augment import AugmentedPredictor
from fmuid.discrepancy.decide import Tie
from fmuid.discrepancy.scan import CandidateFit
from fmuid.errors import FmuidError
from fmuid.estimation.optimize import Mapper
from fmuid.estimation.problem import Problem
from fmuid.experiment_design.discriminate import (
    Discrimination,
    Hypothesis,
    default_space,
    discriminating_experiments,
)

log = logging.getLogger(__name__)

SETTLES = 1e-3
"""A proposed test settles a tie when its expected likelihood-ratio statistic (1 df) has a
p-value below this level."""

MAX_TIES = 2
"""Ties searched (the strongest first); each search is a screen plus a few full fits."""

CONFIRM_BELOW = 4.0
"""The screen's best tests are confirmed by full fits only when the linearised separation is
at least the settling level's chi2 (10.8) over this factor: a linearised estimate four times
too small to settle the tie does not pay for the full fits."""

CANDIDATES = 2
"""Tests sampled per input family (step, chirp, multisine) for each tie: the screen's cost
(about 2 (n + 2) simulations per test, the named candidate's share computed once for all
ties) stays a fraction of the diagnosis."""


def hypothesis(fit: CandidateFit, name: str | None = None) -> Hypothesis:
    """Return a fitted candidate as a hypothesis: its parameters, fitted values and effects.

    ``name`` defaults to the candidate's effect.
    """
    problem = fit.problem
    predictor = problem.predictor
    effects = predictor.effects if isinstance(predictor, AugmentedPredictor) else ()
    return Hypothesis(
        name=name or fit.candidate.effect,
        parameters=dict(problem.parameter_specs),
        values=problem.from_z(fit.z),
        effects=tuple(effects),
    )


def settling_tests(
    problem: Problem, named: CandidateFit, ties: Sequence[Tie], mapper: Mapper | None = None
) -> list[Discrimination]:
    """Return, per tie (the first :data:`MAX_TIES`), the test that best separates it.

    Parameters
    ----------
    problem
        The base study (its data set the space of tests).
    named
        The named candidate's fit.
    ties
        Candidates the data cannot tell from it, strongest first.
    mapper
        Runs the tests' screens and fits side by side (the diagnosis's task engine; default:
        this process).

    Returns
    -------
    list of Discrimination
        One per tie searched, in the order of ``ties``.

    """
    space = default_space(problem).model_copy(update={"candidates": CANDIDATES})
    fits = [named, *(t.fit for t in ties[:MAX_TIES])]
    a, *others = (hypothesis(f, name) for f, name in zip(fits, hypothesis_names(fits), strict=True))
    floor = float(stats.chi2.isf(SETTLES, 1)) / CONFIRM_BELOW
    return discriminating_experiments(
        problem.fmu_path, problem.spec, space, a, others, confirm_from=floor, mapper=mapper
    )


def settling_or_reason(
    problem: Problem, named: CandidateFit, ties: Sequence[Tie], mapper: Mapper | None = None
) -> tuple[list[Discrimination], str]:
    """Return :func:`settling_tests`, or none and the verdict's sentence when the search failed.

    The search is a proposal on top of a finished diagnosis: a test space the data cannot
    support or an FMU that fails on a proposed input costs the proposal, not the diagnosis.
    """
    if not ties:
        return [], ""
    try:
        return settling_tests(problem, named, ties, mapper), ""
    except FmuidError as exc:
        log.warning("no test proposed to settle the tie: %s", exc)
        return [], f" No test to settle the tie was searched: {exc}."


def hypothesis_names(fits: Sequence[CandidateFit]) -> list[str]:
    """Effect names, with the added parameter where two fits share an effect (a bias per output)."""
    effects = [f.candidate.effect for f in fits]
    return [
        f"{e} ({f.candidate.parameters[0].name})" if effects.count(e) > 1 else e
        for e, f in zip(effects, fits, strict=True)
    ]


def settles(found: Discrimination) -> bool:
    """Whether the expected likelihood-ratio statistic is significant at :data:`SETTLES`."""
    return float(stats.chi2.sf(found.expected_chi2, 1)) < SETTLES
