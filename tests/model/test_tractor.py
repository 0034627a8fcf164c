"""Tractor-implement FMU against solve_ivp of the printed thesis equations."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from fmuid.model.simulator import Simulator

from .reference import (
    BOUNDS,
    CHIRP_DELTA,
    CHIRP_TIME,
    OUTPUT_TIME,
    OUTPUTS,
    RAMP_DELTA,
    RAMP_TIME,
    tractor_reference,
    tractor_yaw_rates_exact,
)

INPUTS = {"ramp": (RAMP_TIME, RAMP_DELTA), "chirp": (CHIRP_TIME, CHIRP_DELTA)}
CORNERS = [dict(zip(BOUNDS, values, strict=True)) for values in itertools.product(*BOUNDS.values())]


@pytest.fixture(scope="module")
def simulator(tractor_fmu: Path):
    sim = Simulator(tractor_fmu)
    yield sim
    sim.close()


def _simulate(sim: Simulator, params: dict[str, float], case: str) -> dict[str, np.ndarray]:
    t_in, delta = INPUTS[case]
    y = sim.simulate(params, t_in, {"delta": delta}, OUTPUT_TIME, OUTPUTS)
    return {name: y[:, k] for k, name in enumerate(OUTPUTS)}


@pytest.mark.parametrize("case", ["ramp", "chirp"])
def test_nominal_all_outputs_match_solve_ivp(simulator: Simulator, case: str) -> None:
    t_in, delta = INPUTS[case]
    ref = tractor_reference({}, t_in, delta, OUTPUT_TIME)
    got = _simulate(simulator, {}, case)
    for name in ("gam_t", "gam_i", "psi_t", "psi_i", "v_tc"):
        np.testing.assert_allclose(got[name], ref[name], rtol=0, atol=1e-6, err_msg=name)
    for name in ("x_tc", "y_tc", "x_ic", "y_ic"):
        np.testing.assert_allclose(got[name], ref[name], rtol=0, atol=1e-6, err_msg=name)
    assert np.max(np.abs(ref["gam_t"])) > 0.1


@pytest.mark.slow
@pytest.mark.parametrize("case", ["ramp", "chirp"])
def test_yaw_rates_match_solve_ivp_at_all_64_corners(simulator: Simulator, case: str) -> None:
    t_in, delta = INPUTS[case]
    # the matrix-exponential reference is exact for the linear model: solve_ivp confirms it at
    # the first and last corner, then it stands in at all 64 (30 times faster)
    for corner in (CORNERS[0], CORNERS[-1]):
        exact = tractor_yaw_rates_exact(corner, t_in, delta, OUTPUT_TIME)
        ivp = tractor_reference(corner, t_in, delta, OUTPUT_TIME)
        for name in ("gam_t", "gam_i"):
            np.testing.assert_allclose(exact[name], ivp[name], rtol=1e-8, atol=1e-8, err_msg=name)
    worst = 0.0
    for corner in CORNERS:
        ref = tractor_yaw_rates_exact(corner, t_in, delta, OUTPUT_TIME)
        got = _simulate(simulator, corner, case)
        for name in ("gam_t", "gam_i"):
            error = float(np.max(np.abs(got[name] - ref[name])))
            assert error < 1e-6, f"{name} at {corner}: error {error:.3g} rad/s"
            worst = max(worst, error)
    assert worst < 1e-6


def test_extra_physics_off_by_default_is_the_thesis_model(simulator: Simulator) -> None:
    default = _simulate(simulator, {}, "chirp")
    explicit_off = _simulate(simulator, {"alpha_sat": 0.0, "slope": 0.0}, "chirp")
    for name in OUTPUTS:
        np.testing.assert_array_equal(default[name], explicit_off[name])


@pytest.mark.parametrize(
    ("alpha_sat", "slope"), [(0.02, 0.0), (0.0, 0.1), (0.05, -0.08)], ids=["sat", "slope", "both"]
)
def test_extra_physics_on_matches_solve_ivp(
    simulator: Simulator, alpha_sat: float, slope: float
) -> None:
    params = {"alpha_sat": alpha_sat, "slope": slope}
    got = _simulate(simulator, params, "chirp")
    ref = tractor_reference({}, CHIRP_TIME, CHIRP_DELTA, OUTPUT_TIME, alpha_sat, slope)
    linear = tractor_reference({}, CHIRP_TIME, CHIRP_DELTA, OUTPUT_TIME)
    for name in OUTPUTS:
        np.testing.assert_allclose(got[name], ref[name], rtol=0, atol=1e-6, err_msg=name)
    assert np.max(np.abs(ref["gam_t"] - linear["gam_t"])) > 1e-3
