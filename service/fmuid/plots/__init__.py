"""Matplotlib figures drawn from fmuid results; every function returns a ``Figure``.

Plot functions never simulate: they draw results and the data objects that the engine makes
(``fmuid.fit.series.residual_series``, ``fmuid.profile.band.trajectory_band``). Single-panel
plots take ``ax=`` to draw into a given ``matplotlib`` axes.

The figures follow the thesis: profile likelihoods (Figs 2.8, 3.3), parameter paths along a
profile (Fig 2.9), confidence-interval compilations (Figs 3.4, 3.9, 3.10), trajectory bands
(Figs 2.12, 3.5) and fit overlays with residual diagnostics (Figs 3.11, 3.12). Figures are
built on ``matplotlib.figure.Figure`` directly (Agg canvas, no pyplot state) and never shown.
"""

from fmuid.plots.compilation import CiEntry, ci_compilation_figure, ci_entries_from_profile
from fmuid.plots.fit import fit_figure
from fmuid.plots.profile import parameter_paths_figure, profile_figure
from fmuid.plots.trajectory import trajectory_band_figure

__all__ = [
    "CiEntry",
    "ci_compilation_figure",
    "ci_entries_from_profile",
    "fit_figure",
    "parameter_paths_figure",
    "profile_figure",
    "trajectory_band_figure",
]
