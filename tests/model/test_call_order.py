"""The FMI call order: parameters are set after ``fmi2SetupExperiment`` (20-sim re-applies its
start values there), checked on a test FMU with that quirk against scipy; ``fmuid info`` names
the parameters of an FMU that ignores them whatever the order."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from tests.model.quirks import build_quirk_fmu

from fmuid.model.info import info
from fmuid.model.simulator import Simulator

PARAMS = {"R1": 2.0, "R2": 0.5, "C1": 0.7, "C2": 1.5}
TIMES = np.linspace(0.0, 4.0, 21)


@pytest.fixture(scope="module")
def setup_resets_fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build_quirk_fmu("setup_resets", tmp_path_factory.mktemp("setup_resets"))


def tanks(params: dict[str, float], inflow: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """Levels of the two tanks by solve_ivp, the inflow linear between its samples."""
    r1, r2, c1, c2 = (params[n] for n in ("R1", "R2", "C1", "C2"))

    def rhs(t: float, h: np.ndarray) -> list[float]:
        flow = h[0] / r1
        return [(np.interp(t, *inflow) - flow) / c1, (flow - h[1] / r2) / c2]

    sol = solve_ivp(
        rhs, (0.0, 4.0), [0.0, 0.0], t_eval=TIMES, rtol=1e-10, atol=1e-12, max_step=0.01
    )
    return sol.y.T


def test_parameters_survive_setup_experiment(setup_resets_fmu: Path) -> None:
    inflow = (np.array([0.0, 1.0, 4.0]), np.array([0.0, 1.0, 0.5]))
    sim = Simulator(setup_resets_fmu)
    try:
        runs = [
            sim.simulate(PARAMS, inflow[0], {"q": inflow[1]}, TIMES, ["h1", "h2"]) for _ in range(2)
        ]
    finally:
        sim.close()
    expected = tanks(PARAMS, inflow)
    at_start = tanks(dict.fromkeys(PARAMS, 1.0), inflow)
    assert np.max(np.abs(expected - at_start)) > 0.1  # the quirk would be seen
    for run in runs:  # a fresh instance and one after fmi2Reset
        np.testing.assert_allclose(run, expected, atol=1e-7)


def test_info_names_parameters_the_fmu_ignores(setup_resets_fmu: Path, tmp_path: Path) -> None:
    assert info(setup_resets_fmu).health.ignored == ()  # held: set after fmi2SetupExperiment
    deaf = build_quirk_fmu("setup_resets", tmp_path, layer="initialization_resets.c")
    health = info(deaf).health
    assert health.simulates and health.ignored == ("R1", "R2", "C1", "C2")
    assert health.message.startswith("the FMU ignores the parameter(s) R1, R2, C1, C2")
