"""Generic data-driven correction: how much of a misfit is structure the inputs explain.

When no catalogue entry removes a mismatch, the weighted residuals of each output are fitted by
a low-order ARX model, pooled over the experiments,

    r(t) = a1 r(t-1) + a2 r(t-2) + sum_k b_k u(t - k dt_u) + c + e(t),

(one-step-ahead prediction; ``u`` each input, lags up to 2 s). The chi2 of ``e`` against the
chi2 of ``r`` tells how much of the misfit is predictable structure, and a likelihood-ratio
(F) test says whether that part is significant. The share of the misfit that is structure is
counted above the noise floor (``n - k``: what noise alone leaves after ``k`` coefficients);
when the correction reaches below that floor it fits noise and no share is given.

The residual dynamics are described from the same fit: the frequency and damping ratio of the
autoregressive pole pair (an extra mode the model lacks), the band where the residual spectrum
rises above the noise floor, and which output's residual leads another (the lag of the largest
cross-correlation between two outputs of one experiment).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy import stats

from fmuid.discrepancy.residual_tests import Series, lagged, spectrum_band

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
    per_output: dict[str, dict[str, Any]] = {}
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
        dt = float(
            np.median(np.concatenate([np.diff(s.time) for s in series if s.output == output]))
        )
        per_output[output] = {
            "chi2_before": before,
            "chi2_after": after,
            "n_parameters": int(rank),
            "p_value": float(stats.f.sf(f_stat, rank, max(n - rank, 1))),
            "mode": _mode(coef[:AR_ORDER], dt),
        }
        total_before += before
        total_after += after
        total_k += int(rank)
        total_n += n
    f_all = ((total_before - total_after) / max(total_k, 1)) / (
        total_after / max(total_n - total_k, 1)
    )
    floor = float(total_n - total_k)
    share = None
    if total_before > floor and total_after >= floor:
        share = (total_before - total_after) / (total_before - floor)
    return {
        "model": f"ARX({AR_ORDER}, {INPUT_LAGS}) of the weighted residuals per output, "
        f"input lags up to {INPUT_SPAN} s",
        "chi2_before": total_before,
        "chi2_after": total_after,
        "n_parameters": total_k,
        "n_data": total_n,
        "noise_chi2": floor,
        "structure_fraction": share,
        "p_value": float(stats.f.sf(f_all, max(total_k, 1), max(total_n - total_k, 1))),
        "outputs": per_output,
        "dynamics": dynamics(series, per_output),
    }


def _mode(ar: np.ndarray, dt: float) -> dict[str, float] | None:
    """Frequency [Hz] and damping ratio of the AR pole pair, when it is oscillatory and stable."""
    poles = np.roots(np.concatenate([[1.0], -np.asarray(ar, dtype=float)]))
    complex_poles = [p for p in poles if p.imag > 1e-9 and 0 < abs(p) < 1]
    if not complex_poles:
        return None
    s = np.log(complex_poles[0]) / dt
    return {"frequency_hz": float(abs(s) / (2 * np.pi)), "damping": float(-s.real / abs(s))}


def _lead(series: Sequence[Series], max_lag_s: float = 2.0) -> dict[str, Any] | None:
    """Return the pair of outputs of one experiment that correlate most at a non-zero lag."""
    best: dict[str, Any] | None = None
    for a in series:
        for b in series:
            if a.experiment != b.experiment or a.output >= b.output or len(a.time) != len(b.time):
                continue
            dt = float(np.median(np.diff(a.time)))
            lags = range(-int(max_lag_s / dt), int(max_lag_s / dt) + 1)
            ra, rb = a.residuals - a.residuals.mean(), b.residuals - b.residuals.mean()
            norm = float(np.linalg.norm(ra) * np.linalg.norm(rb)) or 1.0
            corr = {
                k: float(
                    ra[max(0, -k) : len(ra) - max(0, k)] @ rb[max(0, k) : len(rb) - max(0, -k)]
                )
                / norm
                for k in lags
            }
            k = max(corr, key=lambda j: abs(corr[j]))
            if k != 0 and (best is None or abs(corr[k]) > best["correlation"]):
                leader, other = (a.output, b.output) if k > 0 else (b.output, a.output)
                best = {
                    "output": leader,
                    "other": other,
                    "seconds": abs(k) * dt,
                    "correlation": abs(corr[k]),
                    "experiment": a.experiment,
                }
    return best


def dynamics(series: Sequence[Series], per_output: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """Describe the residual dynamics: extra mode, frequency band, which output leads."""
    ranked = sorted(
        per_output, key=lambda o: per_output[o]["chi2_after"] - per_output[o]["chi2_before"]
    )
    mode = next((per_output[o]["mode"] for o in ranked if per_output[o]["mode"]), None)
    bands = [(b, s.output) for s in series if (b := spectrum_band(s)) is not None]
    band = max(bands, key=lambda x: x[0][2]) if bands else None
    return {
        "mode": mode,
        "frequency_hz": [band[0][0], band[0][1]] if band else None,
        "band_output": band[1] if band else None,
        "leads": _lead(series),
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
