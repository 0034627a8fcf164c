"""Matplotlib figures drawn from fmuid results; every function returns a ``Figure``.

Plot functions never simulate: they draw results and the data objects that the engine makes
(``fmuid.estimation.series.residual_series``, ``fmuid.profiling.band.trajectory_band``,
``fmuid.discrepancy.series.diagnosis_series``; a discrimination proposal carries its predictions).

Every function takes ``ax=``: by default it draws a new figure; given axes, it draws into them
and returns the figure that holds them. A one-panel plot takes one ``Axes``; a plot of several
panels takes a sequence or array of ``Axes`` with exactly one per panel, flattened row by row
(so ``fig.subplots(rows, cols)`` or ``subfig.subplots(...)`` can be passed as it is). Each
docstring says how many panels and in which order; a wrong count is a ``ValueError`` naming the
number needed. A figure of its own gets a title; given axes keep the caller's figure title.

The figures follow the thesis: profile likelihoods (Figs 2.8, 3.3), parameter paths along a
profile (Fig 2.9), trajectory bands (Figs 2.12, 3.5) and fit overlays with residual diagnostics
(Figs 3.11, 3.12); the thesis study's confidence-interval compilations (Figs 3.4, 3.9, 3.10)
are drawn by :mod:`fmuid.demo.compilation`. Figures are
built on ``matplotlib.figure.Figure`` directly (Agg canvas, no pyplot state) and never shown.
"""

from fmuid.plots.design import discrimination_figure, widths_figure
from fmuid.plots.diagnosis import (
    diagnosis_figures,
    diagnosis_fit_figure,
    diagnosis_residual_figure,
    diagnosis_spectrum_figure,
)
from fmuid.plots.fit import fit_figure
from fmuid.plots.profile import parameter_paths_figure, profile_figure
from fmuid.plots.trajectory import trajectory_band_figure

__all__ = [
    "diagnosis_figures",
    "diagnosis_fit_figure",
    "diagnosis_residual_figure",
    "diagnosis_spectrum_figure",
    "discrimination_figure",
    "fit_figure",
    "parameter_paths_figure",
    "profile_figure",
    "trajectory_band_figure",
    "widths_figure",
]
