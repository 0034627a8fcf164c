"""Profile likelihood on the mass-spring-damper examples of thesis chapter 2 (Tables 2.1-2.3)."""

import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import fmuid
from fmuid.data import experiment_from_arrays, spec_from_json


def msd_step_data(m, k, b, sigma, seed, force=40.0, duration=10.0, rate=5.0):
    """40 N step response sampled at ``rate`` Hz plus Gaussian noise, solved by scipy."""
    t = np.arange(0.0, duration + 1e-9, 1.0 / rate)
    sol = solve_ivp(
        lambda _t, y: [y[1], (force - b * y[1] - k * y[0]) / m],
        (0.0, duration),
        [0.0, 0.0],
        t_eval=t,
        rtol=1e-11,
        atol=1e-12,
    )
    x = sol.y[0] + np.random.default_rng(seed).normal(0.0, sigma, t.size)
    return experiment_from_arrays("step.csv", t, {"f": np.full(t.size, force), "x": x})


def spec(params, sigma, **extra):
    body = {
        "parameters": {n: {"start": v, "lower": 0.01, "upper": 5.0} for n, v in params.items()},
        "inputs": ["f"],
        "outputs": {"x": {"sigma": sigma}},
        "global_search": False,
        **extra,
    }
    return spec_from_json(json.dumps(body))


@pytest.fixture(scope="module")
def parallel_result(msd_parallel_fmu):
    data = msd_step_data(1.1, 4.4, 1.6, 0.1, seed=1)
    s = spec({"m": 1.1, "k1": 3.0, "k2": 1.4, "b": 1.6}, 0.1)
    return fmuid.profile(msd_parallel_fmu, [data], s, workers=2)


def test_parallel_springs_structurally_non_identifiable(parallel_result):
    res = parallel_result
    for name in ("k1", "k2"):
        assert res.parameters[name].status == "structurally_non_identifiable"
    for name, truth in (("m", 1.1), ("b", 1.6)):
        p = res.parameters[name]
        assert p.status == "identifiable"
        lo, hi = p.ci_simultaneous
        assert lo < truth < hi


def test_parallel_springs_sum_stays_fitted_along_profile(parallel_result):
    res = parallel_result
    k_sum = res.fit.estimates["k1"] + res.fit.estimates["k2"]
    p = res.parameters["k1"]
    free = [q for q in p.points if not q.at_bound and q.error is None]
    assert len(free) >= 5
    values = np.array([q.value for q in free])
    assert values.max() / values.min() > 3.0
    for q in free:
        assert q.value + q.params["k2"] == pytest.approx(k_sum, rel=1e-3)
        assert q.chi2 - res.chi2 < 0.1 * res.thresholds["simultaneous"]


def test_structural_check_names_the_sum(parallel_result):
    combos = parallel_result.structural_check["non_identifiable_combinations"]
    assert len(combos) == 1
    assert sorted(combos[0]["parameters"]) == ["k1", "k2"]
    assert combos[0]["meaning"] == "only k1 + k2 is identifiable"
    sv = parallel_result.structural_check["singular_values"]
    assert sv[-1] < 1e-6 * sv[0]


def test_profile_json_matches_contract(parallel_result):
    out = parallel_result.to_dict()
    assert set(out) >= {
        "fmu",
        "n_data",
        "chi2",
        "confidence",
        "thresholds",
        "sigma",
        "parameters",
        "better_optimum_found",
        "structural_check",
        "cost",
    }
    assert out["thresholds"]["simultaneous"] == pytest.approx(4.6954, abs=1e-3)
    assert out["thresholds"]["pointwise"] == pytest.approx(0.9889, abs=1e-3)
    entry = out["parameters"]["m"]
    assert set(entry) >= {"estimate", "lower", "upper", "ci", "status", "profile"}
    assert set(entry["profile"][0]) >= {"value", "chi2", "params", "at_bound"}
    assert out["n_data"] == 51


@pytest.mark.slow
def test_msd_identifiable_and_covers_truth_for_most_seeds(msd_fmu):
    """Thesis Table 2.3 set-up over 20 noise seeds: nominal simultaneous coverage is 68 %."""
    truth = {"m": 1.1, "k": 4.4, "b": 1.6}
    covered = dict.fromkeys(truth, 0)
    joint = 0
    seeds = range(100, 120)
    for seed in seeds:
        data = msd_step_data(**truth, sigma=0.5, seed=seed)
        res = fmuid.profile(msd_fmu, [data], spec(truth, 0.5), workers=2)
        inside = True
        for name, value in truth.items():
            p = res.parameters[name]
            assert p.status == "identifiable", (seed, name)
            lo, hi = p.ci_simultaneous
            assert lo < p.estimate < hi
            covered[name] += lo < value < hi
            inside &= lo < value < hi
        joint += inside
    for name, count in covered.items():
        assert count >= 0.6 * len(seeds), (name, count)
    assert joint >= 0.5 * len(seeds)


def test_same_seed_same_result(msd_fmu):
    truth = {"m": 1.1, "k": 4.4, "b": 1.6}
    data = msd_step_data(**truth, sigma=0.5, seed=7)
    s = spec(truth, 0.5, **{"global_search": True, "seed": 3})
    a = fmuid.profile(msd_fmu, [data], s, workers=2).to_dict()
    b = fmuid.profile(msd_fmu, [data], s, workers=2).to_dict()
    for doc in (a, b):  # wall time, and when it ran (the rest of the provenance is the same)
        doc.pop("cost")
        started, finished = doc["provenance"].pop("started"), doc["provenance"].pop("finished")
        assert started <= finished
    assert a == b


def test_better_optimum_found_on_a_profile_refits_and_redoes(msd_fmu):
    from fmuid.estimation.optimize import FitOptions, fit_problem
    from fmuid.profiling.engine import profile_problem
    from fmuid.stages import make_problem

    truth = {"m": 1.1, "k": 4.4, "b": 1.6}
    data = msd_step_data(**truth, sigma=0.2, seed=11)
    problem = make_problem(msd_fmu, [data], spec({"m": 1.5, "k": 3.0, "b": 1.0}, 0.2))
    rough = fit_problem(problem, global_search=False, options=FitOptions(max_nfev=4))
    good = fit_problem(problem, global_search=False)
    assert rough.chi2 > good.chi2 + 1.0
    result = profile_problem(problem, rough, workers=1)
    assert result.better_optimum_found
    assert result.chi2 == pytest.approx(good.chi2, rel=1e-5)
    for p in result.parameters.values():
        assert min(q.chi2 for q in p.points if q.error is None) >= result.chi2 - 1e-3
