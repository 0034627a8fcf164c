"""Held-out validation of each augmented model.

The base model and the model after each added effect are simulated on the test experiments
from their fitted parameters; the error is the benchmarks' metric, the root mean square of the
simulation error in the output's unit, over the rows after the settle-in window.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from fmuid.data import Experiment
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
