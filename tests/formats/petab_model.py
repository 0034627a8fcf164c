"""libpetab's validator run on an fmuid PEtab problem, its FMU described by an adapter.

libpetab (``petab``, in the dev extra only) loads SBML and PySB models only, so it cannot load
a problem whose model is an FMU (``language: fmu``). :func:`petab_problem` loads the tables with
libpetab as ``Problem.from_yaml`` does and gives it the FMU through :class:`FmuPetabModel`,
which answers libpetab's questions about the model's entities from ``modelDescription.xml``
(``fmuid.info``): every check that looks at the model (condition targets, parameters in the
parameter table, observables shadowing model entities) then runs against the FMU.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import yaml
from petab.v1.models.model import Model
from petab.v2 import Problem, core

import fmuid


class FmuPetabModel(Model):
    """What libpetab asks of a model, answered from an FMU's variables."""

    type_id = "fmu"

    def __init__(self, path: Path, model_id: str) -> None:
        self.info = fmuid.info(path, health=False)
        self._model_id = model_id
        self.parameters = {v.name: v for v in self.info.parameters}
        self.names = {
            v.name
            for group in (self.info.parameters, self.info.inputs, self.info.outputs)
            for v in group
        }

    @staticmethod
    def from_file(filepath_or_buffer, model_id: str) -> FmuPetabModel:
        return FmuPetabModel(Path(filepath_or_buffer), model_id)

    def to_file(self, filename=None) -> None:
        raise NotImplementedError("the FMU file is copied, not written")

    @property
    def model_id(self) -> str:
        return self._model_id

    def get_parameter_value(self, id_: str) -> float:
        return float(self.parameters[id_].start)

    def get_free_parameter_ids_with_values(self) -> Iterable[tuple[str, float]]:
        return ((n, float(v.start)) for n, v in self.parameters.items() if v.start is not None)

    def get_parameter_ids(self) -> Iterable[str]:
        return iter(self.parameters)

    def has_entity_with_id(self, entity_id) -> bool:
        return entity_id in self.names

    def get_valid_parameters_for_parameter_table(self) -> Iterable[str]:
        return iter(self.parameters)

    def get_valid_ids_for_condition_table(self) -> Iterable[str]:
        return iter(self.parameters)

    def symbol_allowed_in_observable_formula(self, id_: str) -> bool:
        return id_ in self.names

    def is_valid(self) -> bool:
        return True

    def is_state_variable(self, id_: str) -> bool:
        return False


def petab_problem(problem_yaml: Path) -> Problem:
    """Load an fmuid PEtab problem with libpetab, its FMU model through the adapter."""
    base = problem_yaml.parent
    config_dict = yaml.safe_load(problem_yaml.read_text())
    core.validate_yaml_syntax(config_dict)
    config = core.ProblemConfig(**config_dict, base_path=base, filepath=problem_yaml)

    def tables(cls, files):
        return [cls.from_tsv(f, base) for f in files] if files else None

    models = [
        FmuPetabModel(base / m.location, model_id) for model_id, m in config.model_files.items()
    ]
    return Problem(
        config=config,
        models=models,
        parameter_tables=tables(core.ParameterTable, config.parameter_files),
        measurement_tables=tables(core.MeasurementTable, config.measurement_files),
        condition_tables=tables(core.ConditionTable, config.condition_files),
        experiment_tables=tables(core.ExperimentTable, config.experiment_files),
        observable_tables=tables(core.ObservableTable, config.observable_files),
    )
