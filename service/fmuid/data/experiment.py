"""One experiment: a CSV file of time-stamped input and output samples, validated on load.

A file has a header row, a ``time`` column [s] that strictly increases, and one column per FMU
input, FMU output or ``sigma_<output>`` (see ``check_against_model`` in :mod:`fmuid.data.spec`).
An empty cell in a non-time column means "no sample in this row"; ``nan``, ``inf`` and text are
errors. Every error is a :class:`~fmuid.errors.DataError` whose message names the file, the row
as a spreadsheet shows it (the header is row 1) and the column.
"""

from __future__ import annotations

import csv
import io
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from fmuid.data.limits import InputLimits, over_limit
from fmuid.data.messages import names, quote
from fmuid.errors import DataError

__all__ = ["Experiment", "experiment_from_arrays", "load_experiment"]

TIME = "time"
"""Name of the time column [s]."""

_CELL = re.compile(
    r"\s*+(?:[+-]?+(?:[0-9]++(?:\.[0-9]*+)?+|\.[0-9]++)(?:[eE][+-]?+[0-9]++)?+)?+\s*+"
)
"""A cell that is empty or holds a plain decimal number (what ``float`` reads, minus nan/inf).

Every quantifier is possessive and the alternatives start differently, so a match never
backtracks: its time is linear in the cell's length (the plain pattern was quadratic on a long
run of digits followed by a letter).
"""

_NOT_A_NUMBER = {
    word
    for base in ("nan", "inf", "infinity", "na", "n/a", "null", "none")
    for word in (base, "+" + base, "-" + base)
}
"""Spellings of "no value" that must be written as an empty cell instead (compared casefolded)."""


