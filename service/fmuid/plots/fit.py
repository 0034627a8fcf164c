"""Fit overlay and residual diagnostics (thesis Figs 3.11, 3.12)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure
from scipy import stats

from fmuid.estimation.series import ResidualSeries
from fmuid.plots._common import DATA_COLOR, MODEL_COLOR, AxesArg, panels, unit_label

PANELS_PER_SERIES = 4


def fit_figure(series: Sequence[ResidualSeries], *, ax: AxesArg = None) -> Figure:
    """Draw data against the fitted model and the weighted residuals' diagnostics.

    One row per experiment and fitted output with four panels: the time history (data as
    blue dots, model as a red line), the weighted residuals ``(data - model) / sigma`` against
    time, their normal Q-Q plot (with the line y = x) and their histogram with the standard
    normal density.

    Parameters
    ----------
    series
        Data and model of each experiment and output:
        ``fmuid.estimation.series.residual_series(problem, fit.estimates)``.
    ax
        Draw into these axes instead of a new figure: ``4 * len(series)`` of them, in the
        order above (time history, residuals, Q-Q, histogram of the first series, then of the
        next), e.g. ``plt.subplots(len(series), 4)[1]``.

    Returns
    -------
    Figure
        ``4 * len(series)`` panels (the figure holding ``ax`` when given).

    Raises
    ------
    ValueError
        If ``ax`` does not hold ``4 * len(series)`` axes.

    """
    n = PANELS_PER_SERIES * len(series)
    what = f"fit_figure: 4 per residual series, {len(series)} series"
    fig, axes, _ = panels(ax, n, what, ncols=4, panel_size=(3.5, 2.8))
    for k, s in enumerate(series):
        ax_t, ax_r, ax_q, ax_h = axes[PANELS_PER_SERIES * k : PANELS_PER_SERIES * (k + 1)]
        ax_t.plot(s.time, s.data, ".", color=DATA_COLOR, ms=4, label="data", gid="data")
        order = np.argsort(s.time)
        ax_t.plot(
            s.time[order], s.model[order], color=MODEL_COLOR, lw=1.3, label="model", gid="model"
        )
        ax_t.set_title(f"{s.experiment}: {s.output}", fontsize=9)
        ax_t.set_xlabel("time [s]")
        ax_t.set_ylabel(unit_label(s.output, s.unit))
        ax_t.legend(fontsize=7)
        ax_r.axhline(0.0, color="0.5", lw=0.8)
        ax_r.plot(s.time, s.weighted, ".", color=DATA_COLOR, ms=4, gid="residuals")
        ax_r.set_xlabel("time [s]")
        ax_r.set_ylabel("weighted residual")
        theo, ordered = _qq(s.weighted)
        ax_q.plot(theo, ordered, ".", color=DATA_COLOR, ms=4, gid="qq")
        if theo.size:
            lim = [min(theo[0], ordered[0]), max(theo[-1], ordered[-1])]
            ax_q.plot(lim, lim, color=MODEL_COLOR, lw=1.0, gid="qq_line")
        ax_q.set_xlabel("normal quantile")
        ax_q.set_ylabel("residual quantile")
        ax_q.set_title("Q-Q plot", fontsize=9)
        ax_h.hist(s.weighted, bins="auto", density=True, color=DATA_COLOR, alpha=0.7)
        grid_x = np.linspace(-4.0, 4.0, 200)
        ax_h.plot(grid_x, stats.norm.pdf(grid_x), color=MODEL_COLOR, lw=1.0)
        ax_h.set_xlabel("weighted residual")
        ax_h.set_title("histogram", fontsize=9)
    return fig


def _qq(residuals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return normal quantiles (Blom plotting positions) and the sorted residuals."""
    n = residuals.size
    ordered = np.sort(residuals)
    theo = stats.norm.ppf((np.arange(1, n + 1) - 0.375) / (n + 0.25))
    return theo, ordered
