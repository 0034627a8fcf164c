"""Locate: the residual tests of a fit, the experiments' agreement, and where the misfit sits."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy import stats

from fmuid.discrepancy import residual_tests as rt
from fmuid.estimation.optimize import FitOptions, refine
from fmuid.estimation.predictor import merged_inputs
from fmuid.estimation.problem import Problem
from fmuid.estimation.result import FitResult
from fmuid.estimation.series import residual_series as fit_series


def residual_series(
    problem: Problem,
    values: dict[str, float],
    predictions: list[dict[str, np.ndarray]] | None = None,
) -> list[rt.Series]:
    """Weighted residuals of every experiment and output at ``values``, with the inputs.

    ``predictions`` (``problem.predict(values)``) is used when given instead of simulating.
    Series of fewer than two samples are left out (no test can use them).
    """
    inputs = {exp.name: merged_inputs(exp, problem.inputs) for exp in problem.experiments}
    out = []
    for s in fit_series(problem, values, predictions):
        if len(s.time) < 2:
            continue
        input_time, input_values = inputs[s.experiment]
        u = {name: np.interp(s.time, input_time, v) for name, v in input_values.items()}
        out.append(rt.Series(s.experiment, s.output, s.time, s.weighted, u))
    return out


NULL_DRAWS = 400
"""Draws of the fit's null residuals that calibrate the whiteness test."""

NULL_CHUNK = 50
"""Draws simulated at once (memory: this many times the number of residuals)."""


def whiteness_null(problem: Problem, jacobian: np.ndarray) -> dict[tuple[str, str], np.ndarray]:
    """Null draws of each series' whiteness statistic for a fit with this ``jacobian``.

    Under the model, the fit's weighted residuals are white noise less its projection on the
    sensitivities of the weighted predictions; each draw is that (seeded), cut into the
    problem's series (experiments, then outputs, as :meth:`Problem.residuals` orders them).
    """
    u, sv, _ = np.linalg.svd(np.asarray(jacobian, dtype=float), full_matrices=False)
    q = u[:, sv > 1e-10 * max(float(sv.max(initial=0.0)), 1e-300)]
    spans = []
    start = 0
    for i, exp in enumerate(problem.experiments):
        for j, output in enumerate(problem.outputs):
            n = int(np.count_nonzero(problem.masks[i][j]))
            if n >= 8:
                spans.append(((exp.name, output), slice(start, start + n), rt.lb_lags(n)))
            start += n
    if start != q.shape[0]:
        return {}
    rng = np.random.default_rng(0)
    draws: dict[tuple[str, str], list[np.ndarray]] = {key: [] for key, _, _ in spans}
    for k in range(0, NULL_DRAWS, NULL_CHUNK):
        e = rng.standard_normal((min(NULL_CHUNK, NULL_DRAWS - k), start))
        r = e - (e @ q) @ q.T
        for key, rows, lags in spans:
            draws[key].append(rt.ljung_box_null(r[:, rows], lags))
    return {key: np.concatenate(v) for key, v in draws.items()}


def sigma_known(problem: Problem) -> bool:
    """Whether every output's sigma is given (not estimated from the data)."""
    return all(m in ("given", "column") for m in problem.sigma_method.values())


def residual_tests(problem: Problem, fit: FitResult) -> list[rt.TestResult]:
    """Per-series residual tests of a fit and, when sigma is known, the global chi2 test."""
    series = residual_series(problem, fit.estimates)
    known = sigma_known(problem)
    tests = rt.series_tests(series, known, whiteness_null(problem, fit.jacobian))
    if known:
        tests.append(rt.global_goodness_of_fit(fit.chi2, fit.n_data, problem.n_free))
    return tests


def experiments_disagree(problem: Problem, fit: FitResult, max_nfev: int) -> rt.TestResult | None:
    """Likelihood-ratio test that every experiment shares the parameters.

    Each experiment is fitted alone, warm-started from the joint fit; the joint chi2 minus the
    sum of the separate ones is chi2 with (experiments - 1) x shared parameters df (those not
    already one per experiment; conservative when a single experiment leaves parameters
    unidentifiable). A concealed effect often shows here:
    each experiment hides it with other parameter values.
    """
    shared = problem.shared_names
    if len(problem.experiments) < 2 or not shared:
        return None
    separate = 0.0
    z0 = fit.z_estimate()
    for i, exp in enumerate(problem.experiments):
        one = Problem(
            problem.fmu_path,
            [exp],
            problem.spec,
            predictor=problem.predictor,
            parameters=problem.parameter_specs,
            sigma=[problem.sigma[i]],
            sigma_method=problem.sigma_method,
            model=problem.model,
        )
        _, chi2, _ = refine(one, z0, options=FitOptions(ftol=1e-8, max_nfev=max_nfev))
        separate += chi2
    stat = max(fit.chi2 - separate, 0.0)
    df = (len(problem.experiments) - 1) * len(shared)
    p = float(stats.chi2.sf(stat, df))
    return rt.TestResult("experiments_disagree", None, None, p, stat, df)


