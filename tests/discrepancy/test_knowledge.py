"""Model knowledge comes from the FMU's annotation and the spec, never from a model's name."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.data.spec import ParameterSpec
from fmuid.discrepancy.catalogue import TIME_FLOOR, catalogue
from fmuid.discrepancy.effects import FeedbackPolynomial
from fmuid.discrepancy.knowledge import AddedParameter, model_knowledge, read_annotations
from fmuid.discrepancy.words import Words
from fmuid.estimation.study import make_problem

PACKAGE = Path(__file__).resolve().parents[2] / "service" / "fmuid" / "discrepancy"


def test_tractor_declares_its_switchable_physics_and_steer_input(tractor_fmu: Path) -> None:
    knowledge = read_annotations(tractor_fmu)
    physics = {p.effect: p for p in knowledge.physics}
    assert set(physics) == {"tire_saturation", "side_slope"}
    (alpha_sat,) = physics["tire_saturation"].parameters
    assert alpha_sat.name == "alpha_sat" and alpha_sat.off == 0.0 and alpha_sat.off_side == "high"
    (slope,) = physics["side_slope"].parameters
    assert slope.off_side == "inside" and slope.unit == "rad"
    assert knowledge.role("delta") == "steer"


def test_an_fmu_without_annotation_gets_generic_effects_named_by_its_variables(
    msd_fmu: Path,
) -> None:
    spec = spec_from_json(
        json.dumps(
            {
                "parameters": {"k": {"start": 4, "lower": 0.1, "upper": 10}},
                "inputs": ["f"],
                "outputs": {"x": {"sigma": 0.1}},
            }
        )
    )
    knowledge = model_knowledge(msd_fmu, spec)
    assert knowledge.physics == () and knowledge.role("f") is None
    time = np.linspace(0.0, 4.0, 41)
    exp = experiment_from_arrays("e.csv", time, {"f": np.sin(time), "x": 0.1 * np.sin(time)})
    problem = make_problem(msd_fmu, [exp], spec)
    effects = catalogue(problem, knowledge, {"k": 4.0})
    assert {e.label for e in effects} == {
        "input_offset(offset_f)",
        "input_gain(gain_f)",
        "input_lag(tau_f)",
        "input_delay(delay_f)",
        "input_dead_zone(dead_f)",
        "input_saturation(limit_f)",
        "output_lag(tau_outputs)",
        "output_gain(gain_x)",
        "output_bias(bias_x)",
        "output_saturation(max_x)",
        "output_saturation(min_x)",
        "feedback_polynomial(c2_x_f)",
        "feedback_polynomial(c3_x_f)",
        "feedback_friction(coulomb_v_f)",
    }
    values = {p.name: p.spec.upper / 2 for e in effects for p in e.parameters}
    text = " ".join(e.sentence(values) for e in effects)
    assert "steer" not in text and "gyro" not in text
    # the FMU's units make the words: a force from a displacement is a spring, v is a rate
    cubic = next(e for e in effects if e.names == ("c3_x_f",))
    assert "hardening spring" in cubic.sentence({"c3_x_f": -1.0})
    assert "softening spring" in cubic.sentence({"c3_x_f": 1.0})
    friction = next(e for e in effects if e.effect == "feedback_friction")
    assert friction.sentence({"coulomb_v_f": 0.2}).startswith("Coulomb friction: a force of 0.2 N")
    # ranges from the data: a lag or a delay from below a sample to a fifth of the record
    tau = next(e for e in effects if e.names == ("tau_f",)).parameters[0].spec
    assert tau.lower == pytest.approx(0.1 * TIME_FLOOR) and tau.upper == pytest.approx(4.0 / 5)


def test_spec_physics_adds_to_the_declared_ones(tractor_fmu: Path) -> None:
    spec = spec_from_json(
        json.dumps(
            {
                "parameters": {"C_atf": {"start": 2e5, "lower": 1e4, "upper": 7e5}},
                "inputs": ["delta"],
                "outputs": {"gam_t": {"sigma": 0.001}},
                "physics": {
                    "heavier_implement": {
                        "parameters": {
                            "m_i": {"start": 2127, "lower": 1000, "upper": 5000, "off": 2127}
                        }
                    }
                },
            }
        )
    )
    effects = {p.effect for p in model_knowledge(tractor_fmu, spec).physics}
    assert effects == {"tire_saturation", "side_slope", "heavier_implement"}


def test_the_diagnosis_code_names_no_model() -> None:
    for path in PACKAGE.glob("*.py"):
        text = path.read_text()
        for word in ("tractor", "TRACTOR", '"delta"', "gam_t", "x_tc"):
            assert word not in text, f"{path.name} names {word}"


def test_a_polynomial_coefficient_unit_names_only_the_units_declared() -> None:
    both = Words({"f": "N", "x": "m"})
    assert both.per_power("f", "x", 3) == "N/m^3"
    assert Words({"x": "m"}).per_power("f", "x", 2) == "1/m^2"
    assert Words({"f": "N"}).per_power("f", "x", 2) == "N"
    assert Words().per_power("f", "x", 2) == ""
    spec = ParameterSpec(start=0.0, lower=-1.0, upper=1.0, scale="lin")
    p = AddedParameter("c2_h_u", "", "h^2 fed into u", spec, 0.0, "inside")
    sentence = FeedbackPolynomial("u", (p,), Words(), source="h", power=2).sentence({"c2_h_u": -2})
    assert sentence.endswith("(an even static nonlinearity the model leaves out, c2_h_u = -2)")
