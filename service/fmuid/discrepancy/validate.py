"""Held-out validation of each augmented model, and the feedback coupling's own error.

The base model and the model after each added effect are simulated on the test experiments
from their fitted parameters; the error is the benchmarks' metric, the root mean square of the
simulation error in the output's unit, over the rows after the settle-in window.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from fmuid.data import Experiment
from fmuid.discrepancy.augment import AugmentedPredictor
from fmuid.engine.count import counted
from fmuid.estimation.problem import Problem
from fmuid.estimation.validation import ValidationEntry, validate


def validation(
    models: Sequence[tuple[Problem, Mapping[str, float]]], experiments: Sequence[Experiment]
) -> list[ValidationEntry]:
    """Return the contract's entries for the base model (first) and each model after it.

    Each entry: experiment, output, n, ``rms_base``, ``rms_by_step`` (the base, then after each
    added effect) and ``rms_final`` (the last model's).
    """
    if not experiments:
        return []
    runs = []
    for problem, values in models:
        found = validate(problem, values, experiments)
        counted(len(experiments))
        runs.append({(e.experiment, e.output): e for e in found})
    return [
        entry.with_steps([run[key].rms_base for run in runs], runs[-1][key].initial_states)
        for key, entry in runs[0].items()
    ]


def coupling_error(problem: Problem, values: Mapping[str, float]) -> float | None:
    """Largest change, in sigmas, of the fit's predictions when the fine step is halved.

    None when the model has no effect that acts on a fine grid (nothing to check).
    """
    predictor = problem.predictor
    if not isinstance(predictor, AugmentedPredictor):
        return None
    if not any(
        e.side in ("feedback", "input") or e.effect == "output_lag" for e in predictor.effects
    ):
        return None
    half = AugmentedPredictor(predictor.base, predictor.effects, predictor.step_scale / 2)
    worst = 0.0
    for i, exp in enumerate(problem.experiments):
        a = problem.simulate(dict(values), exp)
        b = problem.simulate(dict(values), exp, predictor=half)
        for j, o in enumerate(problem.outputs):
            mask = problem.masks[i][j]
            if mask.any():
                sigma = problem.sigma[i][o][mask]
                worst = max(worst, float(np.max(np.abs(a[mask, j] - b[mask, j]) / sigma)))
    return worst
