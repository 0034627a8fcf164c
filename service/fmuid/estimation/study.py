"""A study's estimation problem, built once its spec and data are checked against the FMU."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from fmuid.data import Experiment, Spec
from fmuid.estimation.check import check_study
from fmuid.estimation.problem import Problem
from fmuid.model.builtin import resolve_fmu
from fmuid.model.fmu import FmuModel, model_of_file
from fmuid.model.registry import get_simulator


def make_problem(
    fmu: str | Path | FmuModel, experiments: Sequence[Experiment], spec: Spec
) -> Problem:
    """Check the spec and the experiments against the FMU and build the estimation problem.

    Raises
    ------
    FmuError, SpecError, DataError
        When the FMU cannot be used (its binary is loaded and instantiated here), or the spec
        or data do not fit its variables.

    ``fmu`` is a parsed FMU (:class:`FmuModel`, handed on as it is), an FMU file or the name
    of a built-in model (e.g. ``"msd"``).
    """
    model = fmu if isinstance(fmu, FmuModel) else model_of_file(resolve_fmu(fmu))
    model = check_study(model, spec, experiments)
    get_simulator(model)
    return Problem(model.path, experiments, spec, model=model)
