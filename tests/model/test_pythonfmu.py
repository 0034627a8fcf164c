"""A second foreign FMI implementation: a first-order lag exported by pythonfmu at test time,
simulated against its closed form, fitted and profiled against an independent scipy profile."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar
from scipy.stats import chi2 as chi2_dist

import fmuid
from fmuid.data import Experiment, experiment_from_arrays, spec_from_json
from fmuid.model.base import MAX_SUB_STEPS
from fmuid.model.simulator import INPUT_STEP, Simulator

K, TAU, SIGMA = 2.0, 0.5, 0.02
T = np.round(np.arange(0.0, 4.0 + 1e-9, 0.1), 10)


def _step(k: float, tau: float) -> np.ndarray:
    return k * (1.0 - np.exp(-T / tau))


def test_step_response_is_the_closed_form(first_order_fmu: Path) -> None:
    sim = Simulator(first_order_fmu)
    assert sim.model.fmi_version == "2.0" and sim.model.interface == "CoSimulation"
    for k, tau in [(K, TAU), (0.7, 1.9), (5.0, 0.05)]:
        y = sim.simulate({"K": k, "tau": tau}, T[:1], {"u": np.ones(1)}, T, ["y"])[:, 0]
        np.testing.assert_allclose(y, _step(k, tau), rtol=0, atol=1e-13)


@pytest.mark.parametrize("samples", [2, 21])
def test_ramp_is_held_at_sub_step_midpoints(first_order_fmu: Path, samples: int) -> None:
    """No input derivatives: each sub-step holds the ramp's midpoint value, so the output
    follows the exact ramp response K (t - tau + tau exp(-t/tau)) to second order, within
    K u' d**2 / (12 tau) for the ramp's slope u' and sub-step d (the steady error of a local
    error K u' d**3 / (12 tau**2) per sub-step). The sub-step is INPUT_STEP, or the input's
    sample interval over MAX_SUB_STEPS where that is longer, and at most the 0.1 s between
    outputs: the ramp given by its 2 end samples is held once per output interval, the ramp
    sampled at every output (0.1 s) over 8 sub-steps of 12.5 ms."""
    sim = Simulator(first_order_fmu)
    t = T[T <= 2.0]
    t_in = np.linspace(0.0, 2.0, samples)
    y = sim.simulate({}, t_in, {"u": t_in}, t, ["y"])[:, 0]
    exact = K * (t - TAU + TAU * np.exp(-t / TAU))
    d = min(0.1, max(INPUT_STEP, (t_in[1] - t_in[0]) / MAX_SUB_STEPS))
    bound = K * 1.0 * d**2 / (12 * TAU)
    error = np.abs(exact - y)
    assert np.max(error) <= bound * 1.05
    assert np.max(error) > bound * 0.5  # the hold is there (a real check)
    assert "midpoint" in sim.input_handling


@pytest.mark.parametrize("native", [True, False])
def test_a_finer_resampling_of_the_input_keeps_its_sub_steps(
    first_order_fmu: Path, native: bool
) -> None:
    """The ramp sampled every 0.1 s and the same ramp resampled every 0.025 s (as the diagnosis
    hands inputs to an FMU without input derivatives): told the original sample times, the
    simulator crosses both in the same 12.5 ms sub-steps, so the outputs agree to rounding;
    not told, it holds the resampled ramp over sub-steps 4 times shorter (a smaller hold
    error, a different result)."""
    sim = Simulator(first_order_fmu)
    sim.native = native
    t = T[T <= 2.0]
    fine = np.linspace(0.0, 2.0, 4 * (t.size - 1) + 1)
    coarse = sim.simulate({}, t, {"u": t}, t, ["y"])[:, 0]
    told = sim.simulate({}, fine, {"u": fine}, t, ["y"], sample_time=t)[:, 0]
    np.testing.assert_allclose(told, coarse, rtol=0, atol=1e-12)
    untold = sim.simulate({}, fine, {"u": fine}, t, ["y"])[:, 0]
    assert np.max(np.abs(untold - coarse)) > 1e-5


@pytest.fixture(scope="module")
def lag_data() -> Experiment:
    noise = np.random.default_rng(3).normal(0.0, SIGMA, T.size)
    return experiment_from_arrays("lag.csv", T, {"u": np.ones(T.size), "y": _step(K, TAU) + noise})


SPEC = {
    "parameters": {
        "K": {"start": 1.0, "lower": 0.1, "upper": 10.0},
        "tau": {"start": 1.0, "lower": 0.05, "upper": 5.0},
    },
    "inputs": ["u"],
    "outputs": {"y": {"sigma": SIGMA}},
    "global_search": False,
}


def _scipy_profiles(y: np.ndarray) -> dict[str, tuple[float, float]]:
    """Pointwise 68 % intervals of K and tau from the closed form (independent of fmuid)."""

    def chi2(k: float, tau: float) -> float:
        return float(np.sum(((y - _step(k, tau)) / SIGMA) ** 2))

    def best_tau(k: float) -> float:
        opt = minimize_scalar(
            lambda lt: chi2(k, np.exp(lt)),
            bounds=(np.log(0.05), np.log(5)),
            method="bounded",
            options={"xatol": 1e-12},
        )
        return float(opt.fun)

    def best_k(tau: float) -> float:
        g = 1.0 - np.exp(-T / tau)
        return chi2(float(g @ y / (g @ g)), tau)

    def interval(profile: Callable[[float], float], guess: float) -> tuple[float, float]:
        opt = minimize_scalar(
            profile, bounds=(guess / 2, guess * 2), method="bounded", options={"xatol": 1e-12}
        )
        level = opt.fun + chi2_dist.ppf(0.68, 1)
        lo = brentq(lambda v: profile(v) - level, guess / 2, opt.x, xtol=1e-12)
        hi = brentq(lambda v: profile(v) - level, opt.x, guess * 2, xtol=1e-12)
        return lo, hi

    return {"K": interval(best_tau, K), "tau": interval(best_k, TAU)}


def test_fit_and_profile_match_scipy(first_order_fmu: Path, lag_data: Experiment) -> None:
    spec = spec_from_json(json.dumps(SPEC))
    result = fmuid.profile(first_order_fmu, [lag_data], spec, workers=1)
    reference = _scipy_profiles(lag_data.columns["y"])
    for name, (lo, hi) in reference.items():
        got = result.parameters[name].ci_pointwise
        half = (hi - lo) / 2
        assert got[0] == pytest.approx(lo, abs=2e-3 * half), name
        assert got[1] == pytest.approx(hi, abs=2e-3 * half), name
        assert result.parameters[name].status == "identifiable"
    fmu = result.to_dict()["fmu"]
    assert fmu["interface"] == "CoSimulation" and "sub-steps" in fmu["input_handling"]
    assert fmu["instances"] == "one instance, reset between runs"
