from __future__ import annotations

import numpy as np
import pytest

from fmuid.data import InputLimits, experiment_from_arrays, load_experiment
from fmuid.errors import DataError

from .helpers import write_csv


def load_error(tmp_path, text, **limits) -> str:
    with pytest.raises(DataError) as caught:
        load_experiment(write_csv(tmp_path, text), InputLimits(**limits))
    return str(caught.value)


def test_valid_file_with_bom_spaces_crlf_empty_cells_and_quotes(tmp_path):
    text = '\ufeff time , delta,"gam_t"\r\n0, 0.1 ,\r\n0.5,"0.2",1e-3\r\n1,,-2.5E+2\r\n\r\n'
    experiment = load_experiment(write_csv(tmp_path, text))
    assert experiment.name == "step.csv"
    assert experiment.n_rows == 3
    np.testing.assert_array_equal(experiment.time, [0.0, 0.5, 1.0])
    assert list(experiment.columns) == ["delta", "gam_t"]
    times, values = experiment.input_samples("delta")
    np.testing.assert_array_equal(times, [0.0, 0.5])
    np.testing.assert_array_equal(values, [0.1, 0.2])
    np.testing.assert_array_equal(experiment.output_mask("gam_t"), [False, True, True])
    np.testing.assert_array_equal(experiment.output_values("gam_t"), [1e-3, -250.0])
    assert experiment.sigma_column("gam_t") is None


def test_sigma_column_and_read_only_arrays(tmp_path):
    experiment = load_experiment(write_csv(tmp_path, "time,x,sigma_x\n0,1,0.1\n1,2,0.2\n"))
    np.testing.assert_array_equal(experiment.sigma_column("x"), [0.1, 0.2])
    with pytest.raises(ValueError):
        experiment.time[0] = 5.0


def test_methods_name_the_file_and_column(tmp_path):
    experiment = load_experiment(write_csv(tmp_path, "time,delta\n0,\n1,\n"))
    with pytest.raises(DataError, match=r"step\.csv: column 'delta' has no value"):
        experiment.input_samples("delta")
    with pytest.raises(DataError, match=r"step\.csv: no column 'gam_t'.*'delta'"):
        experiment.output_mask("gam_t")


def test_missing_file(tmp_path):
    with pytest.raises(DataError, match=r"nowhere\.csv: file not found"):
        load_experiment(tmp_path / "nowhere.csv")


@pytest.mark.parametrize("text", ["", "  \n\n", '""\n'])
def test_empty_file(tmp_path, text):
    assert load_error(tmp_path, text) == "step.csv: file is empty"


def test_no_header_blank_first_row(tmp_path):
    message = load_error(tmp_path, "\ntime,x\n0,1\n1,2\n")
    assert message.startswith("step.csv: row 1 is empty")


def test_no_header_numbers_in_first_row(tmp_path):
    message = load_error(tmp_path, "0,1\n1,2\n2,3\n")
    assert message.startswith("step.csv: row 1: no header row")


def test_duplicate_column_name(tmp_path):
    message = load_error(tmp_path, "time,x, x\n0,1,2\n1,2,3\n")
    assert message == "step.csv: row 1: column name 'x' appears twice (columns 2 and 3)"


def test_empty_column_name(tmp_path):
    message = load_error(tmp_path, "time,,x\n0,1,2\n1,2,3\n")
    assert message == "step.csv: row 1: column 2 has no name"


def test_no_time_column(tmp_path):
    message = load_error(tmp_path, "t,x\n0,1\n1,2\n")
    assert message == "step.csv: row 1: no 'time' column; columns: 't', 'x'"


def test_no_time_column_case_hint_and_delimiter_hint(tmp_path):
    assert "found 'Time'; names are case-sensitive" in load_error(tmp_path, "Time,x\n0,1\n1,2\n")
    assert "delimiter must be a comma" in load_error(tmp_path, "time;x\n0;1\n1;2\n")


@pytest.mark.parametrize(
    ("row", "what"), [("0,1,2", "has 3 cells"), ("0", "has 1 cells"), ("", "is empty")]
)
def test_wrong_number_of_cells(tmp_path, row, what):
    message = load_error(tmp_path, f"time,x\n0.5,1\n{row}\n1,2\n")
    assert message == f"step.csv: row 3 {what}, the header has 2 columns"


def test_text_in_numeric_cell_is_quoted(tmp_path):
    message = load_error(tmp_path, "time,x\n0,1\n1,abc\n2,1_000\n")
    assert message == "step.csv: row 3, column 'x': text 'abc' where a number is expected"


def test_first_bad_cell_in_row_order_is_reported(tmp_path):
    message = load_error(tmp_path, "time,x,y\n0,1,2\n1,2,oops\n2,bad,3\n")
    assert message.startswith("step.csv: row 3, column 'y': text 'oops'")


