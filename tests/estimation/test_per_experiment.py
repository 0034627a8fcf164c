"""Initial states as parameters, one value per experiment (``Spec.per_experiment``).

The FMU is two linear tanks in cascade whose initial levels are parameters; the reference is
the cascade's closed form, fitted and profiled by scipy.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq, least_squares
from scipy.stats import chi2 as chi2_dist

import fmuid
from fmuid.data import Experiment, experiment_from_arrays, spec_from_json
from fmuid.discrepancy.validate import validation
from fmuid.errors import DataError, SpecError
from fmuid.estimation.per_experiment import expand, for_experiment
from fmuid.estimation.validation import STATES_METHOD
from fmuid.experiment_design.space import check_design, space_from_json
from fmuid.model.fmu import FmuModel
from fmuid.stages import make_problem

SIGMA = 0.01
T = np.round(np.arange(0.0, 8.0 + 1e-9, 0.2), 10)
SHARED = {"K": 2.0, "tau1": 0.4, "tau2": 1.5}
RECORDS = {"a.csv": (1.0, 0.5, 3.0), "b.csv": (2.0, 3.5, 0.2)}
"""Each estimation record: its constant input u and its initial levels h1_0, h2_0 [m]."""
TEST = ("c.csv", 1.5, 1.2, 0.9)
NAMES = ["K", "tau1", "tau2", "h1_0@a.csv", "h1_0@b.csv", "h2_0@a.csv", "h2_0@b.csv"]
BOUNDS = {
    "K": (0.1, 10.0),
    "tau1": (0.05, 0.9),
    "tau2": (1.0, 5.0),
    "h1_0": (0.0, 6.0),
    "h2_0": (0.0, 6.0),
}


def level(k: float, tau1: float, tau2: float, h1_0: float, h2_0: float, u: float) -> np.ndarray:
    """Lower level h2 at T: closed form of tau1 h1' = K u - h1, tau2 h2' = h1 - h2."""
    a = k * u
    b = (h1_0 - a) * tau1 / (tau1 - tau2)
    return a + b * np.exp(-T / tau1) + (h2_0 - a - b) * np.exp(-T / tau2)


def record(name: str, u: float, h1_0: float, h2_0: float, seed: int) -> Experiment:
    noise = np.random.default_rng(seed).normal(0.0, SIGMA, T.size)
    h2 = level(*SHARED.values(), h1_0, h2_0, u) + noise
    return experiment_from_arrays(name, T, {"u": np.full(T.size, u), "h2": h2})


def study(**extra: object):
    body = {
        "parameters": {
            "K": {"start": 1.0, "lower": 0.1, "upper": 10.0},
            "tau1": {"start": 0.3, "lower": 0.05, "upper": 0.9},
            "tau2": {"start": 2.0, "lower": 1.0, "upper": 5.0},
            "h1_0": {"start": 1.0, "lower": 0.0, "upper": 6.0},
            "h2_0": {"start": 1.0, "lower": 0.0, "upper": 6.0},
        },
        "per_experiment": ["h1_0", "h2_0"],
        "outputs": {"h2": {"sigma": SIGMA}},
        "global_search": False,
        **extra,
    }
    return spec_from_json(json.dumps(body))


@pytest.fixture(scope="module")
def data() -> list[Experiment]:
    return [record(name, *case, seed=i) for i, (name, case) in enumerate(RECORDS.items())]


def residuals(x: np.ndarray, data: list[Experiment]) -> np.ndarray:
    """Weighted residuals of the closed form at x (in NAMES order) on the records."""
    k, tau1, tau2, h1a, h1b, h2a, h2b = x
    states = {"a.csv": (h1a, h2a), "b.csv": (h1b, h2b)}
    return np.concatenate(
        [
            (e.columns["h2"] - level(k, tau1, tau2, *states[e.name], RECORDS[e.name][0])) / SIGMA
            for e in data
        ]
    )


def bounds(names: list[str]) -> tuple[list[float], list[float]]:
    pairs = [BOUNDS[n.split("@")[0]] for n in names]
    return [p[0] for p in pairs], [p[1] for p in pairs]


def reference_fit(data: list[Experiment]) -> np.ndarray:
    """The maximum-likelihood estimate by scipy from the truth (in NAMES order)."""
    truth = [*SHARED.values(), 0.5, 3.5, 3.0, 0.2]
    fit = least_squares(
        residuals, truth, args=(data,), bounds=bounds(NAMES), xtol=1e-14, ftol=1e-14
    )
    return fit.x


def test_names_expand_and_resolve_per_experiment():
    specs = expand({"K": 1, "x0": 2, "x0@a.csv": 3}, ["x0"], ["a.csv", "b.csv"])
    assert specs == {"K": 1, "x0@a.csv": 3, "x0@b.csv": 2}
    values = {"K": 1.0, "x0@a.csv": 0.1, "x0@b.csv": 0.2, "x0@run@2.csv": 0.3}
    assert for_experiment(values, ["x0"], "b.csv") == {"K": 1.0, "x0": 0.2}
    assert for_experiment(values, ["x0"], "run@2.csv") == {"K": 1.0, "x0": 0.3}
    assert for_experiment({"x0": 0.5}, ["x0"], "c.csv") == {"x0": 0.5}
    assert for_experiment(values, [], "b.csv") == values


def test_each_record_gets_its_own_initial_state_and_the_test_record_too(two_tanks_fmu, data):
    test = record(*TEST, seed=7)
    fit = fmuid.fit(two_tanks_fmu, data, study(), test_data=[test])
    assert list(fit.names) == NAMES
    assert fit.problem.shared_names == list(SHARED)
    expected = reference_fit(data)
    got = np.array([fit.estimates[n] for n in NAMES])
    np.testing.assert_allclose(got, expected, rtol=1e-4, atol=1e-4)
    assert fit.chi2 == pytest.approx(float(np.sum(residuals(expected, data) ** 2)), rel=1e-6)
    assert fit.to_dict()["parameters"]["h1_0@a.csv"]["lower"] == 0.0

    # the test record's levels: fitted with K, tau1, tau2 at their estimates (scipy on it)
    (entry,) = fit.to_dict()["validation"]
    shared = [fit.estimates[n] for n in SHARED]
    u = TEST[1]

    def misfit(h: np.ndarray) -> np.ndarray:
        return test.columns["h2"] - level(*shared, *h, u)

    states = least_squares(misfit, [1.0, 1.0], bounds=bounds(["h1_0", "h2_0"]), xtol=1e-14).x
    assert [entry["initial_states"][n] for n in ("h1_0", "h2_0")] == pytest.approx(states, abs=1e-4)
    rms = float(np.sqrt(np.mean(misfit(states) ** 2)))
    assert entry["rms_base"] == pytest.approx(rms, rel=1e-4)
    assert entry["rms_base"] < 1.2 * SIGMA  # the noise: the record's start is found
    assert entry["initial_states_method"] == STATES_METHOD
    assert abs(states[0] - TEST[2]) < 0.1 and abs(states[1] - TEST[3]) < 0.02

    # the diagnosis's validation: each model (here the same one twice) fits its own states
    (found,) = validation([(fit.problem, fit.estimates)] * 2, [test])
    step = found.to_dict()
    assert step["rms_by_step"] == [entry["rms_base"]] * 2
    assert step["initial_states_final"] == entry["initial_states"]


def test_records_of_one_name_are_refused(two_tanks_fmu, data):
    twin = record("a.csv", 2.0, 3.5, 0.2, seed=3)
    with pytest.raises(DataError, match="a.csv: two experiments have this file name"):
        make_problem(two_tanks_fmu, [data[0], twin], study())
    make_problem(two_tanks_fmu, [data[0], twin], study(per_experiment=[]))


def reference_ends(data: list[Experiment], i: int, best: np.ndarray, threshold: float):
    """The pointwise interval of parameter i from scipy's own profile of the closed form."""
    chi2_min = float(np.sum(residuals(best, data) ** 2))
    others = [k for k in range(len(NAMES)) if k != i]
    lo, hi = bounds([NAMES[k] for k in others])

    def excess(value: float) -> float:
        def r(y: np.ndarray) -> np.ndarray:
            return residuals(np.insert(y, i, value), data)

        fit = least_squares(r, best[others], bounds=(lo, hi), xtol=1e-14, ftol=1e-14)
        return float(np.sum(fit.fun**2)) - chi2_min - threshold

    step = 0.5 * abs(best[i]) + 0.2
    return (
        brentq(excess, best[i] - step, best[i], xtol=1e-10),
        brentq(excess, best[i], best[i] + step, xtol=1e-10),
    )


