"""Locate a misfit in the signal's own terms: where in the range of an output and its rate.

For each fitted output, the weighted residuals of the base fit are regressed on shapes of the
model's own output ``y`` and of its rate ``dy/dt`` (finite differences of the simulated output),
each beyond what a constant and a line in ``y`` already explain:

==========  ==============================================================================
shape       what it means
==========  ==============================================================================
odd         ``y^3``: the misfit changes sign with ``y`` and grows towards both extremes
            (a hardening or softening spring, a gain that depends on the level)
even        ``y^2``: the misfit has the same sign at both extremes (an asymmetry)
top         ``y`` above its 90 % quantile: only near the top of the range (a saturation,
            an overflow)
bottom      ``y`` below its 10 % quantile
rate_sign   ``sign(dy/dt)``: a step whenever the rate changes sign (Coulomb friction,
            backlash)
amplitude   the residual's RMS over short windows grows with the output's RMS there: the
            misfit grows with the amplitude (a stiffness or a gain that depends on the size
            of the motion), also where it is not a static function of the level (one-sided
            slope test over windows of :data:`WINDOWS` of a record, at least 8 samples)
==========  ==============================================================================

An F test of each added shape gives a p-value; of the shapes significant at the diagnosis'
level, the one that explains the largest share of the residual sum of squares is stated (on a
long record several p-values underflow to 0, so the share, not the p-value, ranks them).
Binned means of the residual against ``y`` and against ``dy/dt`` (quantile bins) are kept for
the figure that shows them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy import stats

from fmuid.estimation.series import ResidualSeries

WINDOWS = 200
"""Windows per record of the amplitude test (each at least 8 samples)."""

BINS = 12
"""Quantile bins of the level and of the rate in the figure's data."""

WORDS = {
    "odd": "grows with the size of {y} and changes sign with it (an odd function of {y}, "
    "largest at both extremes)",
    "even": "has the same sign at both extremes of {y} (an even function of {y})",
    "top": "sits near the top of {y}'s range (above its 90 % quantile)",
    "bottom": "sits near the bottom of {y}'s range (below its 10 % quantile)",
    "rate_sign": "jumps when the rate of {y} changes sign",
    "amplitude": "grows with the amplitude of {y} (larger where {y} swings wider)",
}


def _shapes(y: np.ndarray, rate: np.ndarray) -> dict[str, np.ndarray]:
    scale = max(float(np.max(np.abs(y - np.mean(y)))), 1e-300)
    c = (y - np.mean(y)) / scale
    r_scale = max(float(np.max(np.abs(rate))), 1e-300)
    return {
        "odd": c**3,
        "even": c**2,
        "top": (y > np.quantile(y, 0.9)).astype(float),
        "bottom": (y < np.quantile(y, 0.1)).astype(float),
        "rate_sign": np.tanh(rate / (0.02 * r_scale)),
    }


def _f_test(r: np.ndarray, base: np.ndarray, extra: np.ndarray) -> tuple[float, float]:
    """Return the F test's p-value of adding ``extra`` to ``base``, and the share explained.

    The share is of ``r``'s sum of squares.
    """
    full = np.column_stack([base, extra])
    rss0 = float(np.sum((r - base @ np.linalg.lstsq(base, r, rcond=None)[0]) ** 2))
    rss1 = float(np.sum((r - full @ np.linalg.lstsq(full, r, rcond=None)[0]) ** 2))
    df = len(r) - full.shape[1]
    if df <= 0 or rss1 <= 0 or rss0 <= rss1:
        return 1.0, 0.0
    f = (rss0 - rss1) / (rss1 / df)
    return float(stats.f.sf(f, 1, df)), (rss0 - rss1) / max(float(r @ r), 1e-300)


def _amplitude(parts: Sequence[ResidualSeries]) -> tuple[float, float]:
    """Return the one-sided p-value and R^2 of the residual's window RMS against the output's."""
    y_rms: list[np.ndarray] = []
    r_rms: list[np.ndarray] = []
    for s in parts:
        width = max(8, len(s.model) // WINDOWS)
        n = len(s.model) // width
        if n < 3:
            continue
        for x, out in ((s.model, y_rms), (s.weighted, r_rms)):
            blocks = (x - np.mean(x))[: n * width].reshape(n, width)
            out.append(np.sqrt(np.mean(blocks**2, axis=1)))
    if sum(v.size for v in y_rms) < 5:
        return 1.0, 0.0
    fit = stats.linregress(np.concatenate(y_rms), np.concatenate(r_rms))
    if not np.isfinite(fit.pvalue):
        return 1.0, 0.0
    p = fit.pvalue / 2 if fit.slope > 0 else 1.0 - fit.pvalue / 2
    return float(p), float(fit.rvalue**2)


def _bins(x: np.ndarray, r: np.ndarray) -> dict[str, list[float]]:
    edges = np.unique(np.quantile(x, np.linspace(0, 1, BINS + 1)))
    index = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, len(edges) - 2)
    centre, mean, error = [], [], []
    for k in range(len(edges) - 1):
        inside = index == k
        if inside.sum() < 2:
            continue
        centre.append(float(np.mean(x[inside])))
        mean.append(float(np.mean(r[inside])))
        error.append(float(np.std(r[inside], ddof=1) / np.sqrt(inside.sum())))
    return {"centre": centre, "mean": mean, "stderr": error}


def level_location(series: Sequence[ResidualSeries], alpha: float) -> dict[str, Any]:
    """Where in each output's range, and in its rate's, the base fit's misfit sits.

    Returns
    -------
    dict
        Per output: ``pattern`` (the strongest shape, or None), ``p_value``, ``share`` (of the
        residual sum of squares it explains), ``tests`` (every shape's p-value), ``words``
        (a sentence or ''), and ``by_level`` / ``by_rate`` binned means for the figure.

    """
    by_output: dict[str, list[ResidualSeries]] = {}
    for s in series:
        if len(s.time) > 8:
            by_output.setdefault(s.output, []).append(s)
    out: dict[str, Any] = {}
    for output, parts in by_output.items():
        y = np.concatenate([s.model for s in parts])
        r = np.concatenate([s.weighted for s in parts])
        rate = np.concatenate([np.gradient(s.model, s.time) for s in parts])
        base = np.column_stack([np.ones_like(y), y])
        tests = {name: _f_test(r, base, shape) for name, shape in _shapes(y, rate).items()}
        tests["amplitude"] = _amplitude(parts)
        name = max(tests, key=lambda k: (tests[k][0] < alpha, tests[k][1]))
        p, share = tests[name]
        found = p < alpha
        out[output] = {
            "pattern": name if found else None,
            "p_value": p,
            "share": share,
            "tests": {k: v[0] for k, v in tests.items()},
            "words": f"the misfit of {output} {WORDS[name].format(y=output)}" if found else "",
            "by_level": _bins(y, r),
            "by_rate": _bins(rate, r),
            "unit": parts[0].unit,
        }
    return out