@pytest.mark.parametrize("word", ["nan", "NaN", "inf", "-inf", "+Infinity", "NA", "null"])
def test_non_finite_literals_are_errors(tmp_path, word):
    message = load_error(tmp_path, f"time,x\n0,1\n1,{word}\n")
    assert message.startswith(f"step.csv: row 3, column 'x': '{word}' is not allowed")
    assert "leave the cell empty" in message


def test_nan_in_time_is_an_error(tmp_path):
    assert "row 2, column 'time': 'nan'" in load_error(tmp_path, "time,x\nnan,1\n1,2\n")


def test_overflowing_number(tmp_path):
    message = load_error(tmp_path, "time,x\n0,1\n1,-1e999\n")
    assert message == "step.csv: row 3, column 'x': '-1e999' is too large for a 64-bit float"


def test_empty_time_cell(tmp_path):
    message = load_error(tmp_path, "time,x\n0,1\n ,2\n2,3\n")
    assert message == "step.csv: row 3, column 'time': empty time cell"


@pytest.mark.parametrize("second", ["0.5", "0.2"])
def test_time_not_increasing_names_both_rows(tmp_path, second):
    message = load_error(tmp_path, f"time,x\n0,1\n0.5,1\n{second},2\n")
    assert message == (
        "step.csv: rows 3 and 4, column 'time': time must strictly increase "
        f"(0.5 then {float(second)!r})"
    )


@pytest.mark.parametrize("rows", ["", "0,1\n"])
def test_fewer_than_two_rows(tmp_path, rows):
    message = load_error(tmp_path, "time,x\n" + rows)
    assert message == f"step.csv: {rows.count(chr(10))} data row(s); at least 2 are needed"


def test_too_many_rows(tmp_path):
    message = load_error(tmp_path, "time,x\n0,1\n1,2\n2,3\n", max_csv_rows=2)
    assert message == "step.csv: more than the limit of 2 data rows (FMUID_MAX_CSV_ROWS)"


def test_too_many_bytes(tmp_path):
    message = load_error(tmp_path, "time,x\n0,1\n1,2\n", max_csv_bytes=10)
    assert message == "step.csv: more than the limit of 10 bytes (FMUID_MAX_CSV_BYTES)"


def test_million_row_file_is_refused(tmp_path):
    text = "time,x\n" + "".join(f"{i},1\n" for i in range(1_000_000))
    expected = "step.csv: more than the limit of 200000 data rows (FMUID_MAX_CSV_ROWS)"
    assert load_error(tmp_path, text) == expected
    assert "limit of 5000000 bytes" in load_error(tmp_path, text, max_csv_bytes=5_000_000)


def test_non_utf8_bytes(tmp_path):
    message = load_error(tmp_path, b"time,x\n0,1\n1,\xe92\n")
    assert message.startswith("step.csv: row 3, column 'x': byte 0xe9 is not valid UTF-8")


def test_oversized_cell_is_a_data_error(tmp_path):
    message = load_error(tmp_path, "time,x\n0,1\n1," + "9" * 200_000 + "\n")
    assert message.startswith("step.csv: row 3: field larger than field limit")


def test_from_arrays_round_trip_and_copy():
    delta = np.array([0.1, np.nan, 0.3])
    experiment = experiment_from_arrays("sim.csv", [0.0, 1.0, 2.0], {"delta": delta})
    delta[0] = 9.0
    np.testing.assert_array_equal(experiment.columns["delta"], [0.1, np.nan, 0.3])
    assert experiment.columns["delta"].dtype == np.float64


@pytest.mark.parametrize(
    ("time", "columns", "expected"),
    [
        ([0.0, 1.0], {"x": [1.0]}, "sim.csv: column 'x' has 1 values, 'time' has 2"),
        ([[0.0, 1.0]], {}, "sim.csv: column 'time': expected a 1-D array, got 2-D"),
        ([0.0, np.nan], {}, "sim.csv: row 3, column 'time': empty time cell"),
        ([0.0, np.inf], {}, "sim.csv: row 3, column 'time': infinite value"),
        ([0.0, 1.0], {"x": [1.0, -np.inf]}, "sim.csv: row 3, column 'x': infinite value"),
        ([0.0], {}, "sim.csv: 1 data row(s); at least 2 are needed"),
        ([1.0, 0.0], {}, "sim.csv: rows 2 and 3, column 'time': time must strictly increase"),
        ([0.0, 1.0], {"time": [1.0, 2.0]}, "sim.csv: column 'time' is given twice"),
        ([0.0, 1.0], {" x": [1.0, 2.0]}, "sim.csv: column name ' x' is empty"),
        ([0.0, 1.0], {"x": ["a", "b"]}, "sim.csv: column 'x': not numbers"),
    ],
)
def test_from_arrays_errors(time, columns, expected):
    with pytest.raises(DataError) as caught:
        experiment_from_arrays("sim.csv", time, columns)
    assert str(caught.value).startswith(expected)
