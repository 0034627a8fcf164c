"""Figures of a diagnosis: fit overlay, residuals with the located windows, residual spectrum.

They only draw what :func:`fmuid.discrepancy.series.diagnosis_series` simulated. Each figure has
one panel per output and experiment; ``ax=`` takes them row by row (one row per output, one
column per experiment, as ``plt.subplots(n_outputs, n_experiments)`` gives them).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from scipy import stats

from fmuid.discrepancy.residual_tests import FALSE_ALARM, Series, periodogram
from fmuid.discrepancy.result import Diagnosis
from fmuid.discrepancy.series import DiagnosisSeries
from fmuid.plots._common import AxesArg, panels, plain_log_ticks, unit_label

SMOOTH = 5
"""Periodogram ordinates averaged in the spectrum figure (as in the band test)."""


def diagnosis_figures(diagnosis: Diagnosis, series: DiagnosisSeries) -> dict[str, Figure]:
    """Return the diagnosis figures of a report: ``fit``, ``residuals`` and ``spectrum``.

    Parameters
    ----------
    diagnosis
        The result of ``fmuid.diagnose``.
    series
        What to draw (:func:`fmuid.discrepancy.series.diagnosis_series`); nothing is simulated here.

    Returns
    -------
    dict of str to matplotlib.figure.Figure
        :func:`diagnosis_fit_figure`, :func:`diagnosis_residual_figure` and
        :func:`diagnosis_spectrum_figure`, each in a new figure.
    """
    return {
        "fit": diagnosis_fit_figure(series, augmented=bool(diagnosis.added_parameters)),
        "residuals": diagnosis_residual_figure(diagnosis, series),
        "spectrum": diagnosis_spectrum_figure(diagnosis, series),
    }


def diagnosis_fit_figure(
    series: DiagnosisSeries, *, ax: AxesArg = None, augmented: bool = True
) -> Figure:
    """Draw the data, the base model's and the augmented model's outputs.

    Parameters
    ----------
    series
        What to draw (:func:`fmuid.discrepancy.series.diagnosis_series`).
    augmented
        Whether the diagnosis added physics; without, the one model is drawn as ``model``.
    ax
        Draw into these axes instead of a new figure: ``n_outputs * n_experiments`` of them,
        row by row (one row per output, one column per experiment).

    Returns
    -------
    Figure
        One panel per output and experiment (the figure holding ``ax`` when given).

    Raises
    ------
    ValueError
        If ``ax`` does not hold one axes per output and experiment.

    """
    problem = series.problem
    outputs, experiments = list(problem.outputs), [e.name for e in problem.experiments]
    fig, axes, new = _grid(ax, outputs, experiments, "diagnosis_fit_figure")
    units = problem.units()
    for i, exp in enumerate(problem.experiments):
        for j, output in enumerate(problem.outputs):
            panel = axes[j * len(experiments) + i]
            mask = problem.masks[i][j]
            panel.plot(exp.time[mask], problem.data[i][j], ".", ms=3, color="0.4", label="data")
            if augmented:
                panel.plot(
                    exp.time, series.before[i][output], "--", color="tab:red", label="base model"
                )
                panel.plot(
                    exp.time, series.after[i][output], "-", color="tab:blue", label="augmented"
                )
            else:
                panel.plot(exp.time, series.before[i][output], "-", color="tab:red", label="model")
            panel.set_title(f"{exp.name}: {output}", fontsize=9)
            panel.set_xlabel("time [s]")
            panel.set_ylabel(unit_label(output, units.get(output, "")))
    axes[0].legend(fontsize=7)
    if new:
        fig.suptitle("Fit before and after the augmentation" if augmented else "Fit")
    return fig


def diagnosis_residual_figure(
    diagnosis: Diagnosis, series: DiagnosisSeries, *, ax: AxesArg = None
) -> Figure:
    """Draw the weighted residuals before and after the augmentation, the located windows shaded.

    The shaded windows are those of ``diagnosis.location`` (what the report's location table
    states), on the panels of the experiments and outputs it names.

    Parameters
    ----------
    diagnosis
        The result of ``fmuid.diagnose`` (its location and added parameters).
    series, ax
        As for :func:`diagnosis_fit_figure`: what to draw, and optionally the axes to draw
        into (one per output and experiment, row by row).

    Returns
    -------
    Figure
        One panel per output and experiment (the figure holding ``ax`` when given); a wrong
        number of axes is a ``ValueError``.

    """
    where = diagnosis.location or {}
    spans = where.get("time_windows") or []

    def draw(panel: Axes, s: Series, after: Series | None) -> None:
        if s.experiment in (where.get("experiments") or []) and s.output in (
            where.get("outputs") or []
        ):
            for start, end in spans:
                panel.axvspan(start, end, color="gold", alpha=0.4, lw=0, gid="window")
        for curve, color, label in _curves(s, after):
            panel.plot(curve.time, curve.residuals, ".-", ms=2, lw=0.5, color=color, label=label)
        panel.axhline(0, color="k", lw=0.5)
        panel.set_xlabel("time [s]")
        panel.set_ylabel("weighted residual")

    title = "Weighted residuals (shaded: located windows)"
    return _per_series(ax, diagnosis, series, "diagnosis_residual_figure", title, draw)


def diagnosis_spectrum_figure(
    diagnosis: Diagnosis, series: DiagnosisSeries, *, ax: AxesArg = None
) -> Figure:
    """Draw the residual spectrum (smoothed periodogram) against the white-noise floor.

    Parameters
    ----------
    diagnosis
        The result of ``fmuid.diagnose`` (its located frequency band and added parameters).
    series, ax
        As for :func:`diagnosis_fit_figure`.

    Returns
    -------
    Figure
        One panel per output and experiment (the figure holding ``ax`` when given); a wrong
        number of axes is a ``ValueError``.

    """
    band = diagnosis.location.get("frequency_hz")

    def draw(panel: Axes, s: Series, after: Series | None) -> None:
        n_freq = 0
        for curve, color, label in _curves(s, after):
            freq, power = periodogram(curve)
            n_freq = n_freq or len(power)
            smooth = np.convolve(power, np.ones(SMOOTH) / SMOOTH, mode="same")
            panel.semilogy(freq, smooth, color=color, label=label, gid=f"spectrum_{label}")
        plain_log_ticks(panel.yaxis)
        k = max(1, n_freq // SMOOTH)
        level = stats.gamma.isf(FALSE_ALARM / k, SMOOTH, scale=1.0 / SMOOTH)
        panel.axhline(1.0, color="k", lw=0.8, label="white-noise floor")
        panel.axhline(level, color="k", lw=0.8, ls=":", label="significance")
        if band:
            panel.axvspan(band[0], band[1], color="gold", alpha=0.3, lw=0)
        panel.set_xlabel("frequency [Hz]")

    title = "Residual spectrum against the noise floor"
    return _per_series(ax, diagnosis, series, "diagnosis_spectrum_figure", title, draw)


def _curves(before: Series, after: Series | None) -> list[tuple[Series, str, str]]:
    """Return the residual series to draw in one panel, with colour and label."""
    curves = [(before, "tab:red", "base")]
    if after is not None:
        curves.append((after, "tab:blue", "augmented"))
    return curves


def _per_series(
    ax: AxesArg,
    diagnosis: Diagnosis,
    series: DiagnosisSeries,
    what: str,
    title: str,
    draw: Callable[[Axes, Series, Series | None], None],
) -> Figure:
    """Draw each residual series (and its augmented counterpart, if any) into its panel."""
    before = series.residuals_before
    after_by = {(s.experiment, s.output): s for s in series.residuals_after}
    fig, panel_of, new = _series_grid(ax, before, what)
    for s in before:
        panel = panel_of[(s.experiment, s.output)]
        after = after_by.get((s.experiment, s.output)) if diagnosis.added_parameters else None
        draw(panel, s, after)
        panel.set_title(f"{s.experiment}: {s.output}", fontsize=9)
    if before:
        panel_of[(before[0].experiment, before[0].output)].legend(fontsize=7)
    if new:
        fig.suptitle(title)
    return fig


def _grid(
    ax: AxesArg, outputs: list[str], experiments: list[str], what: str
) -> tuple[Figure, list[Axes], bool]:
    """Axes of one panel per (output row, experiment column), flattened row by row."""
    shape = f"{what}: {len(outputs)} outputs x {len(experiments)} experiments, row by row"
    n = len(outputs) * len(experiments)
    return panels(ax, n, shape, ncols=max(1, len(experiments)), panel_size=(4.5, 2.5))


def _series_grid(
    ax: AxesArg, series: Sequence[Series], what: str
) -> tuple[Figure, dict[tuple[str, str], Axes], bool]:
    """Make or take the panel grid of ``series`` and the panel of each (experiment, output)."""
    pairs = list(dict.fromkeys((s.experiment, s.output) for s in series))
    experiments = list(dict.fromkeys(e for e, _ in pairs))
    outputs = list(dict.fromkeys(o for _, o in pairs))
    fig, axes, new = _grid(ax, outputs, experiments, what)
    lookup = {
        (e, o): axes[outputs.index(o) * len(experiments) + experiments.index(e)] for e, o in pairs
    }
    return fig, lookup, new
