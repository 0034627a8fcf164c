from __future__ import annotations

import numpy as np
import pytest

from fmuid.data import Spec, check_against_model, experiment_from_arrays, used_inputs
from fmuid.errors import DataError, SpecError

PARAMETERS = ["m", "k1", "k2", "b"]
INPUTS = ["f"]
OUTPUTS = ["x", "v"]
NAN = np.nan


def make_spec(**changes: object) -> Spec:
    data = {
        "parameters": {"k1": {"start": 3.0, "lower": 0.1, "upper": 10.0}},
        "fixed": {"m": 1.1},
        "inputs": ["f"],
        "outputs": {"x": {"sigma": 0.01}},
        **changes,
    }
    return Spec.model_validate(data)


def experiment(name: str = "step.csv", **columns: list[float]):
    time = np.arange(len(next(iter(columns.values()))), dtype=float)
    return experiment_from_arrays(name, time, columns)


def check(spec: Spec, *experiments) -> None:
    check_against_model(spec, PARAMETERS, INPUTS, OUTPUTS, experiments)


def error_of(kind, spec, *experiments) -> str:
    with pytest.raises(kind) as caught:
        check(spec, *experiments)
    return str(caught.value)


def test_consistent_study_passes():
    sigma = {"x": {"sigma": "column"}, "v": {"sigma": "estimate"}}
    check(
        make_spec(outputs=sigma),
        experiment(f=[0, 1, 1], x=[NAN, 2, 3], v=[1, 2, NAN], sigma_x=[NAN, 0.1, 0.2]),
        experiment("b.csv", f=[0, 1], x=[1, 2], sigma_x=[0.1, 0.1]),
    )


def test_unknown_free_parameter_suggests_close_names():
    message = error_of(
        SpecError, make_spec(parameters={"k3": {"start": 1, "lower": 0, "upper": 2}})
    )
    assert (
        message == "spec: parameters.k3: the FMU has no parameter 'k3' (did you mean 'k2' or 'k1'?)"
    )


def test_unknown_fixed_parameter_lists_the_fmu_parameters():
    message = error_of(SpecError, make_spec(fixed={"zeta": 1.0}))
    assert (
        message
        == "spec: fixed.zeta: the FMU has no parameter 'zeta' (its parameters: b, k1, k2, m)"
    )


def test_unknown_physics_parameter():
    physics = {"lag": {"parameters": {"tau": {"off": 0, "start": 0.1, "lower": 0, "upper": 1}}}}
    message = error_of(SpecError, make_spec(physics=physics))
    assert message.startswith("spec: physics.lag.parameters.tau: the FMU has no parameter 'tau'")


def test_unknown_spec_input_and_output_all_reported():
    message = error_of(SpecError, make_spec(inputs=["F"], outputs={"y": {"sigma": 1}}))
    assert message.splitlines() == [
        "spec: inputs: the FMU has no input 'F' (did you mean 'f'?)",
        "spec: outputs: the FMU has no output 'y' (its outputs: v, x)",
    ]


def test_spec_source_is_named():
    spec = make_spec(fixed={"zeta": 1.0})
    spec._source = "study.json"
    assert error_of(SpecError, spec).startswith("study.json: fixed.zeta:")


def test_unknown_csv_column():
    message = error_of(DataError, make_spec(), experiment(f=[0, 1], x=[1, 2], speed=[1, 2]))
    assert message.startswith("step.csv: row 1, column 'speed': not an input or output of the FMU")


def test_sigma_of_non_output_is_unknown():
    message = error_of(DataError, make_spec(), experiment(f=[0, 1], x=[1, 2], sigma_f=[1, 2]))
    assert message.startswith("step.csv: row 1, column 'sigma_f': not an input or output")


def test_spec_input_missing_from_csv():
    message = error_of(DataError, make_spec(), experiment(x=[1, 2]))
    assert message == "step.csv: column 'f' is missing (the spec lists it in inputs)"


def test_input_without_any_value():
    message = error_of(DataError, make_spec(), experiment(f=[NAN, NAN], x=[1, 2]))
    assert message == "step.csv: column 'f': the input has no value in any row"


def test_spec_output_without_column_in_any_experiment():
    spec = make_spec(outputs={"v": {"sigma": 1}})
    message = error_of(
        DataError, spec, experiment(f=[0, 1], x=[1, 2]), experiment("b.csv", f=[0, 1])
    )
    assert message == "output 'v' (spec) has no column in any data file (step.csv, b.csv)"


def test_output_column_without_any_value():
    message = error_of(
        DataError,
        make_spec(),
        experiment(f=[0, 1], x=[1, 2]),
        experiment("b.csv", f=[0, 1], x=[NAN, NAN]),
    )
    assert message == "b.csv: column 'x': the output has no value in any row"


def test_sigma_column_missing():
    spec = make_spec(outputs={"x": {"sigma": "column"}})
    message = error_of(DataError, spec, experiment(f=[0, 1], x=[1, 2]))
    assert message == "step.csv: column 'sigma_x' is missing (outputs.x.sigma is 'column')"


def test_sigma_cell_empty_where_output_has_value():
    spec = make_spec(outputs={"x": {"sigma": "column"}})
    message = error_of(
        DataError, spec, experiment(f=[0, 1, 2], x=[1, NAN, 2], sigma_x=[1, NAN, NAN])
    )
    assert message == "step.csv: row 4, column 'sigma_x': empty, but 'x' has a value in this row"


@pytest.mark.parametrize("bad", [0.0, -0.5])
def test_sigma_cell_not_positive(bad):
    spec = make_spec(outputs={"x": {"sigma": "column"}})
    message = error_of(DataError, spec, experiment(f=[0, 1], x=[1, 2], sigma_x=[1, bad]))
    assert message == f"step.csv: row 3, column 'sigma_x': sigma must be positive, got {bad!r}"


def test_used_inputs():
    data = experiment(x=[1, 2], f=[0, 1])
    assert used_inputs(make_spec(inputs=[]), INPUTS, data) == ["f"]
    assert used_inputs(make_spec(inputs=[]), INPUTS, experiment(x=[1, 2])) == []
    assert used_inputs(make_spec(), INPUTS, data) == ["f"]
    check(make_spec(inputs=[]), data)
