"""No second definition of a result's JSON: every result class writes its kind's schema model,
the service and ``python -m fmuid.results`` publish the same models, a field the schema does not
name is refused when written and dropped (with a warning) when a file of another version is
read, and files written by the previous version (``previous/``) read back as they are."""

from __future__ import annotations

import ast
import json
import logging
import typing
from dataclasses import replace
from pathlib import Path

import pytest
from pydantic import ValidationError

from fmuid.api import results as api_results
from fmuid.discrepancy.schema import TieOut
from fmuid.estimation.schema import Written
from fmuid.results import load_result
from fmuid.results.__main__ import main
from fmuid.results.schema import KINDS, RESULTS
from results.test_schema import save, small_diagnosis, written

PACKAGE = Path(__file__).resolve().parents[2] / "service" / "fmuid"
RESULT_ROOMS = ("estimation", "profiling", "discrepancy", "experiment_design", "results")
"""The packages whose objects end up in a result's JSON."""
PREVIOUS = Path(__file__).with_name("previous")


@pytest.mark.parametrize("kind", list(KINDS))
def test_each_result_class_writes_its_kinds_schema(kind: str) -> None:
    cls = RESULTS[kind]
    assert cls.schema is KINDS[kind]
    to_dict = cls.to_dict  # the session's check wraps it (tests/conftest.py)
    assert getattr(to_dict, "__wrapped__", to_dict) is Written.to_dict


def test_no_module_of_the_results_writes_json_by_hand() -> None:
    hand_written = [
        f"{path.relative_to(PACKAGE)}:{node.lineno}"
        for room in RESULT_ROOMS
        for path in sorted((PACKAGE / room).rglob("*.py"))
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
        if isinstance(node, ast.FunctionDef) and node.name == "to_dict"
    ]
    assert hand_written == ["estimation/schema.py:" + str(Written.to_dict.__code__.co_firstlineno)]


def test_the_service_and_the_schema_command_publish_the_same_models(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert set(typing.get_args(api_results.ResultOut)) == set(KINDS.values())
    for kind, model in KINDS.items():
        assert main([kind]) == 0
        assert json.loads(capsys.readouterr().out) == model.model_json_schema()


def test_a_field_the_schema_does_not_name_is_refused_when_written() -> None:
    diagnosis = small_diagnosis()
    with pytest.raises(ValidationError, match="location.colour"):
        replace(diagnosis, location={**diagnosis.location, "colour": "red"}).to_dict()
    tie = {"effect": "output_bias", "chi2": 1.0, "test": "vuong", "statistic": 0.1}
    tie |= {"p_value": 0.5, "max_difference_sigma": 0.2, "shade": 1}
    with pytest.raises(ValidationError, match="shade"):
        TieOut.model_validate(tie)


@pytest.mark.parametrize("kind", list(KINDS))
def test_a_file_of_another_version_loads_without_the_fields_it_does_not_name(
    kind: str, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    data = written(kind)
    newer = {**data, "schema_version": 2, "colour": "red", "fmu": {**data["fmu"], "shade": 1}}
    with caplog.at_level(logging.WARNING):
        assert load_result(save(tmp_path, newer)).to_dict() == data
    assert "colour" in caplog.text and "shade" in caplog.text


@pytest.mark.parametrize("path", sorted(PREVIOUS.glob("*.json")), ids=lambda p: p.stem)
def test_a_result_written_by_the_previous_version_reads_back_as_written(path: Path) -> None:
    saved = json.loads(path.read_text())
    again = load_result(path).to_dict()
    assert json.dumps(again, sort_keys=True) == json.dumps(saved, sort_keys=True)
