"""Decide: is there a mismatch, is a candidate significant, which candidates tie.

**One family, one level.** ``mismatch`` is decided by a weighted Holm procedure (valid under
any dependence) over four groups of tests at the family-wise false-alarm level fixed in
advance (0.5 %, :data:`~.residual_tests.FALSE_ALARM`): the catalogue scan (weight
:data:`SCAN_WEIGHT`), the generic error-model test (:data:`GENERIC_WEIGHT`, :mod:`.generic`:
concealed effects outside the catalogue), the agreement of separate per-experiment fits
(:data:`AGREEMENT_WEIGHT`) and the residual tests, which share the rest equally. The weights
put the false-alarm budget where a concealed effect leaves its evidence (the likelihood ratio
of the right augmentation, or input-driven structure that no move of the parameters
reproduces); an effect that shows in the residuals leaves p-values far below any of these
levels.

**The scan's null distribution.** Each candidate's likelihood-ratio statistic has, under the
base model, the null of :func:`~.scan.null_p_value` (chi-bar-square at a bound). The scan's
p-value is that of the smallest candidate p-value, calibrated for the candidates' correlation
(min-P, Westfall and Young): to first order, the statistics are functions of the projections
``Z = U^T e`` of the noise on the candidates' score directions, ``Z ~ N(0, U^T U)``, which are
drawn (seeded) to find the distribution of the smallest p-value. Look-alike candidates (a lag
on the input or on the outputs) thus cost the family almost nothing extra. The Bonferroni bound
caps it. A threshold candidate (a saturation, a dead zone) is fitted over a continuum of levels
and carries the null of that supremum (:mod:`.threshold`): :func:`calibrate` then draws the white
noise itself, in batches, and gives every candidate's score and every threshold's supremum from
the same draws (a threshold's p-value, its own and in the min-P, is its Monte Carlo tail).

**Ties.** Two significant candidates are indistinguishable when their fitted weighted
predictions are equal (``equal_predictions``: no experiment of this design can tell them
apart) or when Vuong's test between the non-nested fits (with Schwarz's correction for the
number of parameters) does not prefer one at :data:`TIE_LEVEL`. The same test between the
named candidate and the generic error model (:func:`generic_tie`) lists ``unexplained`` as a
tie: structure outside the catalogue explains the data as well.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from scipy import special, stats

from fmuid.discrepancy.residual_tests import TestResult
from fmuid.discrepancy.scan import CandidateFit
from fmuid.discrepancy.schema import TieOut
from fmuid.discrepancy.threshold import BATCH
from fmuid.estimation.schema import Written
from fmuid.readable import p_text

SCAN_WEIGHT = 0.7
"""Share of the family-wise level given to the catalogue scan."""

GENERIC_WEIGHT = 0.1
"""Share given to the generic error-model test."""

AGREEMENT_WEIGHT = 0.1
"""Share given to the agreement of separate per-experiment fits."""

GROUPS = {
    "catalogue_scan": SCAN_WEIGHT,
    "generic_error_model": GENERIC_WEIGHT,
    "experiments_disagree": AGREEMENT_WEIGHT,
}
"""Weight of each test that is not a residual test; the residual tests share the rest."""

TIE_LEVEL = 0.05
"""Vuong's test must reject at this level for one candidate to be preferred over another."""

EQUAL_PREDICTIONS = 0.02
"""Fitted predictions whose root-mean-square difference is below this share of sigma are
equal: together they change chi2 by less than ``n * 0.02**2`` (0.4 for 1000 samples)."""

NULL_DRAWS = 20000
"""Draws of the Gaussian null of the scan's smallest p-value."""


class Scored(Protocol):
    """A test whose statistic is, to first order, a function of ``directions^T e``."""

    @property
    def directions(self) -> np.ndarray:
        """Orthonormal score directions (columns)."""

    @property
    def one_sided(self) -> bool:
        """Whether the null is chi-bar-square at a bound (one direction only)."""

    @property
    def p_value(self) -> float:
        """The test's own p-value."""


SUPREMUM = 0.05
"""A threshold candidate whose chi-bar-square p-value of one direction is above this keeps it:
the supremum's tail is heavier still, so it cannot be significant, and its score's p-value
in the draws stays uniform (the others' adjustment is as valid). This spares the supremum's
cost where it cannot change a decision."""


