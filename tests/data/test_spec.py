from __future__ import annotations

import json

import pytest
from hypothesis import given
from hypothesis import strategies as st
from pydantic import ValidationError

from fmuid.data import ParameterSpec, Spec, load_spec, spec_from_json
from fmuid.errors import SpecError

CONTRACT_EXAMPLE = {
    "parameters": {"C_atf": {"start": 220000, "lower": 10000, "upper": 700000}},
    "fixed": {"u_tc": 4.5},
    "inputs": ["delta"],
    "outputs": {"gam_t": {"sigma": 0.00089}, "gam_i": {"sigma": "estimate"}},
    "confidence": 0.68,
    "global_search": True,
    "seed": 0,
}


def spec_error(data: object) -> str:
    text = data if isinstance(data, str) else json.dumps(data)
    with pytest.raises(SpecError) as caught:
        spec_from_json(text, source="spec.json")
    return str(caught.value)


def with_changes(**changes: object) -> dict:
    return {**CONTRACT_EXAMPLE, **changes}


def with_parameter(**fields: object) -> dict:
    return with_changes(parameters={"C_atf": fields})


def test_contract_example_loads_with_defaults():
    spec = spec_from_json(json.dumps(CONTRACT_EXAMPLE), source="study.json")
    assert spec.source == "study.json"
    assert spec.parameters["C_atf"].resolved_scale == "log"
    assert spec.fixed == {"u_tc": 4.5}
    assert spec.outputs["gam_i"].sigma == "estimate"
    assert spec.outputs["gam_t"].sigma == 0.00089
    minimal = Spec.model_validate(
        {"parameters": CONTRACT_EXAMPLE["parameters"], "outputs": {"x": {"sigma": 1}}}
    )
    assert (minimal.confidence, minimal.global_search, minimal.seed) == (0.68, True, 0)
    assert (minimal.fixed, minimal.inputs, minimal.physics) == ({}, [], {})
    assert minimal.source == "spec"


def test_lower_not_below_upper():
    message = spec_error(with_parameter(start=3.0, lower=5.0, upper=2.0))
    assert message == "spec.json: parameters.C_atf.lower: lower (5.0) must be below upper (2.0)"


def test_start_outside_bounds():
    message = spec_error(with_parameter(start=9.0, lower=1.0, upper=2.0))
    assert message.startswith("spec.json: parameters.C_atf.start: start (9.0) must lie within")


@pytest.mark.parametrize("literal", ["NaN", "Infinity", "-Infinity"])
def test_non_finite_numbers(literal):
    message = spec_error(
        json.dumps(with_parameter(start=1.0, lower=0.0, upper=2.0)).replace("2.0", literal)
    )
    assert message.startswith("spec.json: parameters.C_atf.upper: Input should be a finite number")


@pytest.mark.parametrize("value", [True, "2.0", None])
def test_numbers_must_be_numbers(value):
    message = spec_error(with_parameter(start=1.0, lower=0.0, upper=value))
    assert message.startswith("spec.json: parameters.C_atf.upper: Input should be a valid number")


@pytest.mark.parametrize(
    ("lower", "scale", "expected"),
    [
        (1.0, None, "log"),
        (0.0, None, "lin"),
        (-1.0, None, "lin"),
        (1.0, "lin", "lin"),
        (1.0, "log", "log"),
    ],
)
def test_scale_resolution(lower, scale, expected):
    parameter = ParameterSpec(start=lower + 1, lower=lower, upper=lower + 2, scale=scale)
    assert parameter.resolved_scale == expected


@given(
    lower=st.floats(-1e6, 1e6, allow_subnormal=False),
    width=st.floats(1e-3, 1e6),
    scale=st.sampled_from([None, "lin", "log"]),
)
def test_scale_resolution_property(lower, width, scale):
    upper = lower + width
    if scale == "log" and lower <= 0:
        with pytest.raises(ValidationError, match="scale 'log' needs lower > 0"):
            ParameterSpec(start=lower, lower=lower, upper=upper, scale=scale)
        return
    parameter = ParameterSpec(start=lower, lower=lower, upper=upper, scale=scale)
    assert parameter.resolved_scale == (scale or ("log" if lower > 0 else "lin"))


