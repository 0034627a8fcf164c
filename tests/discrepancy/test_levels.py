"""Where in an output's range a misfit sits: known patterns planted in noise are found."""

from __future__ import annotations

import numpy as np
import pytest

from fmuid.discrepancy.levels import level_location
from fmuid.estimation.series import ResidualSeries
from fmuid.plots.levels import level_figure

TIME = np.linspace(0.0, 20.0, 2001)
Y = np.sin(1.3 * TIME) + 0.4 * np.sin(3.7 * TIME)


def _series(extra: np.ndarray, seed: int) -> list[ResidualSeries]:
    noise = np.random.default_rng(seed).normal(0.0, 1.0, TIME.size)
    r = noise + extra
    return [ResidualSeries("e.csv", "x", TIME, Y + r, Y, r, "m")]


@pytest.mark.parametrize(
    ("extra", "pattern"),
    [
        (0.3 * Y**3 - 0.2 * Y, "odd"),
        (0.5 * np.sign(np.gradient(Y, TIME)), "rate_sign"),
        (1.5 * (Y > np.quantile(Y, 0.9)), "top"),
    ],
)
def test_a_planted_pattern_is_named(extra: np.ndarray, pattern: str) -> None:
    found = level_location(_series(extra, 1), 0.01)["x"]
    assert found["pattern"] == pattern
    assert found["p_value"] < 1e-6 and "the misfit of x" in found["words"]


def test_a_misfit_that_grows_with_the_amplitude_is_named() -> None:
    swing = 0.2 + 0.8 * np.abs(np.sin(0.15 * TIME))  # a slowly varying amplitude
    y = swing * np.sin(9.0 * TIME)
    r = np.random.default_rng(3).normal(0.0, 1.0, TIME.size) * (0.3 + 2.0 * swing)
    found = level_location([ResidualSeries("e.csv", "x", TIME, y + r, y, r, "m")], 0.01)["x"]
    assert found["pattern"] == "amplitude" and "amplitude of x" in found["words"]


def test_noise_alone_names_no_pattern_and_the_figure_draws() -> None:
    found = level_location(_series(np.zeros(TIME.size), 2), 0.01)
    assert found["x"]["pattern"] is None and found["x"]["words"] == ""
    fig = level_figure(found)
    assert len(fig.axes) == 2 and fig.axes[0].get_xlabel().startswith("x")
