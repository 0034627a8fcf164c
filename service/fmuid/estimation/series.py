"""Data, model and weighted residuals of a fit per experiment and output (what fit plots draw)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from fmuid.estimation.problem import Problem


@dataclass(frozen=True)
class ResidualSeries:
    """Data, model and weighted residuals of one output in one experiment.

    Attributes
    ----------
    experiment, output
        Names.
    time
        Times of the fitted rows [s].
    data, model
        Measured and simulated values there.
    weighted
        ``(data - model) / sigma``.
    unit
        The output's unit (``""`` when the FMU declares none).

    """

    experiment: str
    output: str
    time: np.ndarray
    data: np.ndarray
    model: np.ndarray
    weighted: np.ndarray
    unit: str = ""


def residual_series(
    problem: Problem,
    values: Mapping[str, float],
    predictions: list[dict[str, np.ndarray]] | None = None,
) -> list[ResidualSeries]:
    """Simulate at ``values`` and pair the model with the data of every fitted output.

    Parameters
    ----------
    problem
        The fitting problem (experiments, sigma, predictions).
    values
        Free parameter values (parameter units).
    predictions
        ``problem.predict(values)`` when the caller has it already (not simulated again).

    Returns
    -------
    list of ResidualSeries
        One per experiment and fitted output, in the problem's order.

    """
    out = []
    predicted = problem.predict(values) if predictions is None else predictions
    for i, (exp, model) in enumerate(zip(problem.experiments, predicted, strict=True)):
        for j, output in enumerate(problem.outputs):
            mask = problem.masks[i][j]
            if not mask.any():
                continue
            data = problem.data[i][j]
            sim = np.asarray(model[output])[mask]
            sig = np.asarray(problem.sigma[i][output], dtype=float)[mask]
            variable = problem.model.outputs.get(output)
            unit = (variable.unit if variable else None) or ""
            out.append(
                ResidualSeries(
                    exp.name, output, exp.time[mask], data, sim, (data - sim) / sig, unit
                )
            )
    return out
