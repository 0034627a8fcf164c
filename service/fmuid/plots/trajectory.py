"""Trajectories over the parameter sets inside the simultaneous CI (thesis Figs 2.12, 3.5)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.figure import Figure

from fmuid.plots._common import DATA_COLOR, axis_label, new_figure
from fmuid.profile.result import ProfileResult

if TYPE_CHECKING:
    from fmuid.fit.problem import Problem

POSITIONS = (("x_tc", "y_tc", "tractor CG"), ("x_ic", "y_ic", "implement CG"))
"""Planar position outputs drawn as paths when the FMU has them."""

BAND_COLOR = "tab:red"


def parameter_sets_in_ci(result: ProfileResult, n: int = 30) -> list[dict[str, float]]:
    """Pick up to ``n`` parameter sets from the profiles' points inside the simultaneous CI.

    A profile point gives a full set (the profiled value plus the re-fitted others). The two
    outermost points inside the CI of every profile come first (they span the band), then the
    remaining points evenly spread. The estimate is not included.

    Parameters
    ----------
    result
        The profile study.
    n
        Most sets returned.

    Returns
    -------
    list of dict
        Free parameter values (parameter units).

    """
    limit = result.chi2 + result.thresholds["simultaneous"]
    extremes: list[dict[str, float]] = []
    inner: list[dict[str, float]] = []
    for name, prof in result.parameters.items():
        inside = [
            {**p.params, name: p.value}
            for p in prof.points
            if p.error is None and math.isfinite(p.chi2) and p.chi2 <= limit
        ]
        if inside:
            extremes.extend([inside[0], inside[-1]] if len(inside) > 1 else inside)
            inner.extend(inside[1:-1])
    picked = extremes[:n]
    room = n - len(picked)
    if room > 0 and inner:
        idx = np.unique(np.linspace(0, len(inner) - 1, min(room, len(inner))).round().astype(int))
        picked.extend(inner[i] for i in idx)
    return picked


def trajectory_band_figure(problem: Problem, result: ProfileResult, *, n: int = 30) -> Figure:
    """Draw the outputs simulated over parameter sets inside the simultaneous CI, with the data.

    One panel per experiment and fitted output against time: thin red lines for up to ``n``
    parameter sets taken from the profiles (see :func:`parameter_sets_in_ci`), the estimate in
    black and the data as blue dots. When the FMU has the CG position outputs ``x_tc``,
    ``y_tc``, ``x_ic``, ``y_ic``, one more panel per experiment draws the tractor and implement
    CG paths (y against x) the same way.

    Parameters
    ----------
    problem
        The fitting problem the profiles were computed on.
    result
        The profile study.
    n
        Most parameter sets simulated.

    Returns
    -------
    Figure
        The panels described above.

    """
    sets = parameter_sets_in_ci(result, n)
    best = dict(result.fit.estimates)
    positions = [
        p for p in POSITIONS if p[0] in problem.model.outputs and p[1] in problem.model.outputs
    ]
    pos_names = [v for p in positions for v in p[:2]]
    series = [(i, j) for i in range(len(problem.experiments)) for j in range(len(problem.outputs))]
    series = [(i, j) for i, j in series if problem.masks[i][j].any()]
    n_panels = len(series) + (len(problem.experiments) if positions else 0)
    fig, axes = new_figure(n_panels, ncols=2, panel_size=(6.0, 3.2))
    runs = [(values, BAND_COLOR, 0.8, 0.35) for values in sets] + [(best, "black", 1.6, 1.0)]
    for values, color, lw, alpha in runs:
        outputs = problem.predict(values)
        for ax, (i, j) in zip(axes, series, strict=False):
            exp = problem.experiments[i]
            ax.plot(
                exp.time,
                outputs[i][problem.outputs[j]],
                color=color,
                lw=lw,
                alpha=alpha,
                gid="band" if color == BAND_COLOR else "estimate",
            )
        if positions:
            full = {**dict(zip(problem.names, problem.start, strict=True)), **values}
            for k, exp in enumerate(problem.experiments):
                ax = axes[len(series) + k]
                y = problem.predictor.predict(full, exp, pos_names)
                for m, (_, _, label) in enumerate(positions):
                    ax.plot(
                        y[:, 2 * m],
                        y[:, 2 * m + 1],
                        color=color,
                        lw=lw,
                        alpha=alpha,
                        ls="-" if m == 0 else "--",
                        label=label if color == "black" else None,
                    )
    for ax, (i, j) in zip(axes, series, strict=False):
        exp = problem.experiments[i]
        ax.plot(
            exp.time[problem.masks[i][j]],
            problem.data[i][j],
            ".",
            color=DATA_COLOR,
            ms=4,
            gid="data",
        )
        ax.set_title(f"{exp.name}: {problem.outputs[j]}", fontsize=9)
        ax.set_xlabel("time [s]")
        output = problem.outputs[j]
        ax.set_ylabel(axis_label(output, "lin", result.fit.units.get(output)))
    if positions:
        for k, exp in enumerate(problem.experiments):
            ax = axes[len(series) + k]
            ax.set_title(f"{exp.name}: CG paths", fontsize=9)
            ax.set_xlabel("x [m]")
            ax.set_ylabel("y [m]")
            ax.legend(fontsize=7)
    fig.suptitle(
        f"Trajectories over {len(sets)} parameter sets inside the "
        f"{result.confidence:.0%} simultaneous CI\n(red), estimate (black), data (blue)",
        fontsize=10,
    )
    return fig
