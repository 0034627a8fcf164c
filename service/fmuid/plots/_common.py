"""Shared helpers of the plot modules: figure creation, coordinates, colours."""

from __future__ import annotations

import math

from matplotlib.axes import Axes
from matplotlib.figure import Figure

PROFILE_COLOR = "black"
QUADRATIC_COLOR = "0.6"
THRESHOLD_COLOR = "red"
BOUND_COLOR = "red"
ESTIMATE_COLOR = "0.45"
DATA_COLOR = "tab:blue"
MODEL_COLOR = "red"


def new_figure(
    n_panels: int, *, ncols: int = 3, panel_size: tuple[float, float] = (4.0, 3.0)
) -> tuple[Figure, list[Axes]]:
    """Create a figure (Agg canvas, no pyplot state) with a grid of at least ``n_panels`` axes.

    Parameters
    ----------
    n_panels
        Number of panels needed; unused grid cells are hidden.
    ncols
        Maximum number of columns.
    panel_size
        Width and height of one panel in inches.

    Returns
    -------
    tuple
        The ``Figure`` and the list of the first ``n_panels`` axes.

    """
    ncols = max(1, min(ncols, n_panels))
    nrows = max(1, math.ceil(n_panels / ncols))
    fig = Figure(figsize=(panel_size[0] * ncols, panel_size[1] * nrows), layout="constrained")
    grid = fig.subplots(nrows, ncols, squeeze=False)
    axes = [ax for row in grid for ax in row]
    for ax in axes[n_panels:]:
        ax.set_visible(False)
    return fig, axes[:n_panels]


def to_plot_coordinate(value: float, scale: str) -> float:
    """Return a parameter value in plot coordinates: log10 for log-scaled parameters."""
    return math.log10(value) if scale == "log" else float(value)


def axis_label(name: str, scale: str, unit: str = "") -> str:
    """Return the axis label of a parameter in plot coordinates, with its unit when known."""
    label = unit_label(name, unit)
    return f"log10({label})" if scale == "log" else label


def unit_label(name: str, unit: str) -> str:
    """Return an axis label with the unit in brackets when there is one."""
    return f"{name} [{unit}]" if unit else name


def figure_of(ax: Axes) -> Figure:
    """Return the top-level figure that holds ``ax``."""
    fig = ax.get_figure(root=True)
    if not isinstance(fig, Figure):
        raise ValueError("the axes belong to no figure")
    return fig