def test_log_scale_needs_positive_lower():
    message = spec_error(with_parameter(start=1.0, lower=0.0, upper=2.0, scale="log"))
    assert message == (
        "spec.json: parameters.C_atf.scale: scale 'log' needs lower > 0 (lower is 0.0); use 'lin'"
    )


def test_unknown_scale():
    message = spec_error(with_parameter(start=1.0, lower=0.5, upper=2.0, scale="ln"))
    assert (
        message == "spec.json: parameters.C_atf.scale: Input should be 'log' or 'lin' (got \"ln\")"
    )


def test_typo_is_an_error_with_suggestion():
    message = spec_error(with_parameter(start=1.0, lowr=0.5, upper=2.0))
    assert message.splitlines() == [
        "spec.json: parameters.C_atf.lower: required field is missing",
        "spec.json: parameters.C_atf.lowr: unknown field (did you mean 'lower'?)",
    ]
    assert "confidnce: unknown field (did you mean 'confidence'?)" in spec_error(
        with_changes(confidnce=0.9)
    )
    assert "spec.json: zzz: unknown field (fields: confidence, fixed," in spec_error(
        with_changes(zzz=1)
    )


@pytest.mark.parametrize("sigma", [0, -0.1, "estimated", True, None, "NaN"])
def test_bad_sigma(sigma):
    data = with_changes(outputs={"gam_t": {"sigma": sigma}})
    message = spec_error(json.dumps(data).replace('"NaN"', "NaN"))
    assert message.startswith(
        "spec.json: outputs.gam_t.sigma: sigma must be a positive number, 'column' or 'estimate'"
    )


def test_missing_and_empty_sections():
    assert spec_error({"outputs": {"x": {"sigma": 1}}}) == (
        "spec.json: parameters: required field is missing"
    )
    assert spec_error(with_changes(parameters={})) == (
        "spec.json: parameters: at least one entry is required"
    )
    assert spec_error(with_changes(outputs={})) == (
        "spec.json: outputs: at least one entry is required"
    )


@pytest.mark.parametrize("confidence", [0, 1, 1.5, -0.2])
def test_confidence_strictly_inside_unit_interval(confidence):
    assert spec_error(with_changes(confidence=confidence)).startswith("spec.json: confidence: ")


def test_seed_and_flags_are_typed():
    assert spec_error(with_changes(seed=-1)).startswith("spec.json: seed: ")
    assert spec_error(with_changes(global_search="yes")).startswith("spec.json: global_search: ")
    assert spec_error(with_changes(inputs="delta")).startswith("spec.json: inputs: ")
    assert spec_error(with_changes(inputs=["delta", 3])).startswith("spec.json: inputs[1]: ")


def test_free_and_fixed():
    message = spec_error(with_changes(fixed={"C_atf": 1.0}))
    assert message == "spec.json: fixed.C_atf: 'C_atf' is both free and fixed"


def test_input_listed_twice():
    message = spec_error(with_changes(inputs=["delta", "delta"]))
    assert message == "spec.json: inputs[1]: 'delta' is listed twice or is an output"


def test_several_problems_one_line_each():
    message = spec_error(with_changes(confidence=2, seed="0", outputs={"x": {"sigma": -1}}))
    assert [line.split(":")[1].strip() for line in message.splitlines()] == [
        "outputs.x.sigma",
        "confidence",
        "seed",
    ]


PHYSICS = {
    "output_lag": {
        "description": "first-order lag on measured outputs",
        "parameters": {
            "tau_outputs": {"off": 0.0, "start": 0.05, "lower": 0.0, "upper": 1.0, "unit": "s"}
        },
    }
}


