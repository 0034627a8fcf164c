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


RAMP = np.linspace(0.0, REACHED, 50)
"""The weighted residuals without the clip: samples up to REACHED."""


def _change(level: float) -> np.ndarray:
    """Weighted residuals with a clip at ``level``."""
    return np.minimum(RAMP, level)


def test_the_gap_between_no_effect_and_effect_is_bisected_towards_the_onset() -> None:
    p = _level("log")
    grid = np.logspace(np.log10(2.0), np.log10(100.0), 7)
    calls: list[float] = []

    def change(value: dict[str, float]) -> np.ndarray:
        calls.append(value["h_max"])
        return _change(value["h_max"])

    found = onset_levels(p, [(float(g), _change(g)) for g in grid], change, RAMP)
    assert len(calls) == BISECTIONS
    below, above = grid[grid < REACHED].max(), grid[grid > REACHED].min()
    assert all(below < v < REACHED for v, _ in found)
    assert found and all(np.sum((RAMP - r) ** 2) > 0 for _, r in found)
    # the last level tried is within a 32nd of the grid's log step from the onset
    assert abs(np.log(calls[-1] / REACHED)) <= np.log(above / below) / 2**BISECTIONS
    # log scale: the first try is the geometric middle of the gap
    assert calls[0] == np.sqrt(below * above)


def test_a_grid_felt_everywhere_adds_nothing() -> None:
    def change(value: dict[str, float]) -> np.ndarray:
        return _change(value["h_max"])

    p = _level("lin")
    grid = np.linspace(2.0, 9.0, 7)
    assert onset_levels(p, [(float(g), _change(g)) for g in grid], change, RAMP) == []