@pytest.mark.slow
def test_profiles_give_each_initial_state_its_interval(two_tanks_fmu, data):
    profile = fmuid.profile(two_tanks_fmu, data, study(confidence=0.95), workers=1).to_dict()
    truth = [*SHARED.values(), 0.5, 3.5, 3.0, 0.2]
    best = reference_fit(data)
    threshold = float(chi2_dist.ppf(0.95, 1))
    for i, name in enumerate(NAMES):
        entry = profile["parameters"][name]
        lower, upper = entry["ci"]["simultaneous"]
        assert lower < truth[i] < upper, name
        assert entry["status"] == "identifiable"
    for name in ("h1_0@a.csv", "h2_0@b.csv", "tau1"):
        i = NAMES.index(name)
        ends = reference_ends(data, i, best, threshold)
        got = profile["parameters"][name]["ci"]["pointwise"]
        assert got == pytest.approx(ends, abs=0.01 * (ends[1] - ends[0])), name


def test_spec_without_per_experiment_is_unchanged(two_tanks_fmu: Path, data):
    problem = make_problem(two_tanks_fmu, data, study(per_experiment=[]))
    assert problem.names == ("K", "tau1", "tau2", "h1_0", "h2_0")


def test_a_design_refuses_per_experiment_parameters(two_tanks_fmu):
    space = space_from_json(
        json.dumps(
            {
                "input": "u",
                "families": {"step": {"amplitude": [0.5, 2.0], "time": [0.0, 1.0]}},
                "rates_hz": [5],
                "outputs": {"h2": {"sigma": SIGMA}},
                "duration": 8,
            }
        ),
        "space.json",
    )
    with pytest.raises(SpecError, match="per_experiment: 'h1_0' takes one value per experiment"):
        check_design(space, study(), FmuModel(two_tanks_fmu))