def _null_stats(draws: np.ndarray, fits: Sequence[Scored], blocks: list[slice]) -> np.ndarray:
    """Each candidate's p-value for every null draw (draws x candidates)."""
    out = np.empty((draws.shape[0], len(fits)))
    for k, (f, block) in enumerate(zip(fits, blocks)):
        z = draws[:, block]
        df = z.shape[1]
        if df == 0:
            out[:, k] = 1.0
        elif f.one_sided and df == 1:
            t = np.maximum(z[:, 0], 0.0) ** 2
            out[:, k] = np.where(t > 0, 0.5 * special.chdtrc(1, t), 1.0)
        else:
            out[:, k] = special.chdtrc(df, np.sum(z**2, axis=1))
    return out


def _blocks(fits: Sequence[Scored]) -> tuple[list[slice], np.ndarray]:
    blocks, start = [], 0
    for f in fits:
        blocks.append(slice(start, start + f.directions.shape[1]))
        start += f.directions.shape[1]
    return blocks, np.hstack([f.directions for f in fits])


def _adjusted(smallest: np.ndarray, own: Sequence[float]) -> list[float]:
    """Min-P adjusted p-values from the sorted smallest p-value of each null draw."""
    out = []
    for p in own:
        exceed = np.searchsorted(smallest, p, side="right")
        monte_carlo = (exceed + 1) / (len(smallest) + 1)
        out.append(float(min(monte_carlo, len(own) * p, 1.0)))
    return out


def min_p(fits: Sequence[Scored], seed: int) -> list[float]:
    """Single-step min-P adjusted p-value of each test (see the module docstring)."""
    if not fits:
        return []
    blocks, u = _blocks(fits)
    gram = u.T @ u
    w, v = np.linalg.eigh(gram)
    root = v * np.sqrt(np.clip(w, 0.0, None))
    rng = np.random.default_rng(seed)
    draws = rng.standard_normal((NULL_DRAWS, len(w))) @ root.T
    smallest = np.sort(_null_stats(draws, fits, blocks).min(axis=1))
    return _adjusted(smallest, [f.p_value for f in fits])


def _ranks(null: np.ndarray, observed: float) -> tuple[np.ndarray, float]:
    """Monte Carlo p-values of the null draws and of the observed statistic, on one scale.

    Each is ``(1 + the others at or above it) / (draws + 1)``, the observed value counted among
    the draws' others: the draws and the observed are exchangeable under the null.
    """
    ordered = np.sort(np.append(null, observed))
    at_or_above = len(ordered) - np.searchsorted(ordered, np.append(null, observed), side="left")
    p = at_or_above / len(ordered)
    return p[:-1], float(p[-1])


def calibrate(fits: Sequence[CandidateFit], seed: int) -> tuple[list[float], list[float]]:
    """Each candidate's own p-value and its min-P adjusted p-value.

    A threshold candidate's own p-value is the Monte Carlo tail of its statistic under its
    null (:mod:`.threshold`), drawn jointly with the other candidates' scores, when its
    chi-bar-square p-value is below :data:`SUPREMUM`; otherwise, and without one, the
    candidates' own p-values stand and :func:`min_p` adjusts them.
    """
    thresholds = [k for k, f in enumerate(fits) if f.null is not None and f.p_value < SUPREMUM]
    if not thresholds:
        return [f.p_value for f in fits], min_p(fits, seed)
    blocks, u = _blocks(fits)
    rng = np.random.default_rng(seed)
    scores, sups = [], []
    for start in range(0, NULL_DRAWS, BATCH):
        e = rng.standard_normal((min(BATCH, NULL_DRAWS - start), u.shape[0]))
        scores.append(_null_stats(e @ u, fits, blocks))
        sups.append(np.column_stack([fits[k].null.statistics(e) for k in thresholds]))  # type: ignore[union-attr]
    p_draws, sup = np.vstack(scores), np.vstack(sups)
    own = [f.p_value for f in fits]
    for column, k in enumerate(thresholds):
        p_draws[:, k], own[k] = _ranks(sup[:, column], fits[k].statistic)
    return own, _adjusted(np.sort(p_draws.min(axis=1)), own)


