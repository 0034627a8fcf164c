"""Forward selection: add effects one at a time while the scan on top of the model finds one.

Round 1 scans the catalogue on the base fit (:mod:`.scan`). When its best candidate is
significant after the round's min-P adjustment at the family-wise level, it is added; while
the augmented model's residuals still fail a test, the remaining candidates are scanned on top
of it (round 2), and so on up to :data:`MAX_EFFECTS`. Each round is one test at the same
level, so a false addition at any step has probability at most that level. After each
addition, an effect the augmented model does without is dropped (:func:`_backward`, the
backward half of stepwise selection): an earlier effect standing in for a later one, or a term
whose chi2 drop came from a better valley of the others found in its fit rather than from
the term; a dropped effect is not scanned again.
An accepted fit is first moved to a fine step its chi2 no longer feels (:mod:`.coupling`), so
that the next round does not read the coupling's error as an effect.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from fmuid.discrepancy.augment import FINE
from fmuid.discrepancy.coupling import acts_on_fine_grid, settle_step, step_scale
from fmuid.discrepancy.effects import Effect
from fmuid.discrepancy.result import AddedEstimate, EffectStep
from fmuid.discrepancy.scan import CandidateFit, Scanner, augmented, null_p_value
from fmuid.errors import FmuidError
from fmuid.estimation.optimize import FitOptions, jacobian, refine, safe_residuals
from fmuid.estimation.problem import Problem

log = logging.getLogger(__name__)

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
    dropped: set[str] = set()
    fits, adjusted = first
    scored = list(zip(fits, adjusted))
    current = scanner
    for stage in range(1, MAX_EFFECTS + 1):
        if stage > 1:
            used = {n for s in steps for n in s.effect.names}
            rest = [c for c in pool if not set(c.names) & used and c.label not in dropped]
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
        before = {s.effect.label for s in steps}
        steps = _backward(scanner, steps, options, alpha)
        dropped |= before - {s.effect.label for s in steps}
        if stage == MAX_EFFECTS or not misfit_left(steps[-1].fit):
            break
        current = _scanner(steps[-1].fit)
    return steps, scored


def _backward(base: Scanner, steps: list[Step], options: FitOptions, alpha: float) -> list[Step]:
    """Drop the added effects the final model does not need, the least needed first.

    Each effect is taken out of the final model in turn and the others refitted from the final
    values. The effect whose removal raises chi2 the least significantly is dropped when that
    rise is not significant at ``alpha`` (chi2 with a degree per parameter, chi-bar-square for
    an off value at a bound), and the pass repeats on the effects left. A removal whose refit
    ends below the final chi2 (a better valley of the others) always drops the effect. For a
    threshold the chi2 null is lenient: it keeps a term that forward selection accepted under
    its own, stricter null, unless the final model plainly does without it.
    """
    while len(steps) > 1:
        final = steps[-1].fit
        values = final.problem.from_z(final.z)
        scale = step_scale(final.problem)
        trials = []
        for k, s in enumerate(steps):
            kept = [t.effect for j, t in enumerate(steps) if j != k]
            refit = _refit(base, kept, scale, values, options)
            if refit is None:
                continue
            rise = max(refit[2] - final.chi2, 0.0)
            trials.append((null_p_value(rise, len(s.effect.names), s.fit.one_sided), k, refit))
        if not trials:
            break
        p, k, refit = max(trials, key=lambda t: t[0])
        if p < alpha:
            break
        label = steps[k].effect.label
        log.info("%s: not needed once the others are in (p %.3g); dropped", label, p)
        shorter = _without(base, steps, k, refit, scale, values, options)
        if shorter is None:
            break
        steps = shorter
    return steps


Refit = tuple[Problem, np.ndarray, float]
"""An augmented problem, its fitted point and chi2 there."""


def _refit(
    base: Scanner,
    effects: Sequence[Effect],
    scale: float,
    values: dict[str, float],
    options: FitOptions,
) -> Refit | None:
    """Fit the base model with ``effects`` from ``values``; None when the fit fails."""
    aug = augmented(base.problem, effects, scale)
    try:
        z, _, _ = refine(aug, aug.to_z({n: values[n] for n in aug.names}), options=options)
    except FmuidError as exc:
        log.info("a refit with %s failed (%s)", [e.label for e in effects], exc)
        return None
    r = safe_residuals(aug, z)
    return aug, z, float(r @ r)


def _without(
    base: Scanner,
    steps: list[Step],
    k: int,
    refit: Refit,
    scale: float,
    values: dict[str, float],
    options: FitOptions,
) -> list[Step] | None:
    """Return the steps without step ``k``, those after it refitted without its effect.

    ``refit`` is the fit of every other effect; the cumulative models in between are refitted
    on the fine step ``scale`` from ``values`` (the final model's; None when such a refit
    fails); the last keeps the lower chi2 of its fits.
    """
    rest = [s for j, s in enumerate(steps) if j != k]
    out = rest[: min(k, len(rest) - 1)]
    chi2_before = out[-1].fit.chi2 if out else base.chi2
    for j, s in enumerate(rest[len(out) :], start=len(out)):
        fits = [refit] if j == len(rest) - 1 else []
        if j < k:
            fits.append((s.fit.problem, s.fit.z, s.fit.chi2))
        elif j < len(rest) - 1:
            cumulative = _refit(base, [t.effect for t in rest[: j + 1]], scale, values, options)
            if cumulative is None:
                return None
            fits.append(cumulative)
        aug, z, chi2 = min(fits, key=lambda f: f[2])
        statistic = max(chi2_before - chi2, 0.0)
        fit = replace(
            s.fit,
            problem=aug,
            z=z,
            chi2=chi2,
            statistic=statistic,
            p_value=null_p_value(statistic, len(s.effect.names), s.fit.one_sided),
            residuals=safe_residuals(aug, z),
        )
        out.append(Step(fit, chi2_before, s.p_adjusted))
        chi2_before = chi2
    return out


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
