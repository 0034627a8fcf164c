"""Figure of where a misfit sits in the signal's own terms: against the level and the rate.

It draws the binned means (with their standard errors) that :mod:`fmuid.discrepancy.levels`
stored in a diagnosis' ``location["levels"]``: one row per output, the weighted residual of
the base fit against the model's output (left) and against its rate (right).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from matplotlib.figure import Figure

from fmuid.plots._common import AxesArg, panels, unit_label


def level_figure(levels: Mapping[str, Mapping[str, Any]], *, ax: AxesArg = None) -> Figure:
    """Draw the base fit's weighted residual against each output's level and rate.

    Parameters
    ----------
    levels
        ``diagnosis.location["levels"]`` (or the JSON's): per output, ``by_level`` and
        ``by_rate`` binned means, ``pattern`` and ``unit``.
    ax
        Two axes per output, row by row, instead of a new figure.

    Returns
    -------
    Figure

    """
    names = list(levels)
    fig, axes, _ = panels(ax, 2 * len(names), "level panels", ncols=2)
    for k, name in enumerate(names):
        entry = levels[name]
        unit = str(entry.get("unit") or "")
        rate_unit = f"{unit}/s" if unit else "1/s"
        for a, key, label in (
            (axes[2 * k], "by_level", unit_label(name, unit)),
            (axes[2 * k + 1], "by_rate", unit_label(f"d{name}/dt", rate_unit)),
        ):
            b = entry[key]
            a.errorbar(b["centre"], b["mean"], yerr=b["stderr"], fmt="o-", ms=3, capsize=2)
            a.axhline(0.0, color="0.5", lw=0.8)
            a.set_xlabel(label)
            a.set_ylabel("mean weighted residual")
        pattern = entry.get("pattern")
        title = f"{name}: {pattern.replace('_', ' ')} pattern" if pattern else f"{name}: no pattern"
        axes[2 * k].set_title(title, fontsize="medium")
    return fig
