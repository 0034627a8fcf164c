"""Measurement noise levels estimated from the data."""

from __future__ import annotations

import numpy as np
from scipy.interpolate import make_smoothing_spline

from fmuid.errors import DataError

SPLINE_METHOD = "estimate: residual spread about a cubic smoothing spline (GCV), dof-corrected"


def spline_residual_sigma(
    time: list[np.ndarray], values: list[np.ndarray], name: str, seed: int = 0
) -> float:
    """Estimate a noise standard deviation from the spread of data about a smoothing spline.

    As the thesis did for its field data: a cubic smoothing spline is fitted to each
    experiment's samples of one output, its smoothing chosen by generalised cross-validation,
    and the residual sum of squares is divided by the residual degrees of freedom
    ``n - tr(H)``. The trace of the (linear) smoother ``H`` is estimated by Hutchinson's method
    with Rademacher probes.

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
        probes = rng.choice([-1.0, 1.0], size=(8, t.size))
        best = (np.inf, 0.0, 0.0)
        scale = (t[-1] - t[0]) ** 3 / t.size
        for lam in np.logspace(-9, 3, 25) * scale:
            fit_rss = float(np.sum((y - make_smoothing_spline(t, y, lam=lam)(t)) ** 2))
            trace = float(np.mean([p @ make_smoothing_spline(t, p, lam=lam)(t) for p in probes]))
            resid_dof = t.size - trace
            if resid_dof <= 1.0:
                continue
            gcv = t.size * fit_rss / resid_dof**2
            if gcv < best[0]:
                best = (gcv, fit_rss, resid_dof)
        rss += best[1]
        dof += best[2]
    if dof <= 1.0 or rss <= 0.0:
        raise DataError(
            f"output {name!r}: too few samples (need at least 6 per experiment) to estimate sigma"
        )
    return float(np.sqrt(rss / dof))
