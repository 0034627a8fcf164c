"""Fisher screen: sensitivities against scipy, predictions against profiles, the null space."""

import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from design_cases import space_of
from fmuid.data import spec_from_json
from fmuid.experiment_design import design
from fmuid.experiment_design.fisher import sensitivity, trial_problem
from fmuid.experiment_design.signals import Trial, input_signal, output_times
from fmuid.model.builtin import builtin_fmu
from fmuid.model.fmu import FmuModel

NOMINAL = {"m": 1.1, "k": 4.4, "b": 1.6}


def scipy_x(params, trial):
    """Position of m x'' + b x' + k x = f for the trial's input, by scipy (rtol 1e-11)."""
    t_in, u = input_signal(trial)
    m, k, b = params["m"], params["k"], params["b"]
    sol = solve_ivp(
        lambda t, y: [y[1], (np.interp(t, t_in, u) - b * y[1] - k * y[0]) / m],
        (0.0, trial.duration),
        [0.0, 0.0],
        t_eval=output_times(trial),
        rtol=1e-11,
        atol=1e-13,
        max_step=0.005,
    )
    return sol.y[0]


def test_fisher_information_matches_scipy_sensitivities(msd_spec, msd_space):
    trial = Trial("step", {"amplitude": 1.0, "time": 1.0}, 6.0, 10.0, ("x", "v"))
    problem = trial_problem(FmuModel(builtin_fmu("msd")), msd_spec, msd_space, trial)
    fisher = sensitivity(problem, NOMINAL).fisher(["x"])
    cols = []
    for name in NOMINAL:  # central differences in log10 of the scipy solution
        up, down = dict(NOMINAL), dict(NOMINAL)
        up[name] *= 10**1e-4
        down[name] *= 10**-1e-4
        cols.append((scipy_x(up, trial) - scipy_x(down, trial)) / 2e-4 / 0.02)
    jac = np.column_stack(cols)
    assert fisher == pytest.approx(jac.T @ jac, rel=2e-3)


@pytest.mark.slow
def test_predicted_widths_agree_with_profiles_on_simulated_data(msd_spec, msd_space):
    result = design("msd", msd_spec, msd_space)
    best = result.best
    assert best.verified is not None and best.verified.draws == 2
    assert result.not_identifiable_by_any == []
    for name in NOMINAL:
        assert best.verified.identifiable[name] == 2
        ratio = best.verified.median_width(name) / best.predicted[name]["width_z"]
        assert 0.67 < ratio < 1.5, (name, ratio)  # stated factor: 1.5
    # every listed design is scored, the verified one first; dropping a sensor costs
    assert [d.verified is not None for d in result.designs[:2]] == [True, False]
    assert all(
        v["score_ratio"] is None or v["score_ratio"] > 1
        for k, v in result.tradeoffs.items()
        if k.startswith(("drop", "rate"))
    )
    doc = result.to_dict()
    assert doc["designs"][0]["experiment"]["input"] in ("step", "chirp")
    assert result.to_frame().shape[0] == len(result.designs)


def test_msd_parallel_reports_k1_k2_not_identifiable_by_any_experiment():
    spec = spec_from_json(
        json.dumps(
            {
                "parameters": {
                    n: {"start": v, "lower": 0.01, "upper": 5}
                    for n, v in {"m": 1.1, "k1": 3.0, "k2": 1.4, "b": 1.6}.items()
                },
                "inputs": ["f"],
                "outputs": {"x": {"sigma": 0.1}},
            }
        )
    )
    space = space_of(robust={"points": 0}, verify_designs=0, candidates=2)
    result = design("msd_parallel", spec, space)
    assert result.to_dict()["not_identifiable_by_any"] == [
        {"parameters": ["k1", "k2"], "meaning": "only k1 + k2 is identifiable"}
    ]
    for d in result.designs:
        assert (
            d.predicted["k1"]["status"]
            == d.predicted["k2"]["status"]
            == "structurally_non_identifiable"
        )
        assert d.predicted["m"]["status"] == "identifiable"
        assert np.isfinite(d.score)
