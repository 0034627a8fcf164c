"""The screen of a declared level tries the levels near its onset, not only its grid."""

from __future__ import annotations

import numpy as np

from fmuid.data import ParameterSpec
from fmuid.discrepancy.knowledge import AddedParameter
from fmuid.discrepancy.onset import BISECTIONS, onset_levels

REACHED = 10.3
"""The highest level the signals reach: a level above it clips nothing."""


def _level(scale: str) -> AddedParameter:
    spec = ParameterSpec(start=9.0, lower=2.0, upper=100.0, scale=scale)
    return AddedParameter("h_max", "m", "overflow level", spec, 100.0, "high")


def _change(level: float) -> np.ndarray:
    """Residual changes of a clip at ``level`` on a ramp of samples up to REACHED."""
    y = np.linspace(0.0, REACHED, 50)
    return y - np.minimum(y, level)


def test_the_gap_between_no_effect_and_effect_is_bisected_towards_the_onset() -> None:
    p = _level("log")
    grid = np.logspace(np.log10(2.0), np.log10(100.0), 7)
    calls: list[float] = []

    def change(v: float) -> np.ndarray:
        calls.append(v)
        return _change(v)

    found = onset_levels(p, [(float(g), _change(g)) for g in grid], change)
    assert len(calls) == BISECTIONS
    below, above = grid[grid < REACHED].max(), grid[grid > REACHED].min()
    assert all(below < v < REACHED for v, _ in found)
    assert found and all(np.sum(d * d) > 0 for _, d in found)
    # the last level tried is within a 32nd of the grid's log step from the onset
    assert abs(np.log(calls[-1] / REACHED)) <= np.log(above / below) / 2**BISECTIONS
    # log scale: the first try is the geometric middle of the gap
    assert calls[0] == np.sqrt(below * above)


def test_a_grid_felt_everywhere_adds_nothing() -> None:
    p = _level("lin")
    grid = np.linspace(2.0, 9.0, 7)
    assert onset_levels(p, [(float(g), _change(g)) for g in grid], _change) == []
