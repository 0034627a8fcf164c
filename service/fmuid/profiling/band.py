"""Outputs simulated over parameter sets inside the simultaneous CI (what a band plot draws)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from fmuid.data import Experiment
from fmuid.estimation.problem import Problem
from fmuid.model.annotations import PlanarPath, planar_paths
from fmuid.profiling.result import ProfileResult


@dataclass(frozen=True)
class OutputBand:
    """One fitted output of one experiment over the parameter sets, with its data.

    Attributes
    ----------
    experiment, output, unit
        Names and the output's unit (``""`` when none is declared).
    time
        Times of every row [s].
    runs
        The output at ``time`` for each parameter set inside the CI.
    estimate
        The output at ``time`` at the estimate.
    data_time, data
        The fitted samples.

    """

    experiment: str
    output: str
    unit: str
    time: np.ndarray
    runs: tuple[np.ndarray, ...]
    estimate: np.ndarray
    data_time: np.ndarray
    data: np.ndarray


@dataclass(frozen=True)
class PathBand:
    """Planar paths of one experiment: per label, ``(x, y)`` per parameter set and estimate.

    ``units`` are the units of the x and y axes: :func:`trajectory_band` takes those the FMU
    declares for the first path's outputs (``""`` when none); a band built by hand defaults to
    metres, the SI unit of a position.
    """

    experiment: str
    runs: tuple[dict[str, tuple[np.ndarray, np.ndarray]], ...]
    estimate: dict[str, tuple[np.ndarray, np.ndarray]]
    units: tuple[str, str] = ("m", "m")


@dataclass(frozen=True)
class TrajectoryBand:
    """Everything ``fmuid.plots.trajectory_band_figure`` draws (made by :func:`trajectory_band`)."""

    confidence: float
    n_sets: int
    outputs: tuple[OutputBand, ...]
    paths: tuple[PathBand, ...]


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


def trajectory_band(problem: Problem, result: ProfileResult, *, n: int = 30) -> TrajectoryBand:
    """Simulate the fitted outputs over up to ``n`` parameter sets inside the simultaneous CI.

    The sets come from :func:`parameter_sets_in_ci`. The planar paths the FMU declares in its
    variable table (:func:`fmuid.model.annotations.planar_paths`, e.g. a vehicle's CG positions)
    are simulated too.

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
    TrajectoryBand
        The runs, the estimate and the data, per experiment and output.

    """
    sets = parameter_sets_in_ci(result, n)
    best = dict(result.fit.estimates)
    runs = [problem.predict(values) for values in sets]
    at_best = problem.predict(best)
    outputs = []
    for i, exp in enumerate(problem.experiments):
        for j, name in enumerate(problem.outputs):
            if not problem.masks[i][j].any():
                continue
            variable = problem.model.outputs.get(name)
            outputs.append(
                OutputBand(
                    exp.name,
                    name,
                    (variable.unit if variable else None) or "",
                    exp.time,
                    tuple(np.asarray(r[i][name]) for r in runs),
                    np.asarray(at_best[i][name]),
                    exp.time[problem.masks[i][j]],
                    problem.data[i][j],
                )
            )
    outputs_of_fmu = problem.model.outputs
    positions = [
        p for p in planar_paths(problem.model) if p.x in outputs_of_fmu and p.y in outputs_of_fmu
    ]
    units = (
        (outputs_of_fmu[positions[0].x].unit or "", outputs_of_fmu[positions[0].y].unit or "")
        if positions
        else ("", "")
    )
    paths = tuple(
        PathBand(
            exp.name,
            tuple(_paths(problem, exp, v, positions) for v in sets),
            _paths(problem, exp, best, positions),
            units,
        )
        for exp in (problem.experiments if positions else ())
    )
    return TrajectoryBand(result.confidence, len(sets), tuple(outputs), paths)


def _paths(
    problem: Problem,
    exp: Experiment,
    values: dict[str, float],
    positions: Sequence[PlanarPath],
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    names = [v for p in positions for v in (p.x, p.y)]
    full = {**dict(zip(problem.names, problem.start, strict=True)), **values}
    y = problem.predictor.predict(full, exp, names)
    return {p.label: (y[:, 2 * m], y[:, 2 * m + 1]) for m, p in enumerate(positions)}
