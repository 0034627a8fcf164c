"""The base model and its augmentations cross the same input sub-steps (a co-simulation FMU
without input derivatives), and threshold screens reach the signals' extremes."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.discrepancy.augment import FINE, AugmentedPredictor
from fmuid.discrepancy.catalogue import LEVELS, levels
from fmuid.discrepancy.scan import augmented
from fmuid.model.base import INPUT_STEP
from fmuid.model.builtin import builtin_fmu
from fmuid.stages import make_problem

K, TAU = 2.0, 0.5  # tests/pythonfmu_src/first_order.py


def _ramp_problem(fmu: Path):
    t = np.arange(0.0, 2.0 + 1e-9, INPUT_STEP)  # sampled at the sub-step
    exp = experiment_from_arrays("ramp.csv", t, {"u": t, "y": np.zeros(t.size)})
    spec = spec_from_json(
        '{"parameters": {"K": {"start": 2.0, "lower": 0.1, "upper": 10}}, "inputs": ["u"],'
        ' "outputs": {"y": {"sigma": 1.0}}, "global_search": false}'
    )
    return make_problem(fmu, [exp], spec), t


def test_base_problem_of_a_diagnosis_holds_inputs_on_the_fine_grid(first_order_fmu: Path) -> None:
    """Closed form of ``tau y' = K u - y`` for ``u = t``: the fine grid's hold error is FINE**2
    times smaller than the sample grid's (second order in the sub-step)."""
    problem, t = _ramp_problem(first_order_fmu)
    common = augmented(problem, [])
    assert isinstance(common.predictor, AugmentedPredictor) and common.predictor.fine_inputs
    exact = K * (t - TAU + TAU * np.exp(-t / TAU))
    coarse = problem.predictor.predict({"K": K}, problem.experiments[0], ["y"])[:, 0]
    fine = common.predictor.predict({"K": K}, problem.experiments[0], ["y"])[:, 0]
    err_coarse, err_fine = np.max(np.abs(coarse - exact)), np.max(np.abs(fine - exact))
    assert err_coarse > 0
    assert err_fine <= err_coarse / FINE**2 * 1.1


def test_an_fmu_with_input_derivatives_keeps_its_own_predictor() -> None:
    t = np.linspace(0.0, 1.0, 11)
    exp = experiment_from_arrays("s.csv", t, {"f": np.ones(11), "x": np.zeros(11)})
    spec = spec_from_json(
        '{"parameters": {"k": {"start": 3, "lower": 0.1, "upper": 20}}, "inputs": ["f"],'
        ' "outputs": {"x": {"sigma": 1.0}}, "global_search": false}'
    )
    problem = make_problem(builtin_fmu("msd"), [exp], spec)
    assert augmented(problem, []).predictor is problem.predictor


def test_threshold_levels_reach_two_samples_of_the_extreme() -> None:
    n = 2000
    got = levels(n)
    assert got[: len(LEVELS)] == LEVELS
    shares = [1 - q for q in got[len(LEVELS) :]]
    assert np.allclose(shares, [0.02 / 2.5**k for k in range(1, len(shares) + 1)])
    assert shares[-1] * n >= 2 > shares[-1] / 2.5 * n
    assert levels(50) == LEVELS
