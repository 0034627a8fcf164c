from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fmuid.data import Experiment, load_experiment
from fmuid.errors import DataError

from .helpers import write_csv

PROPERTY = settings(
    max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
finite = st.floats(allow_nan=False, allow_infinity=False)
names = st.from_regex(r"[A-Za-su-z_][A-Za-z0-9_]{0,8}", fullmatch=True)


@st.composite
def tables(draw) -> tuple[list[str], list[list[float | None]]]:
    """A valid table: 'time' strictly increasing, other columns with empty cells (None)."""
    columns = ["time", *draw(st.lists(names, max_size=4, unique=True))]
    times = sorted(draw(st.sets(finite, min_size=2, max_size=15)))
    rows = [[time, *(draw(st.none() | finite) for _ in columns[1:])] for time in times]
    return columns, rows


def render(columns: list[str], rows: list[list[float | None]], pad: str = "") -> str:
    def cell(value: float | None) -> str:
        return pad + ("" if value is None else repr(value)) + pad

    lines = [",".join(pad + name + pad for name in columns)]
    lines += [",".join(cell(value) for value in row) for row in rows]
    return "\n".join(lines) + "\n"


@PROPERTY
@given(table=tables(), pad=st.sampled_from(["", " ", "\t"]))
def test_valid_tables_round_trip_exactly(tmp_path, table, pad):
    columns, rows = table
    experiment = load_experiment(write_csv(tmp_path, render(columns, rows, pad)))
    assert list(experiment.columns) == columns[1:]
    assert experiment.time.tolist() == [row[0] for row in rows]
    for index, name in enumerate(columns[1:], start=1):
        expected = [math.nan if row[index] is None else row[index] for row in rows]
        np.testing.assert_array_equal(experiment.columns[name], expected)


BAD_TOKENS = ["abc", "nan", "-inf", "Infinity", "1.2.3", "--1", "0x10", "1_000", "\u0661", "1e"]


@st.composite
def corrupted(draw) -> str | bytes:
    """A valid table with one change that always makes it invalid."""
    columns, rows = draw(tables())
    text = render(columns, rows).splitlines()
    cells = [line.split(",") for line in text]
    row = draw(st.integers(1, len(rows)))
    col = draw(st.integers(0, len(columns) - 1))
    kind = draw(
        st.sampled_from(
            [
                "token",
                "empty_time",
                "drop_cell",
                "add_cell",
                "repeat_time",
                "bad_utf8",
                "duplicate_name",
                "no_time",
                "too_short",
            ]
        )
    )
    if kind == "token":
        cells[row][col] = draw(st.sampled_from(BAD_TOKENS))
    elif kind == "empty_time":
        # not the last row: a last row of empty cells is a trailing blank line, which is allowed
        cells[min(row, len(rows) - 1)][0] = " "
    elif kind == "drop_cell":
        cells[min(row, len(rows) - 1)].pop()
    elif kind == "add_cell":
        cells[row].append(draw(st.sampled_from(["", "1"])))
    elif kind == "repeat_time":
        later = max(row, 2)
        cells[later][0] = cells[later - 1][0]
    elif kind == "duplicate_name":
        cells[0].append(cells[0][col])
        for line in cells[1:]:
            line.append("")
    elif kind == "no_time":
        cells[0][0] = "t"
    elif kind == "too_short":
        cells = cells[: draw(st.integers(1, 2))]
    body = "\n".join(",".join(line) for line in cells) + "\n"
    if kind == "bad_utf8":
        at = draw(st.integers(0, len(body)))
        return (
            body[:at].encode()
            + draw(st.sampled_from([b"\xff", b"\xc3", b"\xed\xa0\x80"]))
            + body[at:].encode()
        )
    return body


@PROPERTY
@given(text=corrupted())
def test_corrupted_tables_always_give_data_error(tmp_path, text):
    try:
        load_experiment(write_csv(tmp_path, text))
    except DataError as error:
        assert str(error).startswith("step.csv: ")
    else:
        raise AssertionError(f"no DataError for {text!r}")


@PROPERTY
@given(
    table=tables(),
    edits=st.lists(
        st.tuples(st.integers(0, 10_000), st.binary(max_size=3)), min_size=1, max_size=4
    ),
)
def test_random_byte_edits_give_an_experiment_or_a_data_error(tmp_path, table, edits):
    data = bytearray(render(*table).encode())
    for position, replacement in edits:
        at = position % (len(data) + 1)
        data[at : at + 1] = replacement
    try:
        result = load_experiment(write_csv(tmp_path, bytes(data)))
    except DataError:
        return
    assert isinstance(result, Experiment)
    assert np.all(np.diff(result.time) > 0)
    assert all(not np.isinf(values).any() for values in result.columns.values())
