"""Statistical tests that locate a model mismatch in the weighted residuals of a fit.

Every test returns a p-value under the null hypothesis "the model is right and the weighted
residuals are independent standard normal noise". The tests are pooled into one family and
``mismatch`` is decided by Holm's step-down procedure at a family-wise false-alarm level
(:data:`FALSE_ALARM`); Holm is valid under any dependence between the tests.

Tests per experiment and output (``series``):

``residual_whiteness``
    Ljung-Box portmanteau statistic of the residual autocorrelation up to ``h`` lags
    (:func:`lb_lags`). Fitted
    residuals are not white noise: the fit absorbs the noise's part along the parameters'
    sensitivities (smooth signals), which correlates neighbouring residuals, and a short
    series with many lags is far from the asymptotic chi2(h). Given draws of the statistic on
    the fitted model's own null residuals (:func:`ljung_box_null`), the p-value is that of a
    scaled chi2 with their mean and variance (Satterthwaite); without them, chi2(h).
``input_cross_correlation``
    Ljung's model-validation test: the residuals regressed on lagged inputs; ``n R^2`` is
    chi2 with the number of independent lagged regressors under the null (it does not need a
    white input).
``residual_bias``
    Student t-test of the residual mean.
``chi2_goodness_of_fit``
    Weighted sum of squares of the series against chi2(n) (only when sigma is known); the
    parameters' degrees of freedom are not subtracted, which keeps it conservative.

Location helpers: :func:`windows` (sliding windows whose residual mean or sum of squares exceed
the noise at a Bonferroni level) and :func:`spectrum_band` (Daniell-smoothed periodogram against
the white-noise floor of 1).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats

FALSE_ALARM = 0.005
"""Family-wise false-alarm probability of the ``mismatch`` decision (Holm over all tests).