def location(
    problem: Problem, fit: FitResult, evidence: Sequence[rt.TestResult]
) -> tuple[dict[str, Any], list[rt.Window]]:
    """Return the outputs, experiments, time windows and band the evidence points to.

    Without evidence on a particular series (a mismatch found by the scan or the experiments'
    agreement), every series is searched.
    """
    pairs = {(t.experiment, t.output) for t in evidence if t.output is not None}
    series = residual_series(problem, fit.estimates)
    if not pairs:
        pairs = {(s.experiment, s.output) for s in series}
    chosen = [s for s in series if (s.experiment, s.output) in pairs]
    found = [w for s in chosen for w in rt.windows(s)]
    bands = [b for s in chosen if (b := rt.spectrum_band(s)) is not None]
    spans = sorted([w.start, w.end] for w in found)
    merged: list[list[float]] = []
    for span in spans:
        if merged and span[0] <= merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], span[1])
        else:
            merged.append(list(span))
    band = max(bands, key=lambda b: b[2]) if bands else None
    where = {
        "basis": "residuals",
        "outputs": sorted({o for _, o in pairs}),
        "experiments": [e.name for e in problem.experiments if e.name in {x for x, _ in pairs}],
        "time_windows": merged,
        "frequency_hz": [band[0], band[1]] if band else None,
    }
    return where, found


def effect_location(
    before: Sequence[rt.Series], after: Sequence[rt.Series], width_s: float = 2.0
) -> dict[str, Any]:
    """Where the named effect acts: the chi2 it removes, by output, experiment and time.

    A concealed effect leaves no trace in the base residuals; what locates it is where the
    augmented model's predictions differ from the base model's. ``before`` and ``after`` are
    the weighted residual series of the base and augmented fits (same order).

    Returns
    -------
    dict
        ``outputs`` and ``experiments`` holding at least a fifth of the chi2 removed,
        ``time_windows`` (up to three non-overlapping windows of ``width_s`` seconds with the
        largest gain), ``frequency_hz`` (the band holding the middle 80 % of the power of the
        prediction change) and the ``chi2_gain`` per ``experiment/output``.

    """
    gains: dict[tuple[str, str], float] = {}
    windows: list[tuple[float, float, float]] = []
    power: dict[float, float] = {}
    for b, a in zip(before, after):
        gain = b.residuals**2 - a.residuals**2
        gains[(b.experiment, b.output)] = float(gain.sum())
        dt = float(np.median(np.diff(b.time)))
        w = max(1, min(len(gain), int(round(width_s / dt))))
        sums = np.convolve(gain, np.ones(w), mode="valid")
        for i in np.argsort(sums)[::-1][:3]:
            windows.append((float(sums[i]), float(b.time[i]), float(b.time[i + w - 1])))
        change = b.residuals - a.residuals
        spectrum = np.abs(np.fft.rfft(change - change.mean())) ** 2
        for f, p in zip(np.fft.rfftfreq(len(change), dt), spectrum):
            power[round(float(f), 6)] = power.get(round(float(f), 6), 0.0) + float(p)
    total = sum(gains.values()) or 1.0
    by_output: dict[str, float] = {}
    by_experiment: dict[str, float] = {}
    for (e, o), g in gains.items():
        by_output[o] = by_output.get(o, 0.0) + g / total
        by_experiment[e] = by_experiment.get(e, 0.0) + g / total
    chosen: list[tuple[float, float, float]] = []
    for gain, start, end in sorted(windows, reverse=True):
        if gain > 0 and all(end < s or start > e for _, s, e in chosen) and len(chosen) < 3:
            chosen.append((gain, start, end))
    freqs = np.array(sorted(power))
    cumulative = np.cumsum([power[f] for f in freqs])
    band = None
    if len(freqs) and cumulative[-1] > 0:
        lo = freqs[np.searchsorted(cumulative, 0.1 * cumulative[-1])]
        hi = freqs[min(np.searchsorted(cumulative, 0.9 * cumulative[-1]), len(freqs) - 1)]
        band = [float(lo), float(hi)]
    return {
        "basis": "effect",
        "outputs": sorted(o for o, s in by_output.items() if s >= 0.2),
        "experiments": [e for e, s in by_experiment.items() if s >= 0.2],
        "time_windows": [[s, e] for _, s, e in sorted(chosen, key=lambda c: c[1])],
        "frequency_hz": band,
        "chi2_gain": {f"{e}/{o}": g for (e, o), g in gains.items()},
    }
