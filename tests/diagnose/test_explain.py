"""Ties of one effect on two outputs are told apart in the verdict and in the settling tests."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

from fmuid.data import ParameterSpec
from fmuid.discrepancy import explain
from fmuid.discrepancy.catalogue import Candidate
from fmuid.discrepancy.decide import Tie
from fmuid.discrepancy.knowledge import AddedParameter
from fmuid.discrepancy.result import AddedEstimate
from fmuid.discrepancy.settle import hypothesis_names


def _candidate(effect: str, parameter: str) -> Candidate:
    spec = ParameterSpec(start=0.0, lower=-1.0, upper=1.0, scale="lin")
    added = AddedParameter(parameter, "rad", "", spec, 0.0, "inside")
    return Candidate(effect, (added,), None, "a shift of {value}")


def _tie(effect: str, parameter: str, p_value: float) -> Any:
    fit = SimpleNamespace(candidate=_candidate(effect, parameter))
    return Tie(fit, "vuong", 0.1, p_value, 0.5)  # type: ignore[arg-type]


def test_a_bias_on_each_output_is_named_with_its_parameter() -> None:
    named = _candidate("steer_offset", "offset_steer")
    estimate = AddedEstimate(0.01, (0.005, 0.015), 0.95, "rad", 0.0, True)
    ties = [
        _tie("side_slope", "slope", 0.4),
        _tie("gyro_bias", "bias_gam_t", 0.3),
        _tie("gyro_bias", "bias_gam_i", 0.2),
    ]
    text = explain.explained([named], {"offset_steer": estimate}, 40.0, 20.0, 1e-5, ties, True)
    assert "side_slope (Vuong p = 0.4)" in text
    assert "gyro_bias (bias_gam_t; Vuong p = 0.3)" in text
    assert "gyro_bias (bias_gam_i; Vuong p = 0.2)" in text


def test_settling_hypotheses_have_distinct_names() -> None:
    fits = [
        SimpleNamespace(candidate=_candidate("gyro_bias", "bias_gam_t")),
        SimpleNamespace(candidate=_candidate("gyro_bias", "bias_gam_i")),
        SimpleNamespace(candidate=_candidate("side_slope", "slope")),
    ]
    names = hypothesis_names(fits)  # type: ignore[arg-type]
    assert names == ["gyro_bias (bias_gam_t)", "gyro_bias (bias_gam_i)", "side_slope"]


def test_a_generic_error_model_that_fits_as_well_is_said() -> None:
    named = _candidate("tire_saturation", "alpha_sat")
    estimate = AddedEstimate(0.1, (0.05, 0.2), 0.95, "rad", 0.0, True)
    rival = {"effect": "unexplained", "model": "Laguerre filters", "p_value": 0.65}
    text = explain.explained([named], {"alpha_sat": estimate}, 40.0, 20.0, 1e-5, [], True, rival)
    assert "outside the catalogue (Laguerre filters) explains the data as well" in text
    assert "Vuong p = 0.65" in text
