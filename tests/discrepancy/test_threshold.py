"""Nulls of threshold candidates (``fmuid.discrepancy.threshold``) against exact clipped fits.

A small weighted linear model ``y = a + b s(t)`` whose signal ``s`` rises to a plateau (many
tied predictions, as a step's steady state): the recorded output may be clipped at a level
``L``. The references fit the clipped model ``min(a + b s, L)`` directly (numpy least squares
on the unclipped rows, scipy over the level and over every parameter), independently of the
closed form of the module.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from scipy import optimize, stats

from fmuid.discrepancy.decide import NULL_DRAWS, calibrate
from fmuid.discrepancy.threshold import ClipNull, LevelsNull, unit_columns

N = 30
FLOOR = 0.5
"""Lowest upper limit of the level (in the output's units)."""


def _design() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Signal matrix ``X`` (intercept, plateau signal), weights ``1/sigma`` and the basis."""
    t = np.linspace(0.0, 1.0, N)
    x = np.column_stack([np.ones(N), np.minimum(2.5 * t, 1.0)])
    w = 4.0 / (1.0 + 0.5 * t)
    basis = np.linalg.qr(w[:, None] * x)[0]
    return x, w, basis


def _exact(x: np.ndarray, w: np.ndarray, data: np.ndarray) -> tuple[float, np.ndarray]:
    """Chi2 drop of the clipped model ``min(X theta, L)``, ``L >= FLOOR``, fitted in full.

    Every clipped set the signal's order allows (the slope stays positive) is a convex problem
    with the set's constraints, solved by scipy (SLSQP); the best of them is the fit. Returns
    the drop and the base fit's prediction.
    """
    theta = np.linalg.lstsq(w[:, None] * x, w * data, rcond=None)[0]
    predicted = x @ theta
    base = float(np.sum((w * (data - predicted)) ** 2))
    order = np.argsort(-x[:, 1], kind="stable")
    best = base
    for k in range(1, N + 1):
        if k < N and x[order[k], 1] == x[order[k - 1], 1]:
            continue
        c = np.zeros(N, bool)
        c[order[:k]] = True

        def chi2(z: np.ndarray, c: np.ndarray = c) -> float:
            return float(np.sum((w * (data - np.where(c, z[2], x @ z[:2]))) ** 2))

        def feasible(z: np.ndarray, c: np.ndarray = c) -> np.ndarray:
            return np.concatenate([x[c] @ z[:2] - z[2], z[2] - x[~c] @ z[:2], [z[2] - FLOOR]])

        fit = optimize.minimize(
            chi2,
            [*theta, max(FLOOR, predicted.max())],
            constraints=[{"type": "ineq", "fun": feasible}],
            method="SLSQP",
            options={"ftol": 1e-12, "maxiter": 500},
        )
        if np.all(feasible(fit.x) > -1e-8):
            best = min(best, fit.fun)
    return base - best, predicted


@pytest.mark.parametrize("seed", [2, 3, 5])
def test_clip_null_supremum_is_the_exact_clipped_fit(seed: int) -> None:
    """The closed form's supremum equals the clipped model fitted over every level and set."""
    x, w, basis = _design()
    rng = np.random.default_rng(seed)
    data = x @ np.array([0.0, 1.0]) + rng.standard_normal(N) / w
    data[x[:, 1] == 1.0] -= 0.1  # a plateau a little low
    drop, predicted = _exact(x, w, data)
    r0 = w * (data - predicted)
    null = ClipNull.build(np.arange(N), predicted, w, basis, FLOOR, upper=True)
    assert null.observed(r0) == pytest.approx(drop, rel=1e-5, abs=1e-7)
    lower = ClipNull.build(np.arange(N), -predicted, w, basis, -FLOOR, upper=False)
    assert lower.observed(-r0) == pytest.approx(null.observed(r0), rel=1e-9)


@pytest.mark.slow
def test_clip_null_tail_is_the_exact_fits_and_the_chi_bar_square_is_too_liberal() -> None:
    """The tail of the null against brute-force Monte Carlo of the exact clipped fit."""
    x, w, basis = _design()
    rng = np.random.default_rng(11)
    truth = x @ np.array([0.0, 1.0])
    exact = np.array([_exact(x, w, truth + rng.standard_normal(N) / w)[0] for _ in range(150)])
    null = ClipNull.build(np.arange(N), truth, w, basis, FLOOR, upper=True)
    drawn = null.statistics(np.random.default_rng(12).standard_normal((20000, N)))
    chi_bar = stats.chi2.isf(2 * 0.05, 1)  # 5 % point of 1/2 chi2_0 + 1/2 chi2_1
    tail, tail_exact = np.mean(drawn >= chi_bar), np.mean(exact >= chi_bar)
    assert tail == pytest.approx(tail_exact, abs=3 * np.sqrt(tail * (1 - tail) / len(exact)))
    assert tail > 0.055  # the chi-bar-square says 0.05: too liberal (20000 draws: +-0.0016)


def test_levels_null_is_the_largest_one_sided_score() -> None:
    """Over one level it is the chi-bar-square of one direction (its tail, by a closed form)."""
    rng = np.random.default_rng(5)
    u = rng.standard_normal((40, 1))
    null = LevelsNull(unit_columns(u))
    drawn = null.statistics(rng.standard_normal((40000, 40)))
    assert np.mean(drawn >= 2.0) == pytest.approx(0.5 * stats.chi2.sf(2.0, 1), abs=0.004)
    two = LevelsNull(unit_columns(np.column_stack([u, -u, np.zeros(40)])))
    assert two.directions.shape[1] == 2
    assert np.mean(two.statistics(rng.standard_normal((40000, 40))) >= 2.0) == pytest.approx(
        stats.chi2.sf(2.0, 1), abs=0.005
    )


@dataclass(frozen=True)
class _Fit:
    """What :func:`calibrate` reads of a candidate."""

    directions: np.ndarray
    one_sided: bool
    p_value: float
    statistic: float
    null: LevelsNull | None = None


def test_calibrate_gives_a_threshold_its_nulls_tail_jointly_with_the_others() -> None:
    """A threshold alone: its tail (closed form); beside its own score: min-P of two copies."""
    u = unit_columns(np.random.default_rng(2).standard_normal((30, 1)))
    t = 6.0
    chi_bar = 0.5 * stats.chi2.sf(t, 1)
    threshold = _Fit(u, True, chi_bar, t, LevelsNull(u))
    own, adjusted = calibrate([threshold], seed=4)  # type: ignore[list-item]
    error = 3 * np.sqrt(chi_bar / NULL_DRAWS)
    assert own[0] == pytest.approx(chi_bar, abs=error)
    assert adjusted[0] == pytest.approx(chi_bar, abs=error)
    score = _Fit(u, True, chi_bar, t)
    own, adjusted = calibrate([threshold, score], seed=4)  # type: ignore[list-item]
    assert adjusted[0] == pytest.approx(chi_bar, abs=error)  # the same statistic twice
    assert adjusted[1] == pytest.approx(chi_bar, abs=error)
