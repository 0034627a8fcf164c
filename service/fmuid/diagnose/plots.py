"""Figures of a diagnosis: fit overlay, residuals with the located windows, residual spectrum."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from scipy import stats

from fmuid.diagnose.catalogue import study_catalogue
from fmuid.diagnose.locate import residual_series
from fmuid.diagnose.residual_tests import FALSE_ALARM, Series, periodogram
from fmuid.diagnose.result import Diagnosis
from fmuid.diagnose.scan import augmented
from fmuid.fit.problem import Problem

SMOOTH = 5
"""Periodogram ordinates averaged in the spectrum figure (as in the band test)."""


def augmented_problem_of(problem: Problem, diagnosis: Diagnosis) -> Problem:
    """Rebuild the augmented problem of a diagnosis (the base problem if nothing was added).

    Parameters
    ----------
    problem
        The base problem that was diagnosed.
    diagnosis
        Its diagnosis; the candidates whose parameters it added are switched on.
    """
    if not diagnosis.added_parameters:
        return problem
    cands = study_catalogue(problem)
    added = set(diagnosis.added_parameters)
    chosen = [c for c in cands if set(c.names) <= added]
    return augmented(problem, chosen, problem.spec.confidence)


def figures(
    diagnosis: Diagnosis, problem_before: Problem, problem_after: Problem | None = None
) -> dict[str, Figure]:
    """Return the diagnosis figures: ``fit``, ``residuals`` and ``spectrum``.

    Parameters
    ----------
    diagnosis
        The result of ``fmuid.diagnose``.
    problem_before
        The base problem (spec's free parameters).
    problem_after
        The augmented problem; rebuilt from the diagnosis when ``None``.

    Returns
    -------
    dict of str to matplotlib.figure.Figure
        One row per output, one column per experiment in each figure.
    """
    after = problem_after or augmented_problem_of(problem_before, diagnosis)
    before_values = {n: diagnosis.parameters_before[n] for n in problem_before.names}
    after_values = {n: diagnosis.parameters_after[n] for n in after.names}
    series_before = residual_series(problem_before, before_values)
    series_after = residual_series(after, after_values)
    return {
        "fit": _fit_figure(problem_before, after, before_values, after_values),
        "residuals": _residual_figure(diagnosis, series_before, series_after),
        "spectrum": _spectrum_figure(diagnosis, series_before, series_after),
    }


def _grid(problem: Problem) -> tuple[Figure, np.ndarray]:
    rows, cols = len(problem.outputs), len(problem.experiments)
    fig = Figure(figsize=(4.5 * cols, 2.6 * rows), layout="constrained")
    axes = np.atleast_2d(fig.subplots(rows, cols, squeeze=False))
    return fig, axes


def _fit_figure(
    before: Problem, after: Problem, before_values: dict[str, float], after_values: dict[str, float]
) -> Figure:
    fig, axes = _grid(before)
    y_before = before.predict(before_values)
    y_after = after.predict(after_values)
    units = before.units()
    for i, exp in enumerate(before.experiments):
        for j, output in enumerate(before.outputs):
            ax = axes[j, i]
            mask = before.masks[i][j]
            ax.plot(exp.time[mask], before.data[i][j], ".", ms=3, color="0.4", label="data")
            ax.plot(exp.time, y_before[i][output], "--", color="tab:red", label="base model")
            ax.plot(exp.time, y_after[i][output], "-", color="tab:blue", label="augmented")
            ax.set_title(f"{exp.name}: {output}", fontsize=9)
            ax.set_xlabel("time [s]")
            unit = units.get(output)
            ax.set_ylabel(f"{output} [{unit}]" if unit else output)
    axes[0, 0].legend(fontsize=7)
    fig.suptitle("Fit before and after the augmentation")
    return fig


def _series_grid(series: list[Series]) -> tuple[Figure, Callable[[Series], Axes]]:
    """Make a figure with one panel per (output row, experiment column) and a panel lookup."""
    pairs = list(dict.fromkeys((s.experiment, s.output) for s in series))
    experiments = list(dict.fromkeys(e for e, _ in pairs))
    outputs = list(dict.fromkeys(o for _, o in pairs))
    fig = Figure(figsize=(4.5 * len(experiments), 2.4 * len(outputs)), layout="constrained")
    axes = np.atleast_2d(fig.subplots(len(outputs), len(experiments), squeeze=False))

    def axes_of(s: Series) -> Axes:
        return axes[outputs.index(s.output), experiments.index(s.experiment)]

    return fig, axes_of


def _residual_figure(diagnosis: Diagnosis, before: list[Series], after: list[Series]) -> Figure:
    fig, axes_of = _series_grid(before)
    after_by = {(s.experiment, s.output): s for s in after}
    for s in before:
        ax = axes_of(s)
        for w in diagnosis.windows:
            if w.experiment == s.experiment and w.output == s.output:
                ax.axvspan(w.start, w.end, color="gold", alpha=0.4, lw=0)
        ax.plot(s.time, s.residuals, ".-", ms=2, lw=0.5, color="tab:red", label="base")
        a = after_by.get((s.experiment, s.output))
        if a is not None and diagnosis.added_parameters:
            ax.plot(a.time, a.residuals, ".-", ms=2, lw=0.5, color="tab:blue", label="augmented")
        ax.axhline(0, color="k", lw=0.5)
        ax.set_title(f"{s.experiment}: {s.output}", fontsize=9)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("weighted residual")
    fig.axes[0].legend(fontsize=7)
    fig.suptitle("Weighted residuals (shaded: located windows)")
    return fig


def _spectrum_figure(diagnosis: Diagnosis, before: list[Series], after: list[Series]) -> Figure:
    fig, axes_of = _series_grid(before)
    after_by = {(s.experiment, s.output): s for s in after}
    band = diagnosis.location.get("frequency_hz")
    for s in before:
        ax = axes_of(s)
        curves = [(s, "tab:red", "base")]
        a = after_by.get((s.experiment, s.output))
        if a is not None and diagnosis.added_parameters:
            curves.append((a, "tab:blue", "augmented"))
        n_freq = 0
        for series, color, label in curves:
            freq, power = periodogram(series)
            n_freq = n_freq or len(power)
            smooth = np.convolve(power, np.ones(SMOOTH) / SMOOTH, mode="same")
            ax.semilogy(freq, smooth, color=color, label=label)
        k = max(1, n_freq // SMOOTH)
        level = stats.gamma.isf(FALSE_ALARM / k, SMOOTH, scale=1.0 / SMOOTH)
        ax.axhline(1.0, color="k", lw=0.8, label="white-noise floor")
        ax.axhline(level, color="k", lw=0.8, ls=":", label="significance")
        if band:
            ax.axvspan(band[0], band[1], color="gold", alpha=0.3, lw=0)
        ax.set_title(f"{s.experiment}: {s.output}", fontsize=9)
        ax.set_xlabel("frequency [Hz]")
    fig.axes[0].legend(fontsize=7)
    fig.suptitle("Residual spectrum against the noise floor")
    return fig