@dataclass(frozen=True, eq=False)
class Experiment:
    """The validated samples of one experiment.

    Build it with :func:`load_experiment` or :func:`experiment_from_arrays`, which check it; the
    arrays are read-only.

    Parameters
    ----------
    name
        Base name of the file (e.g. ``step.csv``); results and errors refer to it.
    time
        Sample times [s], strictly increasing, at least two.
    columns
        Every other column by name, as float arrays of the same length as ``time``; NaN marks
        an empty cell ("no sample in this row").

    """

    name: str
    time: np.ndarray
    columns: dict[str, np.ndarray]

    @property
    def n_rows(self) -> int:
        """Number of data rows (the header not counted)."""
        return len(self.time)

    def _column(self, name: str) -> np.ndarray:
        if name not in self.columns:
            raise DataError(f"{self.name}: no column '{name}' (columns: {names(self.columns)})")
        return self.columns[name]

    def input_samples(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Return the samples of an input column, skipping its empty cells.

        Parameters
        ----------
        name
            Column name (an FMU input).

        Returns
        -------
        tuple of numpy.ndarray
            Sample times [s] and values, of equal length.

        Raises
        ------
        DataError
            If the column is missing or has no value at all.

        """
        values = self._column(name)
        mask = ~np.isnan(values)
        if not mask.any():
            raise DataError(f"{self.name}: column '{name}' has no value in any row")
        return self.time[mask], values[mask]

    def output_mask(self, name: str) -> np.ndarray:
        """Return a boolean array, True for the rows where the output column has a value."""
        return ~np.isnan(self._column(name))

    def output_values(self, name: str) -> np.ndarray:
        """Return the values of an output column in the rows where it has one.

        They belong to the times ``time[output_mask(name)]``.
        """
        values = self._column(name)
        return values[~np.isnan(values)]

    def sigma_column(self, output: str) -> np.ndarray | None:
        """Return the column ``sigma_<output>`` (per-row standard deviations) or None if absent."""
        return self.columns.get(f"sigma_{output}")


def experiment_from_arrays(
    name: str, time: ArrayLike, columns: Mapping[str, ArrayLike]
) -> Experiment:
    """Build an :class:`Experiment` from arrays, with the checks :func:`load_experiment` makes.

    Parameters
    ----------
    name
        Name of the experiment (as a file base name, e.g. ``step.csv``).
    time
        Sample times [s]: finite, strictly increasing, at least two.
    columns
        Other columns by name; each as long as ``time``, NaN for "no sample", never infinite.

    Returns
    -------
    Experiment
        The experiment, holding read-only float64 copies of the arrays.

    Raises
    ------
    DataError
        Naming the experiment, row (the first data row is row 2, as in the CSV file) and column.

    """
    if not name:
        raise DataError("an experiment needs a name (the file name, e.g. 'step.csv')")
    time_array = _float_array(name, TIME, time)
    arrays: dict[str, np.ndarray] = {}
    for column, values in columns.items():
        if not column or column != column.strip():
            raise DataError(f"{name}: column name {column!r} is empty or has surrounding spaces")
        if column == TIME:
            raise DataError(f"{name}: column 'time' is given twice")
        arrays[column] = _float_array(name, column, values)
        if len(arrays[column]) != len(time_array):
            raise DataError(
                f"{name}: column '{column}' has {len(arrays[column])} values, "
                f"'time' has {len(time_array)}"
            )
    return _validated(name, time_array, arrays)


def load_experiment(path: str | os.PathLike[str], limits: InputLimits | None = None) -> Experiment:
    """Read and validate one experiment CSV file.

    Parameters
    ----------
    path
        The CSV file: UTF-8 (a byte-order mark is accepted), comma-separated, a header row with a
        ``time`` column [s]. Spaces around cells and names are ignored.
    limits
        Largest size, rows, columns and cell accepted (default :class:`InputLimits`); a file
        over one is refused before or while it is parsed.

    Returns
    -------
    Experiment
        Named after the file's base name.

    Raises
    ------
    DataError
        Naming the file, the row (the header is row 1) and the column at fault, or the limit.

    """
    limits = limits or InputLimits()
    max_bytes = limits.max_csv_bytes
    path = Path(path)
    name = path.name
    try:
        with path.open("rb") as stream:
            raw = stream.read(max_bytes + 1)
    except FileNotFoundError:
        raise DataError(f"{name}: file not found ({path})") from None
    except OSError as error:
        raise DataError(f"{name}: cannot read the file ({error.strerror})") from None
    if len(raw) > max_bytes:
        raise DataError(f"{name}: {over_limit('bytes', 'max_csv_bytes', limits)}")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise DataError(
            f"{name}: {_place(raw, error.start)}: byte 0x{raw[error.start]:02x} is not valid "
            "UTF-8 (save the file as UTF-8)"
        ) from None
    if not text.strip():
        raise DataError(f"{name}: file is empty")
    header, rows = _read_records(name, text, limits)
    return _validated(name, *_parse_table(name, header, rows))


def _place(raw: bytes, offset: int) -> str:
    """Row and column of a byte offset, for a message (columns counted by commas)."""
    row = raw.count(b"\n", 0, offset) + 1
    index = raw.count(b",", raw.rfind(b"\n", 0, offset) + 1, offset)
    header = raw.split(b"\n", 1)[0].decode("utf-8-sig", errors="replace").split(",")
    column = f"'{header[index].strip()}'" if row > 1 and index < len(header) else index + 1
    return f"row {row}, column {column}"


def _read_records(name: str, text: str, limits: InputLimits) -> tuple[list[str], list[list[str]]]:
    """Split the text into the header names and the data rows (trailing blank rows dropped)."""
    reader = csv.reader(io.StringIO(text, newline=""))
    records: list[list[str]] = []
    n_data = 0
    try:
        for record in reader:
            records.append(record)
            if len(record) > limits.max_csv_columns:
                what = over_limit("columns", "max_csv_columns", limits)
                raise DataError(f"{name}: row {len(records)}: {what}")
            if max(map(len, record), default=0) > limits.max_cell_chars:
                widest = max(range(len(record)), key=lambda i: len(record[i])) + 1
                what = over_limit("characters in a cell", "max_cell_chars", limits)
                raise DataError(f"{name}: row {len(records)}, column {widest}: {what}")
            if not _is_blank(record):
                n_data += 1
                if n_data > limits.max_csv_rows + 1:
                    raise DataError(f"{name}: {over_limit('data rows', 'max_csv_rows', limits)}")
    except csv.Error as error:
        raise DataError(f"{name}: row {len(records) + 1}: {error}") from None
    while records and _is_blank(records[-1]):
        records.pop()
    if not records:
        raise DataError(f"{name}: file is empty")
    if _is_blank(records[0]):
        raise DataError(f"{name}: row 1 is empty; the first row must be the header")
    header = [cell.strip() for cell in records[0]]
    first: dict[str, int] = {}
    for index, column in enumerate(header):
        if not column:
            raise DataError(f"{name}: row 1: column {index + 1} has no name")
        if column in first:
            raise DataError(
                f"{name}: row 1: column name '{column}' appears twice "
                f"(columns {first[column] + 1} and {index + 1})"
            )
        first[column] = index
    if TIME not in header:
        raise DataError(f"{name}: row 1: {_missing_time(header)}")
    rows = records[1:]
    if len(rows) < 2:
        raise DataError(f"{name}: {len(rows)} data row(s); at least 2 are needed")
    for index, record in enumerate(rows):
        if len(record) != len(header):
            what = "is empty" if _is_blank(record) else f"has {len(record)} cells"
            raise DataError(f"{name}: row {index + 2} {what}, the header has {len(header)} columns")
    return header, rows


def _missing_time(header: list[str]) -> str:
    """Explain why no ``time`` column was found."""
    if all(_CELL.fullmatch(column) for column in header):
        return "no header row (it holds numbers); the first row must name the columns"
    if len(header) == 1 and re.search("[;\t]", header[0]):
        return f"one column named '{header[0]}'; the delimiter must be a comma"
    close = [column for column in header if column.casefold() == TIME]
    hint = f" (found '{close[0]}'; names are case-sensitive)" if close else ""
    return f"no 'time' column{hint}; columns: {names(header)}"


def _parse_table(
    name: str, header: list[str], rows: list[list[str]]
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Convert the cells column by column, reporting the first bad cell in row order."""
    cells = list(zip(*rows, strict=True))
    bad = [j for j, column in enumerate(cells) if not all(map(_CELL.fullmatch, column))]
    if bad:
        row, j = min((_first_bad_row(cells[j]), j) for j in bad)
        text = quote(cells[j][row].strip())
        raise DataError(f"{name}: row {row + 2}, column '{header[j]}': {_bad_cell(text)}")
    arrays = {}
    for column, texts in zip(header, cells, strict=True):
        values = np.array([float(text) if text.strip() else np.nan for text in texts])
        overflow = np.flatnonzero(np.isinf(values))
        if overflow.size:
            row = int(overflow[0])
            raise DataError(
                f"{name}: row {row + 2}, column '{column}': '{quote(texts[row].strip())}' "
                "is too large for a 64-bit float"
            )
        arrays[column] = values
    time = arrays.pop(TIME)
    return time, arrays


def _first_bad_row(texts: tuple[str, ...]) -> int:
    """Index of the first cell that is neither empty nor a plain number."""
    return next(i for i, text in enumerate(texts) if not _CELL.fullmatch(text))


def _bad_cell(text: str) -> str:
    """Describe a cell that is not a number."""
    if text.casefold() in _NOT_A_NUMBER:
        return f"'{text}' is not allowed; leave the cell empty when there is no sample"
    return f"text '{text}' where a number is expected"


def _validated(name: str, time: np.ndarray, columns: dict[str, np.ndarray]) -> Experiment:
    """Check the arrays (time present, finite, increasing; no infinity) and freeze them."""
    empty = np.flatnonzero(np.isnan(time))
    if empty.size:
        raise DataError(f"{name}: row {empty[0] + 2}, column 'time': empty time cell")
    if len(time) < 2:
        raise DataError(f"{name}: {len(time)} data row(s); at least 2 are needed")
    for column, values in {TIME: time, **columns}.items():
        infinite = np.flatnonzero(np.isinf(values))
        if infinite.size:
            raise DataError(
                f"{name}: row {infinite[0] + 2}, column '{column}': infinite value; "
                "leave the cell empty when there is no sample"
            )
    steps = np.flatnonzero(np.diff(time) <= 0)
    if steps.size:
        row = int(steps[0]) + 2
        raise DataError(
            f"{name}: rows {row} and {row + 1}, column 'time': time must strictly increase "
            f"({float(time[row - 2])!r} then {float(time[row - 1])!r})"
        )
    for values in (time, *columns.values()):
        values.setflags(write=False)
    return Experiment(name=name, time=time, columns=columns)


def _float_array(name: str, column: str, values: ArrayLike) -> np.ndarray:
    """Return a 1-D float64 copy, or raise naming the column."""
    try:
        array = np.array(values, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise DataError(f"{name}: column '{column}': not numbers ({error})") from None
    if array.ndim != 1:
        raise DataError(f"{name}: column '{column}': expected a 1-D array, got {array.ndim}-D")
    return array


def _is_blank(record: list[str]) -> bool:
    """Tell whether a row has no non-space character."""
    return all(not cell.strip() for cell in record)
