"""Measurement noise levels estimated from the data."""

from __future__ import annotations

import numpy as np
from scipy.interpolate import make_smoothing_spline
from scipy.optimize import minimize_scalar

from fmuid.errors import DataError

SPLINE_METHOD = "estimate: residual spread about a cubic smoothing spline (GCV), dof-corrected"

PROBES = 8
"""Rademacher probes of the final trace estimate."""
SEARCH_PROBES = 2
"""Probes of the trace while the smoothing is searched (the same probes at every level)."""


class _Gcv:
    """Generalised cross-validation score of a smoothing spline at ``10**log_lam``."""

    def __init__(self, t: np.ndarray, y: np.ndarray, probes: np.ndarray):
        self.t, self.y, self.probes = t, y, probes

    def parts(self, log_lam: float) -> tuple[float, float]:
        """Return the residual sum of squares and the residual degrees of freedom."""
        lam = 10.0**log_lam
        fit_rss = float(
            np.sum((self.y - make_smoothing_spline(self.t, self.y, lam=lam)(self.t)) ** 2)
        )
        smooth = [p @ make_smoothing_spline(self.t, p, lam=lam)(self.t) for p in self.probes]
        return fit_rss, self.t.size - float(np.mean(smooth))

    def __call__(self, log_lam: float) -> float:
        fit_rss, resid_dof = self.parts(log_lam)
        return self.t.size * fit_rss / resid_dof**2 if resid_dof > 1.0 else np.inf


def spline_residual_sigma(
    time: list[np.ndarray], values: list[np.ndarray], name: str, seed: int = 0
) -> float:
    """Estimate a noise standard deviation from the spread of data about a smoothing spline.

    As the thesis did for its field data: a cubic smoothing spline is fitted to each
    experiment's samples of one output, its smoothing chosen by generalised cross-validation,
    and the residual sum of squares is divided by the residual degrees of freedom
    ``n - tr(H)``. The trace of the (linear) smoother ``H`` is estimated by Hutchinson's method
    with Rademacher probes: two (the same at every level) while the smoothing is searched, on a
    coarse grid of seven levels and then by a bounded scalar search around the best, and eight at
    the level chosen.

    Parameters
    ----------
    time, values
        Per experiment: sample times [s] and values of the output.
    name
        Output name, for error messages.
    seed
        Seed of the random probes of the trace estimate.

    Returns
    -------
    float
        The pooled noise standard deviation, in the output's unit.

    """
    rng = np.random.default_rng(seed)
    rss = 0.0
    dof = 0.0
    for t, y in zip(time, values, strict=True):
        if t.size < 6:
            continue
        probes = rng.choice([-1.0, 1.0], size=(PROBES, t.size))
        scale = (t[-1] - t[0]) ** 3 / t.size
        search = _Gcv(t, y, probes[:SEARCH_PROBES])
        grid = np.linspace(-9.0, 3.0, 7) + np.log10(scale)
        scores = [search(x) for x in grid]
        k = int(np.argmin(scores))
        bounds = (grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)])
        refined = minimize_scalar(search, bounds=bounds, method="bounded", options={"xatol": 0.05})
        best = grid[k] if scores[k] <= refined.fun else float(refined.x)
        fit_rss, resid_dof = _Gcv(t, y, probes).parts(best)
        if resid_dof > 1.0:
            rss += fit_rss
            dof += resid_dof
    if dof <= 1.0 or rss <= 0.0:
        raise DataError(
            f"output {name!r}: too few samples (need at least 6 per experiment) to estimate sigma"
        )
    return float(np.sqrt(rss / dof))