Chosen from what users measure, not from any case: a run of 200 models without mismatch
should show at most 1 % false alarms (2 of 200). A procedure calibrated at exactly 1 % shows
3 or more one time in three (binomial); at 0.5 %, one time in thirteen.
"""


@dataclass(frozen=True)
class Series:
    """Weighted residuals of one output in one experiment, in time order.

    Attributes
    ----------
    experiment, output
        Names.
    time
        Times of the fitted samples [s].
    residuals
        ``(data - model) / sigma`` at those times.
    inputs
        Each input's value at those times.

    """

    experiment: str
    output: str
    time: np.ndarray
    residuals: np.ndarray
    inputs: dict[str, np.ndarray] = field(default_factory=dict)


@dataclass(frozen=True)
class TestResult:
    """One test of the family.

    Attributes
    ----------
    test
        Test name (see the module docstring).
    output, experiment
        Where it was applied (``None`` for tests over all of them).
    p_value
        Probability of a statistic at least this extreme when the model is right.
    statistic
        The test statistic.
    df
        Its degrees of freedom, when it has any.

    """

    test: str
    output: str | None
    experiment: str | None
    p_value: float
    statistic: float
    df: float | None = None


def lb_lags(n: int) -> int:
    """Lags of the whiteness test of a series of ``n`` samples: ``min(20, n // 10)``, at least 1.

    The statistic's tail is near chi2 only when every autocorrelation is estimated from many
    more samples than lags. At ``n // 5`` lags, p-values below 1e-4 came out 20 times too
    often on 101 white samples and 52 times on 101 samples less a 6-parameter fit; at
    ``n // 10`` with the moment calibration of :func:`ljung_box`, 9 and 6 times
    (``bench/whiteness.py``). Longer series are near nominal either way.
    """
    return max(1, min(20, n // 10))


def ljung_box_null(residuals: np.ndarray, lags: int) -> np.ndarray:
    """Ljung-Box statistic of each row of ``residuals`` (draws x samples), mean removed."""
    r = residuals - residuals.mean(axis=-1, keepdims=True)
    n = r.shape[-1]
    denom = np.sum(r * r, axis=-1)
    denom = np.where(denom > 0, denom, 1.0)
    q = np.zeros(r.shape[:-1])
    for k in range(1, lags + 1):
        q += (np.sum(r[..., k:] * r[..., :-k], axis=-1) / denom) ** 2 / (n - k)
    return n * (n + 2) * q


def ljung_box(
    series: Series, lags: int | None = None, null: np.ndarray | None = None
) -> TestResult:
    """Ljung-Box whiteness test of the residuals (``lags`` default :func:`lb_lags`).

    ``null`` holds the statistic (same lags) on draws of the fitted model's null residuals;
    the p-value is then that of the scaled chi2 matching their mean and variance.
    """
    h = lags or lb_lags(len(series.residuals))
    q = float(ljung_box_null(series.residuals, h))
    p, df = whiteness_p(q, h, null)
    return TestResult("residual_whiteness", series.output, series.experiment, float(p), q, df)


def whiteness_p(q: Any, lags: int, null: np.ndarray | None = None) -> tuple[Any, float]:
    """P-value(s) of Ljung-Box statistic(s) ``q`` and the degrees of freedom used.

    chi2(``lags``) without ``null``; with it, the scaled chi2 ``g chi2(nu)`` whose mean and
    variance are those of the null draws (Satterthwaite).
    """
    df, scale = float(lags), 1.0
    if null is not None and len(null) > 1:
        mean, var = float(np.mean(null)), float(np.var(null, ddof=1))
        if mean > 0 and var > 0:
            scale, df = var / (2.0 * mean), 2.0 * mean**2 / var
    return stats.chi2.sf(np.asarray(q) / scale, df), df


def lagged(values: np.ndarray, lags: Sequence[int]) -> np.ndarray:
    """Matrix whose columns are ``values`` delayed by each lag (held at the first sample)."""
    n = len(values)
    cols = [np.concatenate([np.full(min(k, n), values[0]), values[: n - min(k, n)]]) for k in lags]
    return np.column_stack(cols)


def input_cross_correlation(series: Series, max_lag_s: float = 2.0) -> list[TestResult]:
    """Ljung's residual-input cross-correlation test, one per input.

    The residuals are regressed on the input delayed by 0 ... ``max_lag_s`` seconds, at most a
    fifth of the record (up to 10 lags); under the null, ``n R^2`` is chi2 with df = rank of the
    (centred) regressors.
    """
    out = []
    r = series.residuals - series.residuals.mean()
    dt = float(np.median(np.diff(series.time)))
    max_lag_s = min(max_lag_s, float(series.time[-1] - series.time[0]) / 5)
    n_lags = max(1, min(10, int(round(max_lag_s / dt)) + 1))
    step = max(1, int(round(max_lag_s / dt / max(n_lags - 1, 1))))
    for u in series.inputs.values():
        phi = lagged(u, [k * step for k in range(n_lags)])
        phi = phi - phi.mean(axis=0)
        scale = np.linalg.norm(phi, axis=0)
        keep = scale > 1e-12 * max(float(scale.max(initial=0.0)), 1e-300)
        if not keep.any():
            continue
        phi = phi[:, keep] / scale[keep]
        coef, _, rank, _ = np.linalg.lstsq(phi, r, rcond=1e-6)
        fitted = phi @ coef
        r2 = float(fitted @ fitted / (r @ r)) if r @ r > 0 else 0.0
        stat = len(r) * r2
        out.append(
            TestResult(
                "input_cross_correlation",
                series.output,
                series.experiment,
                float(stats.chi2.sf(stat, rank)),
                stat,
                int(rank),
            )
        )
    return out


def bias(series: Series) -> TestResult:
    """Two-sided t-test of the residual mean against zero."""
    r = series.residuals
    n = len(r)
    sd = float(np.std(r, ddof=1))
    t = float(np.mean(r) / (sd / np.sqrt(n))) if sd > 0 else 0.0
    return TestResult(
        "residual_bias",
        series.output,
        series.experiment,
        float(2 * stats.t.sf(abs(t), n - 1)),
        t,
        n - 1,
    )


def goodness_of_fit(series: Series) -> TestResult:
    """Chi2 test of the series' weighted sum of squares against chi2(n)."""
    chi2 = float(series.residuals @ series.residuals)
    n = len(series.residuals)
    return TestResult(
        "chi2_goodness_of_fit",
        series.output,
        series.experiment,
        float(stats.chi2.sf(chi2, n)),
        chi2,
        n,
    )


def global_goodness_of_fit(chi2: float, n_data: int, n_free: int) -> TestResult:
    """Chi2 test of the total weighted sum of squares against chi2(n_data - n_free)."""
    df = max(n_data - n_free, 1)
    return TestResult(
        "chi2_goodness_of_fit", None, None, float(stats.chi2.sf(chi2, df)), float(chi2), df
    )


def series_tests(
    series: Sequence[Series],
    sigma_known: bool,
    whiteness_null: Mapping[tuple[str, str], np.ndarray] | None = None,
) -> list[TestResult]:
    """Run every per-series test (goodness of fit only when ``sigma_known``).

    ``whiteness_null`` maps ``(experiment, output)`` to the whiteness statistic's null draws
    (:func:`ljung_box`).
    """
    out: list[TestResult] = []
    nulls = whiteness_null or {}
    for s in series:
        if len(s.residuals) < 8:
            continue
        out.append(ljung_box(s, null=nulls.get((s.experiment, s.output))))
        out.extend(input_cross_correlation(s))
        out.append(bias(s))
        if sigma_known:
            out.append(goodness_of_fit(s))
    return out


def holm(tests: Sequence[TestResult], alpha: float = FALSE_ALARM) -> list[TestResult]:
    """Return the tests that Holm's step-down procedure rejects at family-wise level ``alpha``.

    Sorted by p-value; empty when none is rejected (then there is no evidence of mismatch).
    """
    ordered = sorted(tests, key=lambda t: t.p_value)
    m = len(ordered)
    rejected = []
    for i, t in enumerate(ordered):
        if t.p_value > alpha / (m - i):
            break
        rejected.append(t)
    return rejected


def min_adjusted_p(tests: Sequence[TestResult]) -> float:
    """Smallest Holm-adjusted p-value of the family (``min p * m``, capped at 1)."""
    if not tests:
        return 1.0
    return float(min(1.0, min(t.p_value for t in tests) * len(tests)))


@dataclass(frozen=True)
class Window:
    """A time window in which one series' residuals concentrate."""

    experiment: str
    output: str
    start: float
    end: float
    score: float


def windows(series: Series, width_s: float = 2.0, alpha: float = FALSE_ALARM) -> list[Window]:
    """Find the windows of ``width_s`` seconds whose residuals exceed the noise.

    A window is flagged when its residual sum divided by ``sqrt(w)`` (a N(0, 1) score) or its
    sum of squares (chi2(w)) is beyond the level ``alpha`` Bonferroni-corrected over the
    ``n / w`` disjoint windows of the series. Overlapping flagged windows are merged; the
    ``score`` is the largest -log10 p-value inside.
    """
    r, t = series.residuals, series.time
    n = len(r)
    dt = float(np.median(np.diff(t)))
    w = max(3, min(n, int(round(width_s / dt))))
    k = max(1, n // w)
    c1 = np.concatenate([[0.0], np.cumsum(r)])
    c2 = np.concatenate([[0.0], np.cumsum(r * r)])
    sums = c1[w:] - c1[:-w]
    squares = c2[w:] - c2[:-w]
    p_mean = 2 * stats.norm.sf(np.abs(sums) / np.sqrt(w))
    p_sq = stats.chi2.sf(squares, w)
    p = np.minimum(p_mean, p_sq) * 2 * k
    flagged = np.flatnonzero(p < alpha)
    out: list[Window] = []
    for i in flagged:
        start, end = float(t[i]), float(t[i + w - 1])
        score = float(-np.log10(max(p[i], 1e-300)))
        if out and start <= out[-1].end:
            last = out[-1]
            out[-1] = Window(last.experiment, last.output, last.start, end, max(last.score, score))
        else:
            out.append(Window(series.experiment, series.output, start, end, score))
    return out


def spectrum_band(
    series: Series, alpha: float = FALSE_ALARM, smooth: int = 5
) -> tuple[float, float, float] | None:
    """Return the frequency band where the residual spectrum exceeds the white-noise floor.

    The periodogram of the weighted residuals has mean 1 at every frequency under the null; the
    average of ``smooth`` neighbouring ordinates is Gamma(smooth, 1/smooth). Ordinates beyond
    the Bonferroni level over the independent averages are flagged and the contiguous run
    holding the largest excess is returned.

    Returns
    -------
    tuple or None
        ``(f_low, f_high, peak power)`` in Hz and noise-floor units, or ``None``.

    """
    freq, power = periodogram(series)
    if len(power) < smooth:
        return None
    avg = np.convolve(power, np.ones(smooth) / smooth, mode="same")
    k = max(1, len(power) // smooth)
    threshold = stats.gamma.isf(alpha / k, smooth, scale=1.0 / smooth)
    above = avg > threshold
    if not above.any():
        return None
    peak = int(np.argmax(np.where(above, avg, -np.inf)))
    lo = peak
    while lo > 0 and above[lo - 1]:
        lo -= 1
    hi = peak
    while hi < len(avg) - 1 and above[hi + 1]:
        hi += 1
    half = smooth // 2
    lo_f = float(freq[max(lo - half, 0)])
    hi_f = float(freq[min(hi + half, len(freq) - 1)])
    return lo_f, hi_f, float(avg[peak])


def periodogram(series: Series) -> tuple[np.ndarray, np.ndarray]:
    """Periodogram of the weighted residuals, normalised so white unit noise has mean 1.

    Returns the positive frequencies [Hz] (zero excluded) and the ordinates.
    """
    r = series.residuals
    n = len(r)
    dt = float(np.median(np.diff(series.time)))
    spec = np.abs(np.fft.rfft(r)) ** 2 / n
    freq = np.fft.rfftfreq(n, dt)
    return freq[1:], spec[1:]
