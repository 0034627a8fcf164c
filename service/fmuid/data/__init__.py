"""Experiments (CSV data) and study specifications (JSON), loaded with full validation."""

from fmuid.data.checks import check_against_model, used_inputs
from fmuid.data.experiment import Experiment, experiment_from_arrays, load_experiment
from fmuid.data.limits import InputLimits
from fmuid.data.spec import OutputSpec, ParameterSpec, PhysicsParameter, PhysicsSpec, Spec
from fmuid.data.spec_json import load_spec, spec_from_json

__all__ = [
    "Experiment",
    "InputLimits",
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