def test_physics():
    spec = spec_from_json(json.dumps(with_changes(physics=PHYSICS)))
    parameter = spec.physics["output_lag"].parameters["tau_outputs"]
    assert (parameter.off, parameter.unit, parameter.resolved_scale) == (0.0, "s", "lin")
    assert isinstance(parameter, ParameterSpec)


def test_physics_errors():
    clash = {"e": {"parameters": {"C_atf": {"off": 0, "start": 1, "lower": 0, "upper": 2}}}}
    assert spec_error(with_changes(physics=clash)) == (
        "spec.json: physics.e.parameters.C_atf: "
        "'C_atf' is already a free, fixed or physics parameter"
    )
    assert spec_error(with_changes(physics={"e": {"parameters": {}}})) == (
        "spec.json: physics.e.parameters: an effect needs at least one parameter"
    )
    typo = {"e": {"parameters": {"p": {"of": 0, "start": 1, "lower": 0, "upper": 2}}}}
    assert "physics.e.parameters.p.of: unknown field (did you mean 'off'?)" in spec_error(
        with_changes(physics=typo)
    )


def test_invalid_json_has_line_and_column():
    message = spec_error('{\n  "parameters": {,\n}')
    assert message.startswith("spec.json: invalid JSON at line 2, column 18: ")


def test_duplicate_key_empty_text_and_non_object():
    assert (
        spec_error('{"seed": 1, "seed": 2}') == "spec.json: key 'seed' appears twice in one object"
    )
    assert spec_error("  ") == "spec.json: file is empty"
    assert spec_error("[1, 2]") == "spec.json: the spec must be a JSON object, got an array"
    assert spec_error("null") == "spec.json: the spec must be a JSON object, got null"


def test_load_spec(tmp_path):
    path = tmp_path / "study.json"
    path.write_bytes(b"\xef\xbb\xbf" + json.dumps(CONTRACT_EXAMPLE).encode())
    assert load_spec(path).source == "study.json"
    with pytest.raises(SpecError, match=r"^nowhere\.json: file not found"):
        load_spec(tmp_path / "nowhere.json")
    path.write_bytes(b'{"seed": \xff}')
    with pytest.raises(SpecError, match=r"^study\.json: not UTF-8 text \(byte 9\)"):
        load_spec(path)
    path.write_text(json.dumps(with_changes(seed=-3)))
    with pytest.raises(SpecError, match=r"^study\.json: seed: "):
        load_spec(path)


def test_per_experiment_names_free_parameters():
    free = {"x1_0": {"start": 0.0, "lower": -1.0, "upper": 1.0}, **CONTRACT_EXAMPLE["parameters"]}
    spec = spec_from_json(json.dumps(with_changes(parameters=free, per_experiment=["x1_0"])))
    assert spec.per_experiment == ["x1_0"]
    assert spec_from_json(json.dumps(CONTRACT_EXAMPLE)).per_experiment == []
    cases = [
        (["x1_0", "x1_0"], {}, "spec.json: per_experiment[1]: 'x1_0' is listed twice"),
        (["h2"], {}, "spec.json: per_experiment[0]: 'h2' is not in parameters: only a free"),
        (["u_tc"], {}, "spec.json: per_experiment[0]: 'u_tc' is fixed: only a free parameter"),
        (
            ["x1_0"],
            {"x1_0@run.csv": {"start": 0.0, "lower": -1.0, "upper": 1.0}},
            "'x1_0@run.csv' is a parameter of its own, but would also name the value of 'x1_0' "
            "in experiment 'run.csv'",
        ),
    ]
    for names, extra, message in cases:
        assert message in spec_error(
            with_changes(parameters={**free, **extra}, per_experiment=names)
        )
    assert "per_experiment[0]" in spec_error(with_changes(per_experiment=[3]))
