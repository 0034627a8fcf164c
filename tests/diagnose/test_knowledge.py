"""Model knowledge comes from the FMU's annotation and the spec, never from a model's name."""

from __future__ import annotations

import json
from pathlib import Path

from fmuid.data import spec_from_json
from fmuid.discrepancy.catalogue import catalogue
from fmuid.discrepancy.knowledge import model_knowledge, read_annotations

PACKAGE = Path(__file__).resolve().parents[2] / "service" / "fmuid" / "diagnose"


def test_tractor_declares_its_switchable_physics_and_steer_input(tractor_fmu: Path) -> None:
    knowledge = read_annotations(tractor_fmu)
    physics = {p.effect: p for p in knowledge.physics}
    assert set(physics) == {"tire_saturation", "side_slope"}
    (alpha_sat,) = physics["tire_saturation"].parameters
    assert alpha_sat.name == "alpha_sat" and alpha_sat.off == 0.0 and alpha_sat.off_side == "high"
    (slope,) = physics["side_slope"].parameters
    assert slope.off_side == "inside" and slope.unit == "rad"
    assert knowledge.role("delta") == "steer"


def test_an_fmu_without_annotation_gets_generic_candidates_named_by_its_input(
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
    cands = catalogue(knowledge, spec, ["f"], ["x"], {"x": 1.0}, {"f": "N", "x": "m"})
    names = {c.label for c in cands}
    assert names == {
        "sensor_lag(tau_sensor)", "input_delay(delay_f)", "steering_lag(tau_f)",
        "steer_offset(offset_f)", "gyro_bias(bias_x)",
    }  # fmt: skip
    text = " ".join(c.description for c in cands)
    assert "steer" not in text and "gyro" not in text


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
