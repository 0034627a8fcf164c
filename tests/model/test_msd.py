"""Mass-spring-damper FMUs against the closed-form step response."""

from __future__ import annotations

import numpy as np
import pytest

from fmuid.model.simulator import Simulator

T_OUT = np.round(np.arange(51) * 0.2, 10)


def step_response(m: float, k: float, b: float, force: float, t: np.ndarray):
    """Underdamped m x'' + b x' + k x = F (F applied at t = 0, at rest): x(t), v(t)."""
    wn = np.sqrt(k / m)
    zeta = b / (2 * np.sqrt(k * m))
    wd = wn * np.sqrt(1 - zeta**2)
    decay = np.exp(-zeta * wn * t)
    x = force / k * (1 - decay * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t)))
    v = force / k * decay * (wn**2 / wd) * np.sin(wd * t)
    return x, v


@pytest.mark.parametrize(
    ("fixture", "params", "k_total"),
    [
        ("msd_fmu", {}, 4.4),
        ("msd_fmu", {"m": 2.0, "k": 3.0, "b": 0.5}, 3.0),
        ("msd_parallel_fmu", {}, 4.4),
        ("msd_parallel_fmu", {"k1": 0.4, "k2": 4.0}, 4.4),
    ],
)
def test_step_response_matches_closed_form(
    request: pytest.FixtureRequest, fixture: str, params: dict[str, float], k_total: float
) -> None:
    sim = Simulator(request.getfixturevalue(fixture))
    try:
        y = sim.simulate(
            params, np.array([0.0, 10.0]), {"f": np.array([40.0, 40.0])}, T_OUT, ["x", "v"]
        )
    finally:
        sim.close()
    m = params.get("m", 1.1)
    b = params.get("b", 1.6)
    x, v = step_response(m, k_total, b, 40.0, T_OUT)
    np.testing.assert_allclose(y[:, 0], x, rtol=0, atol=1e-8)
    np.testing.assert_allclose(y[:, 1], v, rtol=0, atol=1e-8)
