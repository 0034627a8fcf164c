"""One schema per result kind: every kind writes ``kind`` and ``schema_version``, validates
against its published JSON Schema, reads back equal, and files of the previous version (no
``kind``: the shape main wrote before it existed) still load."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import jsonschema
import pytest

from fmuid.discrepancy.result import Diagnosis, StageCost
from fmuid.errors import SpecError
from fmuid.estimation.result import SCHEMA_VERSION, Cost
from fmuid.experiment_design.result import DesignResult, RankedDesign
from fmuid.experiment_design.signals import Trial
from fmuid.experiment_design.verify import Verification
from fmuid.results import kind_of, load_result, result_from_dict
from fmuid.results.__main__ import main
from fmuid.results.schema import KINDS, json_schema
from plots.toy import toy_fit, toy_profile_result

#: The diagnose example of CONTRACT.md, as the previous version's reader accepted it.
CONTRACT_DIAGNOSIS = {
    "mismatch": True,
    "evidence": [
        {"test": "residual_whiteness", "output": "gam_t", "experiment": "step.csv", "p_value": 1e-6}
    ],
    "location": {
        "outputs": ["gam_t"],
        "experiments": ["step.csv"],
        "time_windows": [[1.0, 3.2]],
        "frequency_hz": [0.3, 1.0],
    },
    "effect": "output_lag",
    "description": "The yaw-rate sensors lag the motion by about 0.12 s.",
    "candidates": [
        {
            "effect": "output_lag",
            "parameters": {"tau_outputs": 0.12},
            "chi2": 101.0,
            "p_value": 1e-12,
            "bic": 120.0,
        }
    ],
    "added_parameters": {
        "tau_outputs": {
            "estimate": 0.12,
            "ci": [0.10, 0.14],
            "confidence": 0.95,
            "unit": "s",
            "off": 0.0,
            "excludes_off": True,
        }
    },
    "chi2_before": 640.2,
    "chi2_after": 101.0,
    "parameters": {"C_atf": {"before": 180000.0, "after": 221000.0}},
}

#: Fields CONTRACT.md names for each kind: the published schema requires them.
CONTRACT_FIELDS = {
    "fit": {"fmu", "n_data", "chi2", "sigma", "parameters", "cost"},
    "profile": {
        "fmu",
        "n_data",
        "chi2",
        "confidence",
        "thresholds",
        "sigma",
        "parameters",
        "better_optimum_found",
        "structural_check",
        "cost",
    },
    "diagnose": {"mismatch", "chi2_before", "chi2_after"},
    "design": {"designs", "not_identifiable_by_any", "cost"},
}


def small_design() -> DesignResult:
    trial = Trial("chirp", {"f0": 0.1, "f1": 1.2, "amplitude": 0.17}, 30.0, 10.0, ("x",), {"m": 2})
    verified = Verification(
        draws=3,
        identifiable={"k1": 1, "k2": 3},
        open_ended={"k1": 2, "k2": 0},
        widths={"k1": [0.5, 0.7, 0.9], "k2": [0.1, 0.3, 0.2]},
        simulations=40,
        seconds=1.5,
    )
    predicted = {
        "k1": {"ci": [None, None], "status": "structurally_non_identifiable"},
        "k2": {"ci": [0.5, 2.5], "status": "identifiable", "width_z": 0.7},
    }
    return DesignResult(
        fmu_sha256="ab" * 32,
        model_name="msd_parallel",
        input_name="f",
        criterion="E",
        designs=(
            RankedDesign(trial, 0.25, predicted, verified),
            RankedDesign(trial.with_(rate_hz=5.0), math.inf, predicted),
        ),
        not_identifiable_by_any=[{"parameters": ["k1", "k2"], "meaning": "only k1 + k2"}],
        tradeoffs={"drop x": {"score_ratio": None}},
        screened=12,
        cost=Cost(120, 3.25),
        stage_seconds={"screen_seconds": 1.0},
    )


def small_diagnosis() -> Diagnosis:
    """The contract's diagnosis with the cost of its steps."""
    stages = (StageCost("scan", 10, 1.25), StageCost("profiles", 2, 0.5))
    return replace(result_from_dict(CONTRACT_DIAGNOSIS), cost=Cost(12, 1.75), stages=stages)


def written(kind: str) -> dict[str, Any]:
    """The JSON of a small result of ``kind`` as ``fmuid`` writes it (``allow_nan=False``)."""
    result = {
        "fit": toy_fit,
        "profile": toy_profile_result,
        "diagnose": small_diagnosis,
        "design": small_design,
    }[kind]()
    return json.loads(json.dumps(result.to_dict(), allow_nan=False))


def save(tmp_path: Path, data: dict[str, Any]) -> Path:
    path = tmp_path / "result.json"
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize("kind", list(KINDS))
def test_each_kind_writes_its_kind_and_matches_its_published_schema(kind: str) -> None:
    data = written(kind)
    assert data["kind"] == kind and data["schema_version"] == SCHEMA_VERSION
    jsonschema.validate(data, json_schema(kind))
    assert CONTRACT_FIELDS[kind] <= set(json_schema(kind)["required"])


@pytest.mark.parametrize("kind", list(KINDS))
def test_each_kind_reads_back_as_written(kind: str, tmp_path: Path) -> None:
    data = written(kind)
    assert load_result(save(tmp_path, data)).to_dict() == data


@pytest.mark.parametrize("kind", list(KINDS))
def test_a_file_of_the_previous_version_loads(kind: str, tmp_path: Path) -> None:
    data = written(kind)
    old = {k: v for k, v in data.items() if k not in ("kind", "schema_version")}
    assert kind_of(old) == kind
    assert load_result(save(tmp_path, old)).to_dict() == data


def test_the_kind_decides_not_the_keys(tmp_path: Path) -> None:
    # a profile's JSON names its kind: read as a profile even with a design's key beside it
    data = {**written("profile"), "designs": []}
    assert type(load_result(save(tmp_path, data))).__name__ == "ProfileResult"


def test_an_unknown_kind_and_a_wrong_field_are_refused_by_name(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match="'trajectory' is unknown"):
        load_result(save(tmp_path, {**written("fit"), "kind": "trajectory"}))
    bad = written("fit")
    bad["parameters"]["m"]["estimate"] = "heavy"
    with pytest.raises(SpecError, match=r"parameters\.m\.estimate"):
        load_result(save(tmp_path, bad))


def test_the_schema_command_prints_every_kind(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([]) == 0
    assert set(json.loads(capsys.readouterr().out)) == set(KINDS)
    assert main(["profile"]) == 0
    assert json.loads(capsys.readouterr().out)["title"] == "ProfileResultOut"
    assert main(["trajectory"]) == 2


@pytest.mark.slow
def test_openapi_publishes_the_result_schemas(tmp_path: Path) -> None:
    from fmuid.api.app import create_app
    from fmuid.settings import Settings

    app = create_app(Settings(data_dir=tmp_path / "data", warm_start=False))
    schema = app.openapi()
    route = schema["paths"]["/v1/jobs/{job_id}/result"]["get"]["responses"]["200"]
    refs = {
        r["$ref"].rsplit("/", 1)[-1]
        for r in route["content"]["application/json"]["schema"]["anyOf"]
    }
    components = schema["components"]["schemas"]
    for kind, model in KINDS.items():
        assert model.__name__ in refs
        assert components[model.__name__]["properties"]["kind"]["const"] == kind
