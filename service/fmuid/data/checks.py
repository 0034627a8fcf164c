"""Check a spec and experiments against the variables an FMU declares (names only, no FMU code)."""

from __future__ import annotations

from collections.abc import Collection, Sequence

import numpy as np

from fmuid.data.experiment import Experiment
from fmuid.data.messages import capped, suggest
from fmuid.data.spec import Spec
from fmuid.errors import DataError, SpecError

__all__ = ["check_against_model", "check_test_data", "settled_rows", "used_inputs"]


def used_inputs(spec: Spec, fmu_inputs: Collection[str], experiment: Experiment) -> list[str]:
    """Return the FMU inputs that an experiment drives.

    Parameters
    ----------
    spec
        The study; its ``inputs`` win when not empty.
    fmu_inputs
        Names of the FMU's inputs.
    experiment
        The experiment; without spec inputs, its columns that are FMU inputs are used.

    Returns
    -------
    list of str
        Input names, in spec order or else in column order.

    """
    if spec.inputs:
        return list(spec.inputs)
    return [column for column in experiment.columns if column in fmu_inputs]


def check_against_model(
    spec: Spec,
    parameters: Collection[str],
    inputs: Collection[str],
    outputs: Collection[str],
    experiments: Sequence[Experiment],
) -> None:
    """Check that the spec and the experiments fit an FMU's variables.

    Parameters
    ----------
    spec
        The validated spec.
    parameters, inputs, outputs
        Names of the FMU's parameters, inputs and outputs.
    experiments
        The loaded experiments.

    Raises
    ------
    SpecError
        A free, fixed or physics parameter, an input or an output the FMU does not have
        (every such problem, one per line).
    DataError
        A data column that the FMU does not know, a spec input missing from a file, a spec
        output without data, or sigma columns that do not give a positive value for every
        sample (every such problem, one per line, naming file, row and column).

    """
    problems = []
    groups: list[tuple[str, Collection[str]]] = [
        ("parameters", spec.parameters),
        ("fixed", spec.fixed),
    ]
    for effect, physics in spec.physics.items():
        groups.append((f"physics.{effect}.parameters", physics.parameters))
    for field, names in groups:
        problems += [
            f"{spec.source}: {field}.{name}: the FMU has no parameter '{name}'"
            f"{suggest(name, parameters, 'its parameters')}"
            for name in names
            if name not in parameters
        ]
    named = (("inputs", spec.inputs, inputs), ("outputs", spec.outputs, outputs))
    for field, names, known in named:
        problems += [
            f"{spec.source}: {field}: the FMU has no {field[:-1]} '{name}'"
            f"{suggest(name, known, f'its {field}')}"
            for name in names
            if name not in known
        ]
    if problems:
        raise SpecError(capped(problems))
    for experiment in experiments:
        problems += _experiment_problems(spec, inputs, outputs, experiment)
    files = ", ".join(experiment.name for experiment in experiments) or "no data file"
    problems += [
        f"output '{name}' (spec) has no column in any data file ({files})"
        for name in spec.outputs
        if not any(name in experiment.columns for experiment in experiments)
    ]
    if problems:
        raise DataError(capped(problems))


def _experiment_problems(
    spec: Spec, inputs: Collection[str], outputs: Collection[str], experiment: Experiment
) -> list[str]:
    """Problems of one experiment against the spec and the FMU's inputs and outputs."""
    name = experiment.name
    known = [*inputs, *outputs, *(f"sigma_{output}" for output in outputs)]
    problems = [
        f"{name}: row 1, column '{column}': not an input or output of the FMU"
        f"{suggest(column, known, 'allowed besides time')}"
        for column in experiment.columns
        if column not in known
    ]
    for column in used_inputs(spec, inputs, experiment):
        if column not in experiment.columns:
            problems.append(f"{name}: column '{column}' is missing (the spec lists it in inputs)")
        elif np.isnan(experiment.columns[column]).all():
            problems.append(f"{name}: column '{column}': the input has no value in any row")
    for output, output_spec in spec.outputs.items():
        if output not in experiment.columns:
            continue
        mask = experiment.output_mask(output)
        if not mask.any():
            problems.append(f"{name}: column '{output}': the output has no value in any row")
        if output_spec.sigma != "column":
            continue
        sigma = experiment.sigma_column(output)
        column = f"sigma_{output}"
        if sigma is None:
            problems.append(
                f"{name}: column '{column}' is missing (outputs.{output}.sigma is 'column')"
            )
            continue
        empty = np.flatnonzero(mask & np.isnan(sigma))
        if empty.size:
            problems.append(
                f"{name}: row {empty[0] + 2}, column '{column}': empty, "
                f"but '{output}' has a value in this row"
            )
        bad = np.flatnonzero(sigma <= 0)
        if bad.size:
            problems.append(
                f"{name}: row {bad[0] + 2}, column '{column}': sigma must be positive, "
                f"got {float(sigma[bad[0]])!r}"
            )
    return problems


def check_test_data(
    spec: Spec,
    parameters: Collection[str],
    inputs: Collection[str],
    outputs: Collection[str],
    experiments: Sequence[Experiment],
) -> None:
    """Check test experiments as the estimation data are checked, and that each has an output.

    No test experiments: nothing to check.

    Raises
    ------
    SpecError, DataError
        Naming the test file and column at fault.

    """
    if not experiments:
        return
    check_against_model(spec, parameters, inputs, outputs, experiments)
    for exp in experiments:
        if not any(o in exp.columns for o in spec.outputs):
            raise DataError(
                f"{exp.name}: a test file needs at least one fitted output column "
                f"({', '.join(spec.outputs)})"
            )
        kept = settled_rows(exp, spec.settle)
        if not any(exp.output_mask(o)[kept].any() for o in spec.outputs if o in exp.columns):
            raise DataError(
                f"{exp.name}: no output sample after the {spec.settle:g} s settle window"
            )


def settled_rows(experiment: Experiment, settle: float) -> np.ndarray:
    """Rows of ``experiment`` after its settle-in window (its first ``settle`` seconds)."""
    return experiment.time >= experiment.time[0] + settle
