"""The EMPS closed-loop FMU against an independent scipy solution of the same equations."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fmuid.model.simulator import Simulator

START = {
    "M": 95.11,
    "Fv": 0.0,
    "Fc": 0.0,
    "v_c": 1e-3,
    "offset": 0.0,
    "gtau": 35.15,
    "kp": 160.18,
    "kv": 243.45,
    "vir_max": 10.0,
}
T = np.round(np.arange(8001) * 2.5e-4, 10)
CORNERS = np.array([0.0, 0.4, 0.9, 1.4, 2.0])
Q_CORNERS = np.array([0.0, 0.01, 0.01, -0.0025, -0.0025])
"""A reference position linear between its corners (the FMU's inputs are linear between samples)."""


def reference(params: dict[str, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Solve M q'' = gtau vir - Fv q' - Fc tanh(q'/v_c) - offset in the PD loop; q, vir, v."""
    p = {**START, **params}

    def drive(t: float, x: np.ndarray, segment: int) -> float:
        slope = np.diff(Q_CORNERS)[segment] / np.diff(CORNERS)[segment]
        q_ref = Q_CORNERS[segment] + slope * (t - CORNERS[segment])
        vir = p["kv"] * (p["kp"] * (q_ref - x[0]) - x[1])
        return min(max(vir, -p["vir_max"]), p["vir_max"])

    def rhs(t: float, x: np.ndarray, segment: int) -> list[float]:
        friction = p["Fv"] * x[1] + p["Fc"] * np.tanh(x[1] / p["v_c"])
        return [x[1], (p["gtau"] * drive(t, x, segment) - friction - p["offset"]) / p["M"]]

    state, q, vir, v = np.zeros(2), [], [], []
    for segment, (t0, t1) in enumerate(zip(CORNERS[:-1], CORNERS[1:], strict=True)):
        inside = (T >= t0) & (T < t1) if segment < len(CORNERS) - 2 else T >= t0
        sol = solve_ivp(
            rhs,
            (t0, t1),
            state,
            t_eval=T[inside],
            method="DOP853",
            rtol=1e-12,
            atol=1e-14,
            args=(segment,),
            dense_output=True,
        )
        state = sol.sol(t1)
        q.append(sol.y[0])
        v.append(sol.y[1])
        vir += [drive(t, x, segment) for t, x in zip(sol.t, sol.y.T, strict=True)]
    return np.concatenate(q), np.array(vir), np.concatenate(v)


@pytest.mark.parametrize(
    ("params", "tolerance"),
    [
        ({}, 1e-6),
        ({"Fv": 203.5, "Fc": 20.39, "offset": -3.16}, 1e-6),
        # the saturation's corner falls inside a fixed Runge-Kutta step: first order there
        pytest.param({"vir_max": 1.5}, 1e-3, marks=pytest.mark.slow),
    ],
)
def test_emps_matches_scipy(
    built_fmus: dict[str, Path], params: dict[str, float], tolerance: float
) -> None:
    sim = Simulator(built_fmus["emps"])
    try:
        y = sim.simulate(params, CORNERS, {"q_ref": Q_CORNERS}, T, ["qm", "vir", "v"])
    finally:
        sim.close()
    q, vir, v = reference(params)
    np.testing.assert_allclose(y[:, 0], q, rtol=0, atol=tolerance * np.ptp(q))
    np.testing.assert_allclose(y[:, 1], vir, rtol=0, atol=tolerance * np.ptp(vir))
    np.testing.assert_allclose(y[:, 2], v, rtol=0, atol=tolerance * np.ptp(v))


def test_an_external_force_acts_on_the_load_as_a_negative_offset(
    built_fmus: dict[str, Path],
) -> None:
    sim = Simulator(built_fmus["emps"])
    q_ref = np.interp(T, CORNERS, Q_CORNERS)
    pushed = sim.simulate(START, T, {"q_ref": q_ref, "f_ext": np.full(T.size, 12.0)}, T, ["qm"])
    offset = sim.simulate({**START, "offset": -12.0}, T, {"q_ref": q_ref}, T, ["qm"])
    sim.close()
    np.testing.assert_allclose(pushed, offset, rtol=0, atol=1e-12)
    assert np.max(np.abs(pushed - np.interp(T, CORNERS, Q_CORNERS)[:, None])) > 1e-6
