"""The time grid of one run: where the master stops, what the inputs are there, what is read."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np

from fmuid.errors import FmuError
from fmuid.model.fmu import Variable
from fmuid.model.kept import Kept, content_key, read_only


class GridArrays(NamedTuple):
    """A plan as contiguous arrays, for the native master loop.

    ``rows[row_start[k]:row_start[k + 1]]`` are the rows read at grid point ``k``; ``moving``
    says whether some input changes over each interval, ``segment`` the length of the input
    sample interval each grid interval lies in.
    """

    times: np.ndarray
    value: np.ndarray
    slope: np.ndarray
    moving: np.ndarray
    segment: np.ndarray
    row_start: np.ndarray
    rows: np.ndarray


@dataclass(frozen=True)
class RunPlan:
    """Communication points of one run and the inputs at each of them.

    Attributes
    ----------
    grid
        Sorted grid [s]: the start time, every input breakpoint inside the run, every output time
        (:attr:`times` as a list, for the Python loops).
    value
        Input values at each grid point (right limits), shape ``(len(times), n_inputs)``.
    slope
        Input slopes over each grid interval [unit/s]; zero for held (non-float) inputs.
    input_time
        The input sample times [s].
    sample_time
        The times whose intervals bound the input sub-steps (:attr:`segment`): the input sample
        times, or the coarser times the inputs were sampled at before a caller resampled them.
    row_start, rows
        ``rows[row_start[k]:row_start[k + 1]]`` are the rows of the result read at grid point
        ``k`` (:attr:`rows_at` as lists).
    n_rows
        Number of output rows.

    """

    grid: np.ndarray
    value: np.ndarray
    slope: np.ndarray
    input_time: np.ndarray
    sample_time: np.ndarray
    row_start: np.ndarray
    rows: np.ndarray
    n_rows: int

    @cached_property
    def times(self) -> list[float]:
        """The grid as floats (for the Python loops)."""
        return self.grid.tolist()

    @cached_property
    def rows_at(self) -> list[list[int]]:
        """For each grid point, the rows of the result read there (for the Python loops)."""
        rows = self.rows.tolist()
        bounds = self.row_start.tolist()
        return [rows[a:b] for a, b in zip(bounds[:-1], bounds[1:], strict=True)]

    @cached_property
    def jump(self) -> np.ndarray:
        """Whether some input is discontinuous at each grid point (its left limit differs)."""
        steps = self.value[:-1] + self.slope[:-1] * np.diff(self.grid)[:, None]
        return np.any(np.vstack([self.value[:1], steps]) != self.value, axis=1)

    @cached_property
    def breakpoint(self) -> np.ndarray:
        """Whether each grid point is an input sample time (the slopes may change there)."""
        return np.isin(self.grid, self.input_time)

    @cached_property
    def segment(self) -> np.ndarray:
        """Length [s] of the sample interval (:attr:`sample_time`) each grid interval lies in.

        Infinite outside the samples.
        """
        t = self.sample_time
        mid = 0.5 * (self.grid[:-1] + self.grid[1:])
        j = np.searchsorted(t, mid, side="right") - 1
        inside = (j >= 0) & (j < t.size - 1)
        jc = np.clip(j, 0, max(t.size - 2, 0))
        length = t[np.minimum(jc + 1, t.size - 1)] - t[jc]
        return np.append(np.where(inside, length, np.inf), np.inf)

    @cached_property
    def arrays(self) -> GridArrays:
        """The plan as contiguous float64, uint8 and int64 arrays (made once per plan)."""
        return GridArrays(
            np.ascontiguousarray(self.grid, dtype=np.float64),
            np.ascontiguousarray(self.value, dtype=np.float64),
            np.ascontiguousarray(self.slope, dtype=np.float64),
            np.ascontiguousarray(np.any(self.slope, axis=1), dtype=np.uint8),
            np.ascontiguousarray(self.segment, dtype=np.float64),
            np.ascontiguousarray(self.row_start, dtype=np.int64),
            np.ascontiguousarray(self.rows, dtype=np.int64),
        )

    @property
    def stop(self) -> float:
        """Last grid time [s]."""
        return float(self.grid[-1])


def make_plan(
    input_time: np.ndarray,
    input_values: Mapping[str, np.ndarray],
    inputs: Sequence[Variable],
    output_time: np.ndarray,
    sample_time: np.ndarray | None = None,
) -> RunPlan:
    """Build the grid of a run from input samples and output times.

    Continuous float inputs are linear between their samples; discrete ones and integer,
    Boolean and enumeration inputs hold each sample's value until the next sample. All inputs
    are constant before the first and after the last sample. ``sample_time`` (default: the
    input times) gives the sample intervals that bound the input sub-steps.

    Raises
    ------
    ValueError
        If the times or input arrays are malformed.
    FmuError
        If a non-float input gets a value its type cannot hold (naming input, type and time).

    """
    t_in = np.asarray(input_time, dtype=float)
    t_out = np.asarray(output_time, dtype=float)
    if t_in.ndim != 1 or t_in.size == 0 or t_out.ndim != 1 or t_out.size == 0:
        raise ValueError("input_time and output_time must be non-empty 1-d arrays")
    if not (np.all(np.isfinite(t_in)) and np.all(np.isfinite(t_out))):
        raise ValueError("input_time and output_time must be finite")
    if np.any(np.diff(t_in) < 0):
        raise ValueError("input_time must be non-decreasing")
    samples = np.empty((len(inputs), t_in.size))
    for i, variable in enumerate(inputs):
        values = np.asarray(input_values[variable.name], dtype=float)
        if values.shape != t_in.shape:
            raise ValueError(
                f"input {variable.name!r} has shape {values.shape}, input_time has {t_in.shape}"
            )
        if not variable.is_continuous:
            _check_kind(variable, values, t_in)
        samples[i] = values
    grid = _grid(t_in, t_out)
    held = [i for i, v in enumerate(inputs) if not v.is_continuous]
    value, slope = _segments(t_in, samples, grid)
    if held:
        value[:, held] = samples[held][:, np.maximum(grid.hold, 0)].T
        slope[:, held] = 0.0
    sampled = t_in if sample_time is None else np.asarray(sample_time, dtype=float)
    return RunPlan(grid.times, value, slope, t_in, sampled, grid.row_start, grid.rows, t_out.size)


@dataclass(frozen=True)
class _Grid:
    """What a plan's grid takes from the input and output times alone (kept by content)."""

    times: np.ndarray
    row_start: np.ndarray
    rows: np.ndarray
    segment: np.ndarray
    hold: np.ndarray


