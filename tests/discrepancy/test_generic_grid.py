"""The generic error model's filters on any time grid, against scipy's ODE solution."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.discrepancy import diagnose
from fmuid.discrepancy.generic import filtered
from fmuid.model.simulator import Simulator


def test_filters_on_a_jittered_grid_with_a_repeated_row_match_the_ode() -> None:
    rng = np.random.default_rng(4)
    time = np.sort(np.concatenate([np.linspace(0.0, 5.0, 200) + rng.uniform(0, 0.01, 200)]))
    time = np.insert(time, 50, time[50])  # a step given as two rows
    u = np.sin(3.0 * time)
    u[51:] += 0.5
    num, den = np.array([2.0, 1.0]), np.array([1.0, 3.0, 4.0])

    def rhs(t: float, s: np.ndarray) -> list[float]:
        k = np.searchsorted(time, t, side="right") - 1
        k = min(max(k, 0), len(time) - 2)
        h = time[k + 1] - time[k]
        v = u[k + 1] if h == 0 else u[k] + (u[k + 1] - u[k]) * (t - time[k]) / h
        return [s[1], v - 3.0 * s[1] - 4.0 * s[0]]

    sol = solve_ivp(
        rhs,
        (time[0], time[-1]),
        [0.0, 0.0],
        t_eval=np.unique(time),
        rtol=1e-10,
        atol=1e-12,
        max_step=0.005,
    )
    expected = 2.0 * sol.y[1] + sol.y[0]  # y = (2 s + 1) x for x'' + 3 x' + 4 x = u
    got = filtered(num, den, u, time)
    assert got[50] == got[51]  # a strictly proper filter: no jump at the repeated row
    np.testing.assert_allclose(np.delete(got, 51), expected, atol=2e-5)


def test_equal_steps_go_through_lsim_and_agree_with_the_recursion() -> None:
    time = np.linspace(0.0, 2.0, 101)
    u = np.cos(2.0 * time)
    num, den = np.array([1.0]), np.array([1.0, 2.0])
    jitter = time.copy()
    jitter[1:-1] += 1e-7 * np.sin(np.arange(99))
    np.testing.assert_allclose(
        filtered(num, den, u, time), filtered(num, den, u, jitter), atol=1e-6
    )


@pytest.mark.slow
def test_diagnose_takes_a_record_with_a_dropped_row_and_jittered_times(msd_fmu: Path) -> None:
    rng = np.random.default_rng(5)
    t = np.arange(0.0, 12.0, 0.05) + rng.uniform(0.0, 0.004, 240)
    t = np.delete(np.sort(t), 37)  # a dropped row
    u = np.where(t > 1.0, 1.0, 0.0) + 0.3 * np.sin(2.0 * t)
    sim = Simulator(msd_fmu)
    x = sim.simulate({}, t, {"f": u}, t, ["x"])[:, 0] + rng.normal(0.0, 0.005, t.size)
    sim.close()
    spec = spec_from_json(
        '{"parameters": {"k": {"start": 4, "lower": 0.5, "upper": 20}}, "inputs": ["f"],'
        ' "outputs": {"x": {"sigma": 0.005}}, "global_search": false}'
    )
    result = diagnose(msd_fmu, [experiment_from_arrays("e.csv", t, {"f": u, "x": x})], spec)
    assert result.mismatch is False  # the FMU made the data: nothing is left out
