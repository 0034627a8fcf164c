"""Input limits: each refusal names the limit and its setting; the number pattern is linear."""

from __future__ import annotations

import json

import pytest

from fmuid.data import InputLimits, load_experiment, spec_from_json
from fmuid.data.experiment import _CELL
from fmuid.errors import DataError, SpecError

from .helpers import write_csv

SPEC = {
    "parameters": {"k": {"start": 1.0, "lower": 0.1, "upper": 10.0}},
    "outputs": {"x": {"sigma": 0.1}},
}


def csv_error(tmp_path, text: str, **limits: int) -> str:
    with pytest.raises(DataError) as caught:
        load_experiment(write_csv(tmp_path, text), InputLimits(**limits))
    return str(caught.value)


def spec_error(text: str, **limits: int) -> str:
    with pytest.raises(SpecError) as caught:
        spec_from_json(text, "spec.json", InputLimits(**limits))
    return str(caught.value)


def test_long_digit_runs_are_judged_right():
    digits = "1" * 200_000
    assert _CELL.fullmatch(digits + "x") is None
    assert _CELL.fullmatch(" -" + digits + ".5e-3 ") is not None
    for good in ("", "  ", "1", "+1.", ".5", "-1.5E+07", " 2e3 "):
        assert _CELL.fullmatch(good), good
    for bad in (".", "+", "e5", "1e", "1.2.3", "1 2", "0x10", "--1"):
        assert _CELL.fullmatch(bad) is None, bad


def test_long_bad_cell_is_named_with_its_row_and_column(tmp_path):
    text = "time,x\n0,1\n1," + "9" * 100_000 + "x\n"
    message = csv_error(tmp_path, text, max_cell_chars=200_000)
    assert message.startswith("step.csv: row 3, column 'x': text '999")


def test_cell_and_column_limits(tmp_path):
    message = csv_error(tmp_path, "time,x\n0,1\n1,22222\n", max_cell_chars=4)
    assert message == (
        "step.csv: row 3, column 2: more than the limit of 4 characters in a cell"
        " (FMUID_MAX_CELL_CHARS)"
    )
    message = csv_error(tmp_path, "time,x,y\n0,1,2\n1,2,3\n", max_csv_columns=2)
    assert message == "step.csv: row 1: more than the limit of 2 columns (FMUID_MAX_CSV_COLUMNS)"


def test_duplicate_column_among_many_is_named(tmp_path):
    names = [f"c{i}" for i in range(900)] + ["c7"]
    text = "time," + ",".join(names) + "\n" + "0" + ",1" * 901 + "\n1" + ",1" * 901 + "\n"
    message = csv_error(tmp_path, text)
    assert message == "step.csv: row 1: column name 'c7' appears twice (columns 9 and 902)"


def test_spec_limits():
    deep = json.dumps({**SPEC, "inputs": [[[[[[]]]]]]})
    assert spec_error(deep, max_spec_depth=4) == (
        "spec.json: more than the limit of 4 nested arrays and objects (FMUID_MAX_SPEC_DEPTH)"
    )
    very_deep = (
        json.dumps(SPEC)
        .replace("{}", "")
        .replace('"outputs"', '"x": ' + "[" * 100_000 + "]" * 100_000 + ', "outputs"')
    )
    assert "(FMUID_MAX_SPEC_DEPTH)" in spec_error(very_deep)
    keys = json.dumps({**SPEC, "fixed": {f"p{i}": 1.0 for i in range(50)}})
    assert spec_error(keys, max_spec_keys=40) == (
        "spec.json: more than the limit of 40 keys (FMUID_MAX_SPEC_KEYS)"
    )
    assert spec_error(json.dumps(SPEC), max_spec_bytes=10) == (
        "spec.json: more than the limit of 10 bytes (FMUID_MAX_SPEC_BYTES)"
    )


def test_many_problems_are_capped():
    spec = json.dumps({**SPEC, "fixed": {f"p{i}": [1] for i in range(100)}})
    lines = spec_error(spec).splitlines()
    assert len(lines) == 21
    assert lines[0].startswith("spec.json: fixed.p0.")
    assert lines[-1].startswith("... and ") and lines[-1].endswith(" more problems")