_GRIDS: Kept[_Grid] = Kept(16)
"""Grids kept per process: a fit simulates the same times with new input values each time."""


def _grid(t_in: np.ndarray, t_out: np.ndarray) -> _Grid:
    return _GRIDS.get(content_key(t_in, t_out), lambda: _make_grid(t_in, t_out))


def _make_grid(t_in: np.ndarray, t_out: np.ndarray) -> _Grid:
    t0 = min(t_in[0], float(np.min(t_out)))
    times = np.unique(np.concatenate(([t0], t_in[t_in < t_out.max()], t_out)))
    point = np.searchsorted(times, t_out)
    mid = np.append(0.5 * (times[:-1] + times[1:]), times[-1])
    return _Grid(
        read_only(times),
        read_only(np.concatenate(([0], np.cumsum(np.bincount(point, minlength=times.size))))),
        read_only(np.argsort(point, kind="stable")),
        read_only(np.searchsorted(t_in, mid, side="right") - 1),
        read_only(np.searchsorted(t_in, times, side="right") - 1),
    )


def _check_kind(variable: Variable, values: np.ndarray, t_in: np.ndarray) -> None:
    kind = variable.kind
    if kind == "float":
        return
    if kind == "integer":
        bad = np.flatnonzero(values != np.round(values))
        need = "whole numbers"
    elif kind == "boolean":
        bad = np.flatnonzero((values != 0) & (values != 1))
        need = "0 or 1 (false or true)"
    else:
        raise FmuError(
            f"input {variable.name!r} is of type {variable.type_label}, which fmuid cannot "
            "drive from a data column (inputs must be Real/Float, Integer, Boolean or "
            "Enumeration scalars)"
        )
    if bad.size:
        raise FmuError(
            f"input {variable.name!r} ({variable.type_label}) takes {need}; got "
            f"{float(values[bad[0]])!r} at t = {float(t_in[bad[0]])} s"
        )


def _segments(t_in: np.ndarray, samples: np.ndarray, grid: _Grid) -> tuple[np.ndarray, np.ndarray]:
    """Input values at each grid point and slopes over each grid interval.

    Every input breakpoint inside the run is a grid point, so each interval lies in one segment
    of the piecewise-linear input; the value at a grid point is the right limit.

    Returns
    -------
    value, slope
        Arrays of shape ``(len(grid), n_inputs)``; the slope is 0 outside the samples.

    """
    n = t_in.size
    j, times = grid.segment, grid.times
    inside = (j >= 0) & (j < n - 1)
    jc = np.clip(j, 0, max(n - 2, 0))
    if n > 1:
        dt = t_in[jc + 1] - t_in[jc]
        rate = (samples[:, jc + 1] - samples[:, jc]) / np.where(dt > 0, dt, 1.0)
        slope = np.where(inside, rate, 0.0)
        base = samples[:, jc] + slope * (times - t_in[jc])
    else:
        slope = np.zeros((samples.shape[0], times.size))
        base = samples[:, jc]
    value = np.where(j < 0, samples[:, :1], np.where(j >= n - 1, samples[:, -1:], base))
    return value.T.copy(), slope.T.copy()
