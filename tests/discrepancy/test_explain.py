"""Ties of one effect on two outputs are told apart in the verdict and in the settling tests."""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace
from typing import Any

from fmuid.data import ParameterSpec
from fmuid.discrepancy import explain
from fmuid.discrepancy.decide import Tie
from fmuid.discrepancy.effects import DeclaredPhysics, Effect
from fmuid.discrepancy.knowledge import AddedParameter
from fmuid.discrepancy.result import AddedEstimate, Diagnosis, EffectStep
from fmuid.discrepancy.schema import TieOut
from fmuid.discrepancy.settle import hypothesis_names
from fmuid.estimation.validation import ValidationEntry
from fmuid.results import result_from_dict


def _candidate(effect: str, parameter: str) -> Effect:
    spec = ParameterSpec(start=0.0, lower=-1.0, upper=1.0, scale="lin")
    added = AddedParameter(parameter, "rad", "", spec, 0.0, "inside")
    return DeclaredPhysics("", (added,), declared=effect, description="a shift")


def _step(effect: str, parameter: str, estimate: AddedEstimate) -> EffectStep:
    return EffectStep(effect, effect, "a shift", {parameter: estimate}, 40.0, 20.0, 1e-5, 1e-4)


def _mismatch(**fields: Any) -> Diagnosis:
    """A diagnosis that found a mismatch, with ``fields`` set."""
    base = result_from_dict({"mismatch": True, "chi2_before": 40.0, "chi2_after": 20.0})
    return replace(base, **fields)


def _tie(effect: str, parameter: str, p_value: float) -> Any:
    fit = SimpleNamespace(candidate=_candidate(effect, parameter))
    return Tie(fit, "vuong", 0.1, p_value, 0.5)  # type: ignore[arg-type]


def test_a_bias_on_each_output_is_named_with_its_parameter() -> None:
    estimate = AddedEstimate(0.01, (0.005, 0.015), 0.95, "rad", 0.0, True)
    named = _step("input_offset", "offset_delta", estimate)
    ties = [
        _tie("side_slope", "slope", 0.4),
        _tie("output_bias", "bias_gam_t", 0.3),
        _tie("output_bias", "bias_gam_i", 0.2),
    ]
    text = explain.explained([named], 40.0, 20.0, 1e-5, ties, True)
    assert "side_slope (Vuong p = 0.4)" in text
    assert "output_bias (bias_gam_t; Vuong p = 0.3)" in text
    assert "output_bias (bias_gam_i; Vuong p = 0.2)" in text


def test_settling_hypotheses_have_distinct_names() -> None:
    fits = [
        SimpleNamespace(candidate=_candidate("output_bias", "bias_gam_t")),
        SimpleNamespace(candidate=_candidate("output_bias", "bias_gam_i")),
        SimpleNamespace(candidate=_candidate("side_slope", "slope")),
    ]
    names = hypothesis_names(fits)  # type: ignore[arg-type]
    assert names == ["output_bias (bias_gam_t)", "output_bias (bias_gam_i)", "side_slope"]


def test_a_generic_error_model_that_fits_as_well_is_said() -> None:
    estimate = AddedEstimate(0.1, (0.05, 0.2), 0.95, "rad", 0.0, True)
    named = _step("tire_saturation", "alpha_sat", estimate)
    rival = {"effect": "unexplained", "model": "Laguerre filters", "p_value": 0.65}
    text = explain.explained([named], 40.0, 20.0, 1e-5, [], True, rival)
    assert "outside the catalogue (Laguerre filters) explains the data as well" in text
    assert "Vuong p = 0.65" in text
    found = _mismatch(
        effect="tire_saturation",
        lrt_p_value=1e-5,
        indistinguishable=(TieOut.model_validate(rival),),
        effects=(named,),
    )
    assert found.verdict().startswith("Physics outside the catalogue explains the mismatch as well")


def test_several_effects_and_held_out_errors_are_in_the_verdict() -> None:
    estimate = AddedEstimate(0.1, (0.05, 0.2), 0.95, "rad", 0.0, True)
    held_out = ValidationEntry("test.csv", "x", 100, 0.0071).with_steps([0.0069, 0.00098])
    found = _mismatch(
        effect="steer_offset",
        lrt_p_value=1e-9,
        effects=(
            _step("steer_offset", "offset", estimate),
            _step("feedback_polynomial", "c1", estimate),
        ),
        validation=(held_out,),
    )
    text = found.verdict()
    assert text.startswith("input_offset, then feedback_polynomial explain the mismatch")
    assert "held-out RMS simulation error x 0.0071 -> 0.00098 (test.csv)" in text


def test_a_misfit_well_above_the_noise_widens_the_reading_of_the_intervals() -> None:
    sentence = explain.misfit_scale(4_000.0 * 10, 10, residuals_pass=False)
    assert "chi2 4e+03 per degree of freedom" in sentence
    assert "63 times wider" in sentence  # sqrt(4000)
    assert explain.misfit_scale(4_000.0 * 10, 10, residuals_pass=True) == ""
    assert explain.misfit_scale(1.5 * 10, 10, residuals_pass=False) == ""


def test_a_named_term_whose_interval_holds_its_off_value_is_said_to_be_loose() -> None:
    pinned = AddedEstimate(0.1, (0.05, 0.2), 0.95, "m", 0.0, True)
    loose = AddedEstimate(0.005, (-0.008, 0.013), 0.95, "V", 0.0, False)
    found = _mismatch(
        effect="output_saturation",
        lrt_p_value=1e-9,
        effects=(_step("output_saturation", "max_h2", pinned), _step("input_offset", "u0", loose)),
    )
    text = found.verdict()
    assert text.startswith("output_saturation, then input_offset explain the mismatch")
    assert "but the interval of input_offset holds the off value" in text
    assert "output_saturation holds" not in text
