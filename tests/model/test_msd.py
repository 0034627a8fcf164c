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


def test_linear_models_step_exactly_on_an_uneven_grid(msd_fmu) -> None:
    """The msd is stepped by its matrix exponential: a ramping, reversing force read at uneven
    times agrees with a tight scipy solution to 1e-10, and the step response to rounding."""
    from scipy.integrate import solve_ivp

    t_in = np.array([0.0, 0.7, 1.3, 2.9, 4.0])
    f_in = np.array([0.0, 30.0, -12.0, 5.0, 5.0])
    t_out = np.unique(np.r_[np.linspace(0.0, 4.0, 37), 0.013, 1.0001, 3.333])
    m, k, b = 1.1, 4.4, 1.6

    def rhs(t: float, s: np.ndarray) -> list[float]:
        return [s[1], (np.interp(t, t_in, f_in) - b * s[1] - k * s[0]) / m]

    ref = solve_ivp(
        rhs,
        (0.0, 4.0),
        [0.0, 0.0],
        t_eval=t_out,
        rtol=1e-13,
        atol=1e-14,
        method="DOP853",
        first_step=1e-4,
        max_step=0.01,
    )
    sim = Simulator(msd_fmu)
    try:
        y = sim.simulate({}, t_in, {"f": f_in}, t_out, ["x", "v"])
        step = sim.simulate({}, np.array([0.0, 10.0]), {"f": np.array([40.0, 40.0])}, T_OUT, ["x"])
    finally:
        sim.close()
    np.testing.assert_allclose(y.T, ref.y, rtol=0, atol=1e-10)
    np.testing.assert_allclose(step[:, 0], step_response(m, k, b, 40.0, T_OUT)[0], atol=1e-12)
