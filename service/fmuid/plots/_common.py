"""Shared helpers of the plot modules: figure creation, coordinates, colours."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TypeAlias

import numpy as np
from matplotlib.axes import Axes
from matplotlib.axis import Axis
from matplotlib.figure import Figure
from matplotlib.ticker import LogFormatter

from fmuid.estimation.space import value_to_z

AxesArg: TypeAlias = Axes | Sequence[Axes] | np.ndarray | None
"""What ``ax=`` takes: one Axes, or a sequence or array of Axes (flattened row by row)."""

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


def panels(
    ax: AxesArg,
    n_panels: int,
    what: str,
    *,
    ncols: int = 3,
    panel_size: tuple[float, float] = (4.0, 3.0),
) -> tuple[Figure, list[Axes], bool]:
    """Return the figure and the axes to draw ``n_panels`` panels into.

    Parameters
    ----------
    ax
        ``None`` for a new figure (see :func:`new_figure`), else the caller's axes: one
        ``Axes`` or a sequence or array of them (e.g. from ``plt.subplots``), flattened row by
        row, exactly one per panel.
    n_panels
        Number of panels the plot draws.
    what
        The panels, for the error message, e.g. ``"fit_figure: 4 per residual series"``.
    ncols, panel_size
        Layout of a new figure.

    Returns
    -------
    tuple
        The figure (the top-level one holding the caller's axes), the axes in panel order, and
        whether the figure is new (only a new figure gets a title of its own).

    Raises
    ------
    ValueError
        If the number of axes given is not ``n_panels``; the message names the number needed.
    TypeError
        If ``ax`` holds something that is not a matplotlib ``Axes``.

    """
    if ax is None:
        fig, axes = new_figure(n_panels, ncols=ncols, panel_size=panel_size)
        return fig, axes, True
    given = [ax] if isinstance(ax, Axes) else list(np.asarray(ax, dtype=object).ravel())
    wrong = [type(a).__name__ for a in given if not isinstance(a, Axes)]
    if wrong:
        raise TypeError(
            f"ax= takes matplotlib Axes (one, or a sequence or array of them), got {wrong[0]}"
        )
    if len(given) != n_panels:
        raise ValueError(f"ax= needs exactly {n_panels} Axes here ({what}), got {len(given)}")
    return figure_of(given[0]), given, False


def to_plot_coordinate(value: float, scale: str) -> float:
    """Return a parameter value in plot coordinates: log10 for log-scaled parameters."""
    return value_to_z(value, scale)


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


def plain_log_ticks(axis: Axis) -> None:
    """Label a log axis in plain text (``100``, ``0.01``, ``1e+05``), not in math text.

    Matplotlib's default log labels are math text (``10^{2}`` between dollar signs), which
    reads raw wherever math text is off: the report writer turns it off so that a ``$`` in a
    name stays text.
    """
    axis.set_major_formatter(LogFormatter())
    axis.set_minor_formatter(LogFormatter())
