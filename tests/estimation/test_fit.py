"""Fit stage: global start, trust-region refinement, sigma estimation, scaling."""

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

import fmuid
from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.estimation.sigma import spline_residual_sigma
from fmuid.stages import make_problem


def msd_data(name, force, sigma, seed, m=1.1, k=4.4, b=1.6, duration=10.0):
    t = np.arange(0.0, duration + 1e-9, 0.2)
    sol = solve_ivp(
        lambda tt, y: [y[1], (np.interp(tt, force[0], force[1]) - b * y[1] - k * y[0]) / m],
        (0.0, duration),
        [0.0, 0.0],
        t_eval=t,
        rtol=1e-11,
        atol=1e-12,
        max_step=0.01,
    )
    x = sol.y[0] + np.random.default_rng(seed).normal(0.0, sigma, t.size)
    return experiment_from_arrays(name, t, {"f": np.interp(t, force[0], force[1]), "x": x})


def msd_spec(start, sigma=0.1, **extra):
    body = {
        "parameters": {n: {"start": v, "lower": 0.01, "upper": 5.0} for n, v in start.items()},
        "inputs": ["f"],
        "outputs": {"x": {"sigma": sigma}},
        **extra,
    }
    return spec_from_json(json.dumps(body))


STEP = (np.array([0.0, 10.0]), np.array([40.0, 40.0]))


def test_global_search_recovers_truth_from_a_far_start(msd_fmu):
    data = msd_data("step.csv", STEP, 0.05, seed=2)
    spec = msd_spec({"m": 4.5, "k": 0.05, "b": 0.02}, sigma=0.05, global_search=True, seed=1)
    fit = fmuid.fit(msd_fmu, [data], spec)
    assert fit.estimates["m"] == pytest.approx(1.1, rel=0.03)
    assert fit.estimates["k"] == pytest.approx(4.4, rel=0.02)
    assert fit.estimates["b"] == pytest.approx(1.6, rel=0.05)
    assert fit.chi2 < 51 + 4 * np.sqrt(2 * 51)
    assert fit.cost.simulations > 100


def test_several_experiments_share_parameters(msd_fmu):
    ramp = (np.array([0.0, 2.0, 4.0, 10.0]), np.array([0.0, 20.0, 20.0, -10.0]))
    data = [msd_data("step.csv", STEP, 0.1, seed=3), msd_data("ramp.csv", ramp, 0.1, seed=4)]
    fit = fmuid.fit(msd_fmu, data, msd_spec({"m": 1.0, "k": 4.0, "b": 1.0}, global_search=False))
    assert fit.n_data == 102
    for name, truth in (("m", 1.1), ("k", 4.4), ("b", 1.6)):
        assert fit.estimates[name] == pytest.approx(truth, rel=0.05)


@pytest.mark.slow
def test_estimated_sigma_is_close_to_the_true_noise(msd_fmu):
    data = [msd_data(f"s{i}.csv", STEP, 0.2, seed=10 + i, duration=40.0) for i in range(3)]
    problem = make_problem(
        msd_fmu, data, msd_spec({"m": 1.1, "k": 4.4, "b": 1.6}, sigma="estimate")
    )
    sigma = problem.representative_sigma()["x"]
    assert sigma == pytest.approx(0.2, rel=0.15)
    assert "smoothing spline" in problem.sigma_method["x"]


def test_spline_sigma_of_pure_noise_about_a_smooth_curve():
    t = np.linspace(0.0, 20.0, 400)
    y = np.sin(t) + np.random.default_rng(0).normal(0.0, 0.05, t.size)
    assert spline_residual_sigma([t], [y], "y") == pytest.approx(0.05, rel=0.1)


@settings(max_examples=50, deadline=None)
@given(
    st.floats(0.011, 4.99),
    st.floats(0.011, 4.99),
    st.floats(-3.0, 3.0),
)
def test_log_and_linear_scaling_round_trip(msd_fmu, m, k, b):
    spec = spec_from_json(
        json.dumps(
            {
                "parameters": {
                    "m": {"start": 1, "lower": 0.01, "upper": 5},
                    "k": {"start": 1, "lower": 0.01, "upper": 5, "scale": "lin"},
                    "b": {"start": 0, "lower": -5, "upper": 5},
                },
                "outputs": {"x": {"sigma": 1}},
            }
        )
    )
    data = experiment_from_arrays("d.csv", [0.0, 1.0], {"f": [0.0, 0.0], "x": [0.0, 0.0]})
    problem = make_problem(msd_fmu, [data], spec)
    assert problem.scales == ("log", "lin", "lin")
    values = {"m": m, "k": k, "b": b}
    back = problem.from_z(problem.to_z(values))
    for name, v in values.items():
        assert back[name] == pytest.approx(v, rel=1e-12, abs=1e-12)
    assert problem.to_z(values)[0] == pytest.approx(np.log10(m))


@pytest.mark.slow
def test_slow_generations_are_evaluated_side_by_side_with_the_same_result(msd_fmu, monkeypatch):
    from fmuid.engine.run import open_engine
    from fmuid.estimation import optimize

    data = msd_data("step.csv", STEP, 0.05, seed=2)
    problem = make_problem(msd_fmu, [data], msd_spec({"m": 4.5, "k": 0.05, "b": 0.02}))
    options = optimize.FitOptions(pop_size=8, generations=4)
    alone = optimize.global_start(problem, 1, options)
    monkeypatch.setattr(optimize, "SLOW_RUN", 0.0)  # every run counts as slow
    shares = []
    with open_engine(problem.model, workers=2) as engine:

        def mapper(fn, *iterables):
            shares.append(len(iterables[1]))
            return engine.map(fn, *iterables)

        side = optimize.global_start(problem, 1, options, mapper=mapper)
    np.testing.assert_array_equal(side, alone)
    assert shares == [optimize.GA_TASKS] * (options.generations - 1)  # the first timed here
