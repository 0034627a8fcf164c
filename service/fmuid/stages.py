"""The documented Python API: load inputs, fit, profile (and diagnose) in one call each."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from fmuid.data import Experiment, Spec, check_against_model
from fmuid.errors import SpecError
from fmuid.estimation.optimize import fit_problem
from fmuid.estimation.problem import Problem
from fmuid.estimation.result import FitResult
from fmuid.model.builtin import resolve_fmu
from fmuid.model.fmu import INTERFACES, FmuModel
from fmuid.model.simulator import get_simulator
from fmuid.profiling.engine import profile_problem
from fmuid.profiling.result import ProfileResult
from fmuid.progress import ProgressCallback


def make_problem(fmu: str | Path, experiments: Sequence[Experiment], spec: Spec) -> Problem:
    """Check the spec and the experiments against the FMU and build the estimation problem.

    Raises
    ------
    FmuError, SpecError, DataError
        When the FMU cannot be used (its binary is loaded and instantiated here), or the spec
        or data do not fit its variables.

    ``fmu`` is an FMU file or the name of a built-in model (e.g. ``"msd"``).
    """
    fmu = resolve_fmu(fmu)
    model = FmuModel(fmu)
    wrong_interface = model.interface_problem(spec.interface)
    if wrong_interface:
        raise SpecError(f"{spec.source}: interface: {wrong_interface}")
    if INTERFACES[spec.interface] not in (None, model.interface):
        model = FmuModel(fmu, spec.interface)
    check_against_model(spec, model.parameters, model.inputs, model.outputs, experiments)
    free = [*spec.parameters, *(n for p in spec.physics.values() for n in p.parameters)]
    problems = model.usage_problems(free, spec.fixed, spec.inputs, spec.outputs)
    if problems:
        raise SpecError("\n".join(f"{spec.source}: {problem}" for problem in problems))
    get_simulator(fmu, spec.interface)
    return Problem(fmu, experiments, spec, model=model)


def fit(
    fmu: str | Path,
    experiments: Sequence[Experiment],
    spec: Spec,
    *,
    progress: ProgressCallback | None = None,
) -> FitResult:
    """Fit the spec's free parameters of an FMU to one or more experiments.

    A seeded genetic algorithm over the bounds gives the global start (``spec.global_search``),
    then trust-region least squares refines it in log-parameter space.

    Parameters
    ----------
    fmu
        An FMU file (FMI 2.0 or 3.0), or the name of a built-in model (e.g. ``"msd"``).
    experiments
        Datasets (``fmuid.data.load_experiment``) sharing the parameters.
    spec
        The study (``fmuid.data.load_spec``).
    progress
        Receives ``fmuid.progress.Progress`` events.

    Returns
    -------
    FitResult
        Estimates, chi2 and cost; ``.to_dict()`` gives the JSON of ``fmuid fit``.

    Examples
    --------
    >>> from fmuid.data import load_experiment, load_spec
    >>> result = fmuid.fit("fmus/msd.fmu", [load_experiment("step.csv")], load_spec("spec.json"))

    """
    problem = make_problem(fmu, experiments, spec)
    return fit_problem(problem, global_search=spec.global_search, seed=spec.seed, progress=progress)


def profile(
    fmu: str | Path,
    experiments: Sequence[Experiment],
    spec: Spec,
    *,
    fit: FitResult | None = None,
    workers: int | None = None,
    executor: Any = None,
    progress: ProgressCallback | None = None,
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
        Receives ``fmuid.progress.Progress`` events, one per profile point.

    Returns
    -------
    ProfileResult
        Intervals, labels, profiles and structural check; ``.to_dict()`` gives the contract JSON.

    """
    problem = make_problem(fmu, experiments, spec)
    if fit is None:
        fit = fit_problem(
            problem, global_search=spec.global_search, seed=spec.seed, progress=progress
        )
    return profile_problem(problem, fit, workers=workers, executor=executor, progress=progress)
