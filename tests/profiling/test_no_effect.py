"""Parameters that move no output: structural when the FMU holds them, an error when it ignored
them (checked by reading the value back), and the structural check with zero columns."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from tests.model.foreign import reference_fmu
from tests.model.quirks import build_quirk_fmu

import fmuid
from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.errors import FmuError
from fmuid.profiling.result import STRUCTURALLY_NON_IDENTIFIABLE
from fmuid.profiling.structural import structural_check


def test_an_all_zero_jacobian_names_every_parameter() -> None:
    check = structural_check(np.zeros((6, 2)), ["a", "b"], ["lin", "lin"], [1.0, 2.0])
    combos = check["non_identifiable_combinations"]
    assert [c["parameters"] for c in combos] == [["a"], ["b"]]
    assert combos[0]["meaning"] == "a has no effect on the outputs here"


def test_a_zero_column_beside_a_sum() -> None:
    rng = np.random.default_rng(0)
    column = rng.normal(size=8)
    jac = np.column_stack([column, np.zeros(8), column, rng.normal(size=8)])
    check = structural_check(jac, ["k1", "dead", "k2", "c"], ["lin"] * 4, [1.0, 1.0, 1.0, 1.0])
    meanings = {
        tuple(c["parameters"]): c["meaning"] for c in check["non_identifiable_combinations"]
    }
    assert meanings == {
        ("dead",): "dead has no effect on the outputs here",
        ("k1", "k2"): "only k1 + k2 is identifiable",
    }


def test_an_unused_parameter_is_structural() -> None:
    t = np.round(np.arange(0.0, 2.0 + 1e-9, 0.2), 10)
    data = experiment_from_arrays(
        "ft.csv", t, {"Float64_continuous_input": t, "Float64_continuous_output": t}
    )
    body = {
        "parameters": {"Float64_tunable_parameter": {"start": 1.0, "lower": 0.0, "upper": 2.0}},
        "outputs": {"Float64_continuous_output": {"sigma": 0.1}},
        "global_search": False,
    }
    path = reference_fmu("fmi2", "Feedthrough")
    result = fmuid.profile(path, [data], spec_from_json(json.dumps(body)), workers=1)
    assert result.parameters["Float64_tunable_parameter"].status == STRUCTURALLY_NON_IDENTIFIABLE
    assert result.checks["health"]["no_effect"] == ["Float64_tunable_parameter"]


def test_an_ignored_parameter_is_an_error(tmp_path: Path) -> None:
    fmu = build_quirk_fmu("setup_resets", tmp_path, layer="initialization_resets.c")
    t = np.round(np.arange(0.0, 2.0 + 1e-9, 0.2), 10)
    data = experiment_from_arrays("tanks.csv", t, {"q": np.ones_like(t), "h1": 1 - np.exp(-t)})
    body = {
        "parameters": {"R1": {"start": 2.0, "lower": 0.5, "upper": 4.0}},
        "outputs": {"h1": {"sigma": 0.01}},
        "global_search": False,
    }
    with pytest.raises(FmuError, match="ignored the parameter.s. R1: .*R1 set to 2 holds 1"):
        fmuid.profile(fmu, [data], spec_from_json(json.dumps(body)), workers=1)
