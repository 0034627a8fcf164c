"""Held-out validation: the simulation error of a fitted model on experiments it never saw.

The metric is the benchmarks' own: the RMS of the simulation error ``y_data - y_model`` in the
output's unit, over the samples after the settle-in window (``Spec.settle``), the model run
free from its start state with the test experiment's inputs.

A test record starts from its own unknown state too. When the spec fits parameters per
experiment (``Spec.per_experiment``: initial states an FMU exposes as parameters), they are
estimated on each test record by weighted least squares with every other parameter fixed at
its fitted value, as the benchmarks do (:func:`record_states`); the entry reports them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from fmuid.data import Experiment
from fmuid.data.checks import settled_rows
from fmuid.errors import FmuError
from fmuid.estimation.per_experiment import per_experiment_name, split
from fmuid.estimation.predictor import Predictor
from fmuid.estimation.schema import ValidationOut, Written

if TYPE_CHECKING:  # the fit machinery is imported on first use: simulate starts fast
    from fmuid.estimation.problem import Problem

__all__ = ["STATES_METHOD", "ValidationEntry", "held_out_rms", "record_states", "validate"]

STATES_METHOD = (
    "fitted to this test record by weighted least squares, every other parameter at its "
    "estimate (the benchmark practice)"
)
"""How a test record's per-experiment parameters (its initial states) were obtained."""


@dataclass(frozen=True)
class ValidationEntry(Written):
    """The held-out error of one output in one test experiment.

    ``to_dict`` writes :class:`~fmuid.estimation.schema.ValidationOut` (the steps only when
    set; the initial states, and how they were obtained, only with ``Spec.per_experiment``).

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
    initial_states
        The per-experiment parameters the base model took on this record, by FMU name,
        estimated on it (:func:`record_states`; empty without ``Spec.per_experiment``).
    initial_states_final
        The same for the final augmented model (diagnose only).

    """

    experiment: str
    output: str
    n: int
    rms_base: float
    rms_final: float | None = None
    rms_by_step: tuple[float, ...] = ()
    initial_states: Mapping[str, float] = field(default_factory=dict)
    initial_states_final: Mapping[str, float] = field(default_factory=dict)

    schema = ValidationOut

    def with_steps(
        self,
        rms_by_step: Sequence[float],
        initial_states_final: Mapping[str, float] | None = None,
    ) -> ValidationEntry:
        """Return this entry with the errors of an augmented model's steps (the last is final).

        ``initial_states_final``: the final model's states on this record, when estimated.
        """
        steps = tuple(float(r) for r in rms_by_step)
        return replace(
            self,
            rms_by_step=steps,
            rms_final=steps[-1] if steps else None,
            initial_states_final=dict(initial_states_final or {}),
        )

    @property
    def initial_states_method(self) -> str | None:
        """How ``initial_states`` were obtained (None without them)."""
        return STATES_METHOD if self.initial_states else None


def validate(
    problem: Problem, values: Mapping[str, float], experiments: Sequence[Experiment]
) -> list[ValidationEntry]:
    """Return the held-out error of ``problem``'s model at ``values`` on each test experiment.

    Parameters
    ----------
    problem
        The estimation problem (its predictor, outputs, settle window and per-experiment
        parameters).
    values
        Its fitted parameter values.
    experiments
        The test experiments (checked with :func:`fmuid.data.checks.check_test_data`).

    Returns
    -------
    list of ValidationEntry
        As :func:`held_out_rms`; with ``Spec.per_experiment``, each test record's own values
        of those parameters are first estimated on it (:func:`record_states`) and reported in
        ``initial_states``.

    """
    entries = []
    for exp in experiments:
        states = record_states(problem, values, exp)
        own = {per_experiment_name(name, exp.name): v for name, v in states.items()}
        found = held_out_rms(
            problem.predictor, {**values, **own}, [exp], problem.outputs, problem.spec.settle
        )
        entries += [replace(entry, initial_states=states) for entry in found]
    return entries


def record_states(
    problem: Problem, values: Mapping[str, float], experiment: Experiment
) -> dict[str, float]:
    """Estimate a test record's per-experiment parameters, every other one at its fitted value.

    Weighted least squares over the record's samples after the settle window, each output
    weighted by the estimation's representative sigma (:meth:`Problem.representative_sigma`),
    within the spec's bounds and scale; started from the best (lowest chi2) of the spec's
    start and the values fitted to each estimation experiment.

    Returns
    -------
    dict
        The estimate by FMU parameter name; empty without ``Spec.per_experiment``.

    """
    names = problem.spec.per_experiment
    if not names:
        return {}
    from fmuid.estimation.optimize import FitOptions, refine, safe_residuals
    from fmuid.estimation.problem import Problem

    own = [per_experiment_name(name, experiment.name) for name in names]
    pinned = {k: v for k, v in values.items() if split(k, names) is None}
    sigma = problem.representative_sigma()
    record = Problem(
        problem.fmu_path,
        [experiment],
        problem.spec,
        predictor=_Pinned(problem.predictor, pinned),
        parameters={key: problem.spec.parameters[name] for key, name in zip(own, names)},
        sigma=[{o: np.full(experiment.n_rows, sigma[o]) for o in problem.outputs}],
        sigma_method={o: "the estimation's" for o in problem.outputs},
        model=problem.model,
    )
    starts = [record.start] + [
        np.array([values[per_experiment_name(n, e.name)] for n in names])
        for e in problem.experiments
        if all(per_experiment_name(n, e.name) in values for n in names)
    ]
    chi2 = [float(np.sum(safe_residuals(record, record.to_z_array(s)) ** 2)) for s in starts]
    z0 = record.to_z_array(starts[int(np.argmin(chi2))])
    z, _, _ = refine(record, z0, options=FitOptions())
    return dict(zip(names, record.from_z(z).values(), strict=True))


@dataclass(frozen=True)
class _Pinned:
    """A predictor with some parameter values pinned (the others are given to ``predict``)."""

    predictor: Predictor
    values: Mapping[str, float]

    def predict(
        self, params: Mapping[str, float], experiment: Experiment, outputs: Sequence[str]
    ) -> np.ndarray:
        """Return ``predictor``'s outputs with the pinned values and ``params`` (which win)."""
        return self.predictor.predict({**self.values, **params}, experiment, outputs)


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
