"""Held-out validation: the simulation error of a fitted model on experiments it never saw.

The metric is the benchmarks' own: the RMS of the simulation error ``y_data - y_model`` in the
output's unit, over the samples after the settle-in window (``Spec.settle``), the model run
free from its start state with the test experiment's inputs.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from fmuid.data import Experiment
from fmuid.data.checks import settled_rows
from fmuid.errors import FmuError
from fmuid.estimation.predictor import Predictor
from fmuid.estimation.schema import ValidationOut, Written

__all__ = ["ValidationEntry", "held_out_rms"]


@dataclass(frozen=True)
class ValidationEntry(Written):
    """The held-out error of one output in one test experiment.

    ``to_dict`` writes :class:`~fmuid.estimation.schema.ValidationOut` (``rms_final`` and the
    steps only when set).

    Attributes
    ----------
    experiment
        The test experiment (its file name).
    output
        The output compared.
    n
        Number of samples compared (those with a value, after the settle-in window).
    rms_base
        RMS simulation error of the fitted model [output unit].
    rms_final
        RMS error of the final augmented model (diagnose only; None otherwise).
    rms_by_step
        RMS error after each step of an augmented model, the base first (diagnose only).

    """

    experiment: str
    output: str
    n: int
    rms_base: float
    rms_final: float | None = None
    rms_by_step: tuple[float, ...] = ()

    schema = ValidationOut

    def with_steps(self, rms_by_step: Sequence[float]) -> ValidationEntry:
        """Return this entry with the errors of an augmented model's steps (the last is final)."""
        steps = tuple(float(r) for r in rms_by_step)
        return replace(self, rms_by_step=steps, rms_final=steps[-1] if steps else None)


def held_out_rms(
    predictor: Predictor,
    values: Mapping[str, float],
    experiments: Sequence[Experiment],
    outputs: Sequence[str],
    settle: float = 0.0,
) -> list[ValidationEntry]:
    """Simulate each test experiment and return the RMS error of each output it records.

    Parameters
    ----------
    predictor
        Anything with ``predict(params, experiment, outputs)`` (the estimation problem's
        ``predictor``, or the predictor of an augmented model).
    values
        Parameter values for ``predictor`` (e.g. a fit's estimates).
    experiments
        The test experiments (checked with :func:`fmuid.data.checks.check_test_data`).
    outputs
        The outputs compared (the spec's); an output a file lacks is skipped for that file.
    settle
        Settle-in window [s] left out at the start of every experiment.

    Returns
    -------
    list of ValidationEntry
        One per experiment and output it records after the settle window, in experiment then
        output order, with ``rms_base`` set.

    Raises
    ------
    FmuError
        When a simulation gives non-finite outputs.

    """
    entries = []
    for exp in experiments:
        present = [o for o in outputs if o in exp.columns]
        y = predictor.predict(values, exp, present)
        kept = settled_rows(exp, settle)
        for j, output in enumerate(present):
            mask = exp.output_mask(output) & kept
            if not mask.any():
                continue
            error = exp.columns[output][mask] - y[mask, j]
            if not np.all(np.isfinite(error)):
                raise FmuError(f"{exp.name}: non-finite simulated {output} on the test data")
            rms = math.sqrt(float(np.mean(error**2)))
            entries.append(ValidationEntry(exp.name, output, int(mask.sum()), rms))
    return entries
