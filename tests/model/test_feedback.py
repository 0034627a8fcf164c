"""Closed-loop co-simulation: outputs fed back into inputs, against scipy's solution."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fmuid.model.feedback import Feedback, FeedbackTerm, fine_times
from fmuid.model.simulator import Simulator

M, K, B = 1.1, 4.4, 1.6
C3, FC, WIDTH, BAND, CD = -3.0, -0.3, 0.05, 0.1, -2.0


def _reference(t: np.ndarray, u: np.ndarray) -> np.ndarray:
    """m x'' + b x' + k x = f + c3 x^3 + Fc tanh(v / w) + cd (x - clip(x)), solved by scipy."""

    def rhs(tt: float, s: np.ndarray) -> list[float]:
        x, v = s
        f = np.interp(tt, t, u) + C3 * x**3 + FC * np.tanh(v / WIDTH)
        f += CD * (x - np.clip(x, -BAND, BAND))
        return [v, (f - B * v - K * x) / M]

    sol = solve_ivp(
        rhs, (t[0], t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-10, atol=1e-12, max_step=0.005
    )
    return sol.y[0]


def _terms() -> tuple[FeedbackTerm, ...]:
    return (
        FeedbackTerm("f", "x", False, "power", C3, 3),
        FeedbackTerm("f", "v", False, "tanh", FC, WIDTH),
        FeedbackTerm("f", "x", False, "dead", CD, BAND),
    )


def test_feedback_converges_to_the_closed_loop_ode_at_second_order(msd_fmu: Path) -> None:
    t = np.linspace(0.0, 10.0, 501)
    u = np.sin(1.3 * t) + 0.5 * np.sin(3.1 * t)
    reference = _reference(t, u)
    sim = Simulator(msd_fmu)
    errors = []
    for step in (0.005, 0.00125):
        y = sim.simulate({"m": M, "k": K, "b": B}, t, {"f": u}, t, ["x"], Feedback(_terms(), step))
        errors.append(float(np.max(np.abs(y[:, 0] - reference))))
    sim.close()
    assert errors[1] < 1e-6 * np.max(np.abs(reference)) * 10
    assert errors[0] / errors[1] > 8  # 4x smaller step: second order gives 16x


def test_rate_by_finite_difference_matches_the_rate_output(msd_fmu: Path) -> None:
    t = np.linspace(0.0, 5.0, 251)
    u = np.sin(2.0 * t)
    sim = Simulator(msd_fmu)
    by_output = Feedback((FeedbackTerm("f", "v", False, "tanh", FC, WIDTH),), 0.001)
    by_difference = Feedback((FeedbackTerm("f", "x", True, "tanh", FC, WIDTH),), 0.001)
    a = sim.simulate({}, t, {"f": u}, t, ["x"], by_output)
    b = sim.simulate({}, t, {"f": u}, t, ["x"], by_difference)
    sim.close()
    assert np.max(np.abs(a - b)) < 1e-3 * np.max(np.abs(a))


def test_an_undriven_input_is_driven_by_the_terms_alone(msd_fmu: Path) -> None:
    t = np.linspace(0.0, 2.0, 21)
    sim = Simulator(msd_fmu)
    spring = Feedback((FeedbackTerm("f", "x", False, "power", 1.0, 1),), 0.01)
    y = sim.simulate({}, t, {}, t, ["x"], spring)
    sim.close()
    assert np.all(y == 0.0)  # at rest, a force proportional to x keeps it at rest


def test_bad_terms_and_grids() -> None:
    with pytest.raises(ValueError, match="width"):
        FeedbackTerm("f", "v", False, "tanh", 1.0, 0.0)
    with pytest.raises(ValueError, match="kind"):
        FeedbackTerm("f", "v", False, "cube", 1.0, 3)
    fine = fine_times(np.array([0.0, 1.0, 1.05]), 0.3)
    assert np.max(np.diff(fine)) <= 0.3 + 1e-12 and {0.0, 1.0, 1.05} <= set(fine.tolist())


def test_inputs_between_the_fine_points_keep_a_finite_difference_rate_stable(
    msd_fmu: Path,
) -> None:
    # inputs every 2.5 ms, outputs every 10 ms, steps of at most 2 ms: the grid has intervals of
    # 0.5 ms, which must not become the baseline of the rate (it blew up before)
    t_in = np.arange(0.0, 2.0, 0.0025)
    u = np.sin(3.0 * t_in)
    t_out = np.arange(0.0, 2.0, 0.01)
    terms = (FeedbackTerm("f", "x", True, "tanh", FC, WIDTH),)
    sim = Simulator(msd_fmu)
    y = sim.simulate({"m": M, "k": K, "b": B}, t_in, {"f": u}, t_out, ["x"], Feedback(terms, 0.002))
    sim.close()

    def rhs(tt: float, s: np.ndarray) -> list[float]:
        x, v = s
        return [v, (np.interp(tt, t_in, u) + FC * np.tanh(v / WIDTH) - B * v - K * x) / M]

    sol = solve_ivp(
        rhs, (0.0, t_out[-1]), [0.0, 0.0], t_eval=t_out, rtol=1e-10, atol=1e-12, max_step=0.001
    )
    assert np.max(np.abs(y[:, 0] - sol.y[0])) < 0.02 * np.max(np.abs(sol.y[0]))