def weighted_holm(tests: Sequence[tuple[TestResult, float]], alpha: float) -> list[TestResult]:
    """Return the tests that Holm's weighted step-down procedure rejects at level ``alpha``.

    Parameters
    ----------
    tests
        ``(test, weight)`` pairs, weights > 0 (normalised here).
    alpha
        Family-wise level.

    """
    remaining = [(t, w) for t, w in tests if w > 0]
    rejected: list[TestResult] = []
    while remaining:
        total = sum(w for _, w in remaining)
        test, weight = min(remaining, key=lambda tw: tw[0].p_value / tw[1])
        if test.p_value > alpha * weight / total:
            break
        rejected.append(test)
        remaining.remove((test, weight))
    return sorted(rejected, key=lambda t: t.p_value)


def family_weights(tests: Sequence[TestResult]) -> list[tuple[TestResult, float]]:
    """Weights of the decision family: scan, generic, agreement, residual tests (equal shares)."""
    residual = [t for t in tests if t.test not in GROUPS]
    rest = 1.0 - sum(GROUPS.values())
    return [(t, GROUPS.get(t.test, rest / max(len(residual), 1))) for t in tests]


@dataclass(frozen=True)
class Tie(Written):
    """A candidate that explains the data as well as the named one.

    ``to_dict`` writes :class:`~fmuid.discrepancy.schema.TieOut`.

    Attributes
    ----------
    fit
        The candidate's fit.
    test
        ``"equal_predictions"`` or ``"vuong"``.
    statistic, p_value
        Vuong's z statistic and its two-sided p-value (0 and 1 for equal predictions).
    max_difference
        Largest difference of the two fitted predictions in units of sigma.

    """

    fit: CandidateFit
    test: str
    statistic: float
    p_value: float
    max_difference: float

    schema = TieOut


def vuong(best: CandidateFit, other: CandidateFit) -> tuple[float, float]:
    """Vuong's z statistic of ``best`` against ``other`` and its two-sided p-value."""
    return vuong_test(best.residuals, best.problem.n_free, other.residuals, other.problem.n_free)


def vuong_test(
    best: np.ndarray, best_free: int, other: np.ndarray, other_free: int
) -> tuple[float, float]:
    """Vuong's z of one fit against another, from their weighted residuals and free counts."""
    n = len(best)
    ratio = 0.5 * (other**2 - best**2)
    omega = float(np.std(ratio))
    correction = 0.5 * (best_free - other_free) * np.log(n)
    if omega == 0.0:
        return 0.0, 1.0
    z = (float(ratio.sum()) - correction) / (np.sqrt(n) * omega)
    return float(z), float(2.0 * stats.norm.sf(abs(z)))


def generic_tie(
    best: CandidateFit, residuals: np.ndarray, n_free: int, model: str
) -> dict[str, object] | None:
    """Return the generic error model as a tie of ``best`` when Vuong's test prefers neither.

    ``residuals`` and ``n_free`` are those of the base model with the generic error model
    (:func:`.generic.fitted_residuals`): a named candidate that explains the data no better
    than input-driven structure outside the catalogue may stand in for physics the catalogue
    lacks.
    """
    z, p = vuong_test(best.residuals, best.problem.n_free, residuals, n_free)
    if p < TIE_LEVEL:
        return None
    return {
        "effect": "unexplained",
        "model": model,
        "parameters": {},
        "chi2": float(residuals @ residuals),
        "test": "vuong",
        "statistic": z,
        "p_value": p,
        "max_difference_sigma": float(np.max(np.abs(residuals - best.residuals))),
    }


def ties(best: CandidateFit, others: Sequence[CandidateFit]) -> list[Tie]:
    """Return the fitted candidates that no test of this data prefers ``best`` to."""
    out = []
    for other in others:
        if other is best or not other.fitted:
            continue
        difference = other.residuals - best.residuals
        gap = float(np.max(np.abs(difference)))
        if float(np.sqrt(np.mean(difference**2))) < EQUAL_PREDICTIONS:
            out.append(Tie(other, "equal_predictions", 0.0, 1.0, gap))
            continue
        z, p = vuong(best, other)
        if p >= TIE_LEVEL:
            out.append(Tie(other, "vuong", z, p, gap))
    return out


def strength(p: float) -> str:
    """Words for a p-value: how strong the evidence is."""
    if p < 1e-6:
        return f"very strong evidence ({p_text(p)})"
    if p < 1e-3:
        return f"strong evidence ({p_text(p)})"
    if p < 0.01:
        return f"evidence ({p_text(p)})"
    return f"weak evidence ({p_text(p)})"
