"""Forward selection: add effects one at a time while the scan on top of the model finds one.

Round 1 scans the catalogue on the base fit (:mod:`.scan`). When its best candidate is
significant after the round's min-P adjustment at the family-wise level, it is added; while
the augmented model's residuals still fail a test, the remaining candidates are scanned on top
of it (round 2), and so on up to :data:`MAX_EFFECTS`. Each round is one test at the same
level, so a false addition at any step has probability at most that level. After the second
addition, the first is dropped when the second alone explains the data as well (its chi2 drop
over the second alone is not significant): the first effect was standing in for the second.
An accepted fit is first moved to a fine step its chi2 no longer feels (:mod:`.coupling`), so
that the next round does not read the coupling's error as an effect.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

from fmuid.discrepancy.augment import FINE
from fmuid.discrepancy.coupling import acts_on_fine_grid, settle_step, step_scale
from fmuid.discrepancy.effects import Effect
from fmuid.discrepancy.result import AddedEstimate, EffectStep
from fmuid.discrepancy.scan import CandidateFit, Scanner
from fmuid.estimation.optimize import FitOptions, jacobian

MAX_EFFECTS = 3
"""Effects added at most (real recordings carry more than one: an offset and a spring)."""


@dataclass(frozen=True)
class Step:
    """One accepted effect.

    Attributes
    ----------
    fit
        The augmented model with this and every earlier effect, fitted.
    chi2_before
        Chi2 of the model it was added to.
    p_adjusted
        Its p-value adjusted for the round's scan (min-P).

    """

    fit: CandidateFit
    chi2_before: float
    p_adjusted: float

    @property
    def effect(self) -> Effect:
        """The effect added at this step."""
        return self.fit.candidate

    @property
    def drop(self) -> float:
        """Chi2 drop of this step."""
        return max(self.chi2_before - self.fit.chi2, 0.0)


Round = Callable[[Scanner, list[Effect], int], tuple[list[CandidateFit], list[float]]]


def _scanner(fit: CandidateFit) -> Scanner:
    return Scanner(fit.problem, fit.z, jacobian(fit.problem, fit.z))


def _fitted(scanner: Scanner, f: CandidateFit, options: FitOptions) -> CandidateFit:
    """Fit the candidate fully, on a fine step its chi2 no longer feels (:mod:`.coupling`)."""
    return settle_step(scanner, f if f.fitted else scanner.fit(f, options), options)


def forward(
    scanner: Scanner,
    first: tuple[list[CandidateFit], list[float]],
    pool: Sequence[Effect],
    scan_round: Round,
    alpha: float,
    options: FitOptions,
    misfit_left: Callable[[CandidateFit], bool],
) -> tuple[list[Step], list[tuple[CandidateFit, float]]]:
    """Add effects while a round's best candidate is significant.

    Parameters
    ----------
    scanner
        The base model's scanner (round 1 ran on it).
    first
        Round 1's fits and adjusted p-values.
    pool
        Every candidate.
    scan_round
        ``(scanner, candidates, stage) -> (fits, adjusted p-values)``.
    alpha
        Family-wise level of each round.
    options
        Full-fit settings.
    misfit_left
        Whether an augmented model's residuals still fail a test (another round is scanned
        only then).

    Returns
    -------
    steps, scored
        The accepted effects in order, and every round's fits with their adjusted p-values.

    """
    steps: list[Step] = []
    fits, adjusted = first
    scored = list(zip(fits, adjusted))
    current = scanner
    for stage in range(1, MAX_EFFECTS + 1):
        if stage > 1:
            used = {n for s in steps for n in s.effect.names}
            rest = [c for c in pool if not set(c.names) & used]
            if not rest:
                break
            fits, adjusted = scan_round(current, rest, stage)
            scored += list(zip(fits, adjusted))
        if not fits or adjusted[0] > alpha:
            break
        best = _fitted(current, fits[0], options)
        if best.statistic <= 0:
            break
        steps.append(Step(best, current.chi2, adjusted[0]))
        if stage == 2:
            steps = _drop_stand_in(scanner, first, steps, options, alpha)
        if stage == MAX_EFFECTS or not misfit_left(steps[-1].fit):
            break
        current = _scanner(steps[-1].fit)
    return steps, scored


def _drop_stand_in(
    base: Scanner,
    first: tuple[list[CandidateFit], list[float]],
    steps: list[Step],
    options: FitOptions,
    alpha: float,
) -> list[Step]:
    """Keep only the second effect when the first adds nothing significant on top of it."""
    second = steps[1].effect
    fits, adjusted = first
    k = next((i for i, f in enumerate(fits) if f.candidate.label == second.label), None)
    if k is None:
        return steps
    alone = _fitted(base, fits[k], options)
    drop = max(alone.chi2 - steps[1].fit.chi2, 0.0)
    if stats.chi2.sf(drop, len(steps[0].effect.names)) < alpha:
        return steps
    return [Step(alone, base.chi2, float(np.clip(adjusted[k], 0.0, 1.0)))]


def effect_steps(
    steps: Sequence[Step], estimates: dict[str, AddedEstimate], coupling: float | None
) -> tuple[EffectStep, ...]:
    """Return the accepted steps as the result reports them.

    ``estimates``: the added parameters' estimates and intervals from the final model's
    profiles; ``coupling``: the final model's coupling error (:func:`.coupling.coupling_error`),
    given to the effects on the fine grid.
    """
    out = []
    for s in steps:
        e = s.effect
        values = {n: estimates[n].estimate for n in e.names}
        fine = acts_on_fine_grid(e)
        out.append(
            EffectStep(
                e.effect,
                e.label,
                e.sentence(values),
                {n: estimates[n] for n in e.names},
                s.chi2_before,
                s.fit.chi2,
                s.fit.p_value,
                s.p_adjusted,
                coupling if fine else None,
                FINE / step_scale(s.fit.problem) if fine else None,
            )
        )
    return tuple(out)
