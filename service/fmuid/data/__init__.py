"""Experiments (CSV data) and study specifications (JSON), loaded with full validation."""

from fmuid.data.experiment import Experiment, experiment_from_arrays, load_experiment
from fmuid.data.spec import (
    OutputSpec,
    ParameterSpec,
    PhysicsParameter,
    PhysicsSpec,
    Spec,
    check_against_model,
    load_spec,
    spec_from_json,
    used_inputs,
)

__all__ = [
    "Experiment",
    "OutputSpec",
    "ParameterSpec",
    "PhysicsParameter",
    "PhysicsSpec",
    "Spec",
    "check_against_model",
    "experiment_from_arrays",
    "load_experiment",
    "load_spec",
    "spec_from_json",
    "used_inputs",
]
