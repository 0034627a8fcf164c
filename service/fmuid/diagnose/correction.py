"""Generic data-driven correction: how much of a misfit is structure the inputs explain.

When no catalogue entry removes a mismatch, the weighted residuals of each output are fitted by
a low-order ARX model, pooled over the experiments,

    r(t) = a1 r(t-1) + a2 r(t-2) + sum_k b_k u(t - k dt_u) + c + e(t),

(one-step-ahead prediction; ``u`` each input, lags up to 2 s). The chi2 of ``e`` against the
chi2 of ``r`` tells how much of the misfit is predictable structure, and a likelihood-ratio
(F) test says whether that part is significant.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy import stats

from fmuid.diagnose.residual_tests import Series, lagged

AR_ORDER = 2
"""Autoregressive order of the correction."""

INPUT_LAGS = 10
"""Number of input lags, spread over :data:`INPUT_SPAN` seconds."""

INPUT_SPAN = 2.0
"""Longest input lag [s]."""


def arx_correction(series: Sequence[Series]) -> dict[str, Any]:
    """Fit the ARX correction per output and report the misfit it removes.

    Parameters
    ----------
    series
        Weighted residuals of the fit, per experiment and output.

    Returns
    -------
    dict
        ``model`` (description), ``chi2_before``, ``chi2_after``, ``n_parameters``,
        ``n_data``, ``noise_chi2`` (what noise alone would leave: ``n_data - n_parameters``),
        ``structure_fraction`` ((before - after) / before) and ``p_value`` (F test of the
        correction against none), plus the same per output under ``outputs``.

    """
    per_output: dict[str, dict[str, float]] = {}
    total_before = total_after = 0.0
    total_k = 0
    total_n = 0
    for output in dict.fromkeys(s.output for s in series):
        rows, targets = [], []
        for s in series:
            if s.output != output or len(s.residuals) <= AR_ORDER + 2:
                continue
            rows.append(_regressors(s))
            targets.append(s.residuals)
        if not rows:
            continue
        phi = np.vstack(rows)
        y = np.concatenate(targets)
        coef, _, rank, _ = np.linalg.lstsq(phi, y, rcond=1e-8)
        before = float(y @ y)
        resid = y - phi @ coef
        after = float(resid @ resid)
        n = len(y)
        f_stat = ((before - after) / rank) / (after / max(n - rank, 1)) if after > 0 else np.inf
        per_output[output] = {
            "chi2_before": before,
            "chi2_after": after,
            "n_parameters": int(rank),
            "p_value": float(stats.f.sf(f_stat, rank, max(n - rank, 1))),
        }
        total_before += before
        total_after += after
        total_k += int(rank)
        total_n += n
    f_all = ((total_before - total_after) / max(total_k, 1)) / (
        total_after / max(total_n - total_k, 1)
    )
    return {
        "model": f"ARX({AR_ORDER}, {INPUT_LAGS}) of the weighted residuals per output, "
        f"input lags up to {INPUT_SPAN} s",
        "chi2_before": total_before,
        "chi2_after": total_after,
        "n_parameters": total_k,
        "n_data": total_n,
        "noise_chi2": float(total_n - total_k),
        "structure_fraction": (total_before - total_after) / total_before if total_before else 0.0,
        "p_value": float(stats.f.sf(f_all, max(total_k, 1), max(total_n - total_k, 1))),
        "outputs": per_output,
    }


def _regressors(s: Series) -> np.ndarray:
    """ARX regressors of one series: past residuals, lagged inputs, a constant."""
    r = s.residuals
    cols = [np.concatenate([np.zeros(k), r[:-k]]) for k in range(1, AR_ORDER + 1)]
    dt = float(np.median(np.diff(s.time)))
    step = max(1, int(round(INPUT_SPAN / dt / (INPUT_LAGS - 1))))
    for u in s.inputs.values():
        cols.extend(lagged(u, [k * step for k in range(INPUT_LAGS)]).T)
    cols.append(np.ones(len(r)))
    return np.column_stack(cols)
