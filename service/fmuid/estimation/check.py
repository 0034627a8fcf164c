"""The study check: a spec and its experiments against an FMU, before anything is simulated.

The engine runs it when it builds a problem (:func:`fmuid.estimation.study.make_problem`) and
the service runs it on every upload (:mod:`fmuid.intake.vet`), so that a spec the engine would
refuse gets a 422 instead of a failed job. It imports only the data and model layers (not the
engine), so that a checking process starts fast.
"""

from __future__ import annotations

from collections.abc import Sequence

from fmuid.data import Experiment, Spec, check_against_model
from fmuid.errors import DataError, SpecError
from fmuid.model.fmu import FmuModel


def check_study(model: FmuModel, spec: Spec, experiments: Sequence[Experiment]) -> FmuModel:
    """Check the spec and the experiments against the FMU's variables and their FMI types.

    Returns
    -------
    FmuModel
        ``model`` with the interface the spec asks for.

    Raises
    ------
    SpecError, DataError
        Naming the field, the file or the variable at fault: an interface the FMU lacks, a
        name it does not have, data that do not fit, a variable whose type does not fit the
        role the spec gives it (:meth:`FmuModel.usage_problems`), or two experiments of one
        name when parameters take one value per experiment (``name@<experiment>``).

    """
    wrong_interface = model.interface_problem(spec.interface)
    if wrong_interface:
        raise SpecError(f"{spec.source}: interface: {wrong_interface}")
    model = model.with_interface(spec.interface)
    check_against_model(spec, model.parameters, model.inputs, model.outputs, experiments)
    free = [*spec.parameters, *(n for p in spec.physics.values() for n in p.parameters)]
    problems = model.usage_problems(free, spec.fixed, spec.inputs, spec.outputs)
    if problems:
        raise SpecError("\n".join(f"{spec.source}: {problem}" for problem in problems))
    names = [experiment.name for experiment in experiments]
    repeated = sorted({name for name in names if names.count(name) > 1})
    if spec.per_experiment and repeated:
        raise DataError(
            f"{', '.join(repeated)}: two experiments have this file name, but "
            f"{', '.join(spec.per_experiment)} (per_experiment) take one value per experiment, "
            "named after its file; rename one of the files"
        )
    return model
