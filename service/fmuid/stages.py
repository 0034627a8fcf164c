"""The documented Python API: simulate, fit, profile (and diagnose) in one call each."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from fmuid import provenance
from fmuid.data import Experiment, Spec
from fmuid.data.checks import check_test_data
from fmuid.errors import DataError, FmuError, SpecError
from fmuid.estimation.predictor import merged_inputs
from fmuid.estimation.validation import validate
from fmuid.model.base import as_model
from fmuid.model.builtin import resolve_fmu
from fmuid.model.fmu import USABLE, FmuModel
from fmuid.model.registry import get_simulator
from fmuid.progress import ProgressCallback, default_progress

if TYPE_CHECKING:  # the fit and profile machinery is imported on first use: simulate starts fast
    from fmuid.estimation.problem import Problem
    from fmuid.estimation.result import FitResult
    from fmuid.profiling.result import ProfileResult


def __getattr__(name: str) -> Any:
    if name != "make_problem":
        raise AttributeError(f"module 'fmuid.stages' has no attribute {name!r}")
    from fmuid.estimation.study import make_problem

    return make_problem


@dataclass(frozen=True)
class Simulation:
    """One run of an FMU at an experiment's times (the result of :func:`simulate`).

    Attributes
    ----------
    time
        The experiment's times [s].
    inputs
        Each input the experiment drives, as the FMU saw it at ``time`` (linear between the
        samples, or held for discrete inputs).
    outputs
        Every output fmuid can read, in file order, at ``time``.
    model
        The parsed FMU.
    input_handling
        How the inputs reached the FMU between their samples.

    """

    time: np.ndarray
    inputs: dict[str, np.ndarray]
    outputs: dict[str, np.ndarray]
    model: FmuModel
    input_handling: str

    def to_frame(self) -> Any:
        """Return a pandas table indexed by ``time`` [s]: inputs, then outputs (needs pandas).

        The columns are what ``fmuid simulate --with-inputs`` writes.
        """
        from fmuid.frames import pandas_module

        pandas = pandas_module()
        frame = pandas.DataFrame({**self.inputs, **self.outputs}, index=self.time)
        frame.index.name = "time"
        return frame


def simulate(
    fmu: str | Path | FmuModel,
    experiment: Experiment,
    values: Mapping[str, float | str] | None = None,
    *,
    interface: str = "auto",
    source: str = "spec",
) -> Simulation:
    """Run the FMU once with the experiment's inputs and read every output at its times.

    Parameters
    ----------
    fmu
        A parsed FMU, an FMU file or the name of a built-in model (e.g. ``"msd"``).
    experiment
        Its input columns drive the FMU; its output columns, if any, are not used.
    values
        FMU parameter values (the others keep their start values).
    interface
        ``"auto"``, ``"co_simulation"`` or ``"model_exchange"``.
    source
        Where ``values`` come from, for error messages (e.g. the spec file).

    Returns
    -------
    Simulation

    Raises
    ------
    SpecError
        When a value names no FMU parameter or does not fit its type.
    DataError
        When a column of the experiment is not an FMU variable.
    FmuError
        When the FMU cannot be used or has no output fmuid can read.

    """
    values = dict(values or {})
    model = as_model(fmu if isinstance(fmu, FmuModel) else resolve_fmu(fmu), interface)
    unknown = sorted(set(values) - set(model.parameters))
    if unknown:
        raise SpecError(f"{source}: the FMU has no parameter(s) {', '.join(unknown)}")
    problems = model.usage_problems((), values, (), ())
    if problems:
        raise SpecError("\n".join(f"{source}: {problem}" for problem in problems))
    columns = experiment.columns
    strangers = [
        c
        for c in columns
        if c not in model.inputs
        and c not in model.outputs
        and not (c.startswith("sigma_") and c[6:] in model.outputs)
    ]
    if strangers:
        raise DataError(
            f"{experiment.name}: column(s) {', '.join(strangers)} are not FMU variables"
        )
    inputs = [c for c in columns if c in model.inputs]
    held = [c for c in inputs if not model.inputs[c].is_continuous]
    input_time, input_values = merged_inputs(experiment, inputs, held)
    outputs = [n for n, v in model.outputs.items() if v.kind in USABLE["output"]]
    if not outputs:
        types = ", ".join(f"{n} ({v.type_label})" for n, v in model.outputs.items()) or "none"
        raise FmuError(f"{model.path}: no output fmuid can read (its outputs: {types})")
    simulator = get_simulator(model)
    y = simulator.simulate(values, input_time, input_values, experiment.time, outputs)
    seen = {n: _input_at(experiment.time, input_time, input_values[n], n in held) for n in inputs}
    return Simulation(
        experiment.time,
        seen,
        dict(zip(outputs, y.T, strict=True)),
        model,
        simulator.input_handling,
    )


def _input_at(
    time: np.ndarray, input_time: np.ndarray, values: np.ndarray, held: bool
) -> np.ndarray:
    """Return an input at ``time`` as the FMU sees it: linear between samples, or held."""
    if held:
        return np.asarray(values[np.searchsorted(input_time, time, side="right") - 1])
    return np.interp(time, input_time, values)


def fit(
    fmu: str | Path | FmuModel,
    experiments: Sequence[Experiment],
    spec: Spec,
    *,
    progress: ProgressCallback | None = None,
    problem: Problem | None = None,
    test_data: Sequence[Experiment] = (),
) -> FitResult:
    """Fit the spec's free parameters of an FMU to one or more experiments.

    A seeded genetic algorithm over the bounds gives the global start (``spec.global_search``),
    then trust-region least squares refines it in log-parameter space.

    Parameters
    ----------
    fmu
        A parsed FMU (``fmuid.model.FmuModel``), an FMU file (FMI 2.0 or 3.0), or the name of
        a built-in model (e.g. ``"msd"``).
    experiments
        Datasets (``fmuid.data.load_experiment``) sharing the parameters.
    spec
        The study (``fmuid.data.load_spec``).
    progress
        Receives ``fmuid.progress.Progress`` events (default: bars under the cell in a
        Jupyter notebook, nothing elsewhere).
    problem
        The problem :func:`make_problem` built of these inputs, to hand on one already built
        (e.g. the one the report then draws from); default: built here.
    test_data
        Held-out experiments: the fitted model is simulated on them and the RMS of its
        simulation error per file and output goes into ``validation``.

    Returns
    -------
    FitResult
        Estimates, chi2 and cost; ``.to_dict()`` gives the JSON of ``fmuid fit``.

    Raises
    ------
    DataError, SpecError
        When a test file does not fit the FMU and spec (checked before the fit).

    Examples
    --------
    >>> from fmuid.data import load_experiment, load_spec
    >>> result = fmuid.fit("fmus/msd.fmu", [load_experiment("step.csv")], load_spec("spec.json"))

    """
    started = provenance.now()
    progress = default_progress(progress)
    from fmuid.estimation.optimize import fit_problem
    from fmuid.estimation.study import make_problem

    problem = problem or make_problem(fmu, experiments, spec)
    _check_test_data(problem, test_data)
    result = fit_problem(
        problem, global_search=spec.global_search, seed=spec.seed, progress=progress
    )
    options = {
        "stage": "fit",
        "global_search": spec.global_search,
        "interface": spec.interface,
        "test_data": [e.name for e in test_data],
    }
    recorded = provenance.record(
        _validated(problem, result, test_data),
        fmu_sha256=problem.model.sha256,
        spec=spec,
        experiments=[*experiments, *test_data],
        options=options,
        started=started,
    )
    return replace(recorded, problem=problem)


def profile(
    fmu: str | Path | FmuModel,
    experiments: Sequence[Experiment],
    spec: Spec,
    *,
    fit: FitResult | None = None,
    workers: int | None = None,
    executor: Any = None,
    progress: ProgressCallback | None = None,
    problem: Problem | None = None,
    test_data: Sequence[Experiment] = (),
) -> ProfileResult:
    """Fit, then profile the likelihood of every free parameter.

    Parameters
    ----------
    fmu, experiments, spec
        As for :func:`fit`.
    fit
        A fit of the same inputs to start from (default: fit first).
    workers
        Local worker processes for the branches (default: CPU count; 1: in this process).
    executor
        A ``dask.distributed.Client``: branches run as tasks on its workers.
    progress
        Receives ``fmuid.progress.Progress`` events, one per profile point (default: bars
        under the cell in a Jupyter notebook, nothing elsewhere).
    problem, test_data
        As for :func:`fit` (``validation`` is computed at the profile's best fit).

    Returns
    -------
    ProfileResult
        Intervals, labels, profiles and structural check; ``.to_dict()`` gives the contract JSON.

    """
    started = provenance.now()
    progress = default_progress(progress)
    from fmuid.estimation.optimize import fit_problem
    from fmuid.estimation.study import make_problem
    from fmuid.profiling.engine import profile_problem

    problem = problem or make_problem(fmu, experiments, spec)
    options = {
        "stage": "profile",
        "global_search": spec.global_search,
        "interface": spec.interface,
        "confidence": spec.confidence,
        "workers": workers,
        "executor": None if executor is None else type(executor).__name__,
        "fit": "given" if fit is not None else "fitted here",
        "test_data": [e.name for e in test_data],
    }
    _check_test_data(problem, test_data)
    if fit is None:
        fit = fit_problem(
            problem, global_search=spec.global_search, seed=spec.seed, progress=progress
        )
    result = profile_problem(problem, fit, workers=workers, executor=executor, progress=progress)
    if test_data:
        result = replace(result, fit=_validated(problem, result.fit, test_data))
    recorded = provenance.record(
        result,
        fmu_sha256=problem.model.sha256,
        spec=spec,
        experiments=[*experiments, *test_data],
        options=options,
        started=started,
    )
    return replace(recorded, problem=problem)


def _check_test_data(problem: Problem, test_data: Sequence[Experiment]) -> None:
    """Check held-out experiments against the problem's FMU and spec, as its data were."""
    if test_data:
        model = problem.model
        check_test_data(problem.spec, model.parameters, model.inputs, model.outputs, test_data)


def _validated(problem: Problem, fit: FitResult, test_data: Sequence[Experiment]) -> FitResult:
    """Return ``fit`` with the held-out error of its estimates on ``test_data``."""
    if not test_data:
        return fit
    return replace(fit, validation=tuple(validate(problem, fit.estimates, test_data)))
