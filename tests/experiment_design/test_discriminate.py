"""Model discrimination: a sensor lag versus an input delay on the msd model."""

import json
import pickle

import numpy as np
import pytest
from scipy.stats import chi2

from fmuid.data import ParameterSpec, experiment_from_arrays, spec_from_json
from fmuid.discrepancy.effects import InputDelay, OutputLag
from fmuid.discrepancy.knowledge import AddedParameter
from fmuid.estimation.optimize import fit_problem
from fmuid.estimation.problem import Problem
from fmuid.experiment_design import space_from_json
from fmuid.experiment_design.discriminate import (
    Hypothesis,
    default_space,
    discriminating_experiment,
    discriminating_experiments,
)
from fmuid.model.builtin import builtin_fmu
from fmuid.plots import discrimination_figure
from fmuid.report.design import write_discrimination_report

TAU = 0.3
SPACE = {
    "input": "f",
    "families": {"step": {"amplitude": [0.3, 1.0], "time": [1.0, 1.0]}},
    "duration": 6.0,
    "rates_hz": [5, 10],
    "outputs": {"x": {"sigma": 0.005}, "v": {"sigma": 0.01}},
    "base_outputs": ["x"],
    "max_sensors": 2,
    "longest_test": 6.0,
    "candidates": 3,
}
SPEC = {
    "parameters": {
        "m": {"start": 1.1, "lower": 0.1, "upper": 10},
        "k": {"start": 4.4, "lower": 0.1, "upper": 40},
        "b": {"start": 1.6, "lower": 0.1, "upper": 10},
    },
    "inputs": ["f"],
    "outputs": {"x": {"sigma": 0.005}},
    "global_search": False,
}


@pytest.fixture(scope="module")
def proposal():
    spec, space = spec_from_json(json.dumps(SPEC)), space_from_json(json.dumps(SPACE))
    truth = {n: p.start for n, p in spec.parameters.items()}
    added = ParameterSpec(start=0.1, lower=0.005, upper=1.0)
    tau = AddedParameter("tau_outputs", "s", "lag", added, 0.0, "low")
    wait = AddedParameter("delay_f", "s", "delay", added, 0.0, "low")
    lag = Hypothesis(
        "output_lag",
        {**spec.parameters, "tau_outputs": added},
        {**truth, "tau_outputs": TAU},
        (OutputLag("", (tau,)),),
    )
    delay = Hypothesis(
        "input_delay",
        {**spec.parameters, "delay_f": added},
        {**truth, "delay_f": TAU},
        (InputDelay("f", (wait,)),),
    )
    return spec, space, lag, delay, discriminating_experiment("msd", spec, space, lag, delay)


def test_proposal_measures_both_sensors_at_full_amplitude(proposal):
    _, _, _, _, found = proposal
    # the separation grows with the amplitude (squared), the rate and the sensors
    assert found.trial.outputs == ("x", "v")
    assert found.trial.rate_hz == 10
    assert found.trial.settings["amplitude"] > 0.7
    assert found.expected_chi2 > 20
    doc = found.to_dict()
    assert doc["hypotheses"] == ["output_lag", "input_delay"]
    assert doc["expected_p_value"] < 1e-3
    fig = discrimination_figure(found)
    assert len(fig.axes) == 3


def test_one_hypothesis_against_several_equals_each_pair(proposal):
    # A's predictions and sensitivities are shared between the pairs; the answers are the pairs'
    spec, space, lag, delay, found = proposal
    slower = Hypothesis(
        "slower_lag", lag.parameters, {**lag.values, "tau_outputs": TAU / 2}, lag.effects
    )
    both = discriminating_experiments("msd", spec, space, lag, [delay, slower])
    assert both[0].trial == found.trial
    assert both[0].separation == pytest.approx(found.separation, rel=1e-9)
    alone = discriminating_experiment("msd", spec, space, lag, slower)
    assert both[1].trial == alone.trial
    assert both[1].separation == pytest.approx(alone.separation, rel=1e-9)
    assert both[1].hypotheses == ("output_lag", "slower_lag")


@pytest.mark.slow
def test_a_mapper_gets_the_answers_of_this_process(proposal):
    """Screens and confirming fits run as tasks on pickled copies give the same proposals."""
    spec, space, lag, delay, _ = proposal
    slower = Hypothesis(
        "slower_lag", lag.parameters, {**lag.values, "tau_outputs": TAU / 2}, lag.effects
    )
    tasks = []

    def mapper(fn, *iterables):
        tasks.append((fn.__name__, len(iterables[0])))
        return [fn(*pickle.loads(pickle.dumps(args))) for args in zip(*iterables, strict=True)]

    here = discriminating_experiments("msd", spec, space, lag, [delay, slower])
    mapped = discriminating_experiments("msd", spec, space, lag, [delay, slower], mapper=mapper)
    assert [d.to_dict() for d in mapped] == [d.to_dict() for d in here]
    assert [name for name, _ in tasks] == ["_screen_test", "_full_separation"]
    assert tasks[0][1] == here[0].screened and tasks[1][1] == 2 * 3  # the best 3 of each pair


def test_discrimination_report_shows_both_predictions_and_the_numbers(proposal, tmp_path):
    *_, found = proposal
    page = write_discrimination_report(found, tmp_path / "rep").read_text()
    assert (tmp_path / "rep" / "discrimination.png").stat().st_size > 10_000
    assert 'src="data:image/png;base64,' in page  # embedded
    assert "output_lag" in page and "input_delay" in page
    assert f"chi2 = {found.expected_chi2:.4g}" in page
    for name, value in found.separation.items():
        assert name in page and f"{value:.4g}" in page
    assert ">0.005<" in page and ">0.01<" in page  # the space's noise of x and v
    assert found.to_dict()["noise_sigma"] == {"x": 0.005, "v": 0.01}
    body = page.split("<body", 1)[1]
    for raw in ("{", "}", "': ", "array("):  # no Python literal reaches the page
        assert raw not in body, raw


@pytest.mark.slow
def test_predicted_separation_is_confirmed_on_simulated_data(proposal):
    """LRT p < 1e-3 (chi2 with 1 df of chi2_wrong - chi2_right) in >= 90 % of 20 draws each."""
    spec, space, lag, delay, found = proposal
    fmu = builtin_fmu("msd")
    for truth, other in ((lag, delay), (delay, lag)):
        template = truth.problem(fmu, spec, space, found.trial)
        clean = template.predict(truth.values)[0]
        mask = template.masks[0][0]
        hits = 0
        for draw in range(20):
            rng = np.random.default_rng(draw)
            data = {
                o: clean[o][mask] + rng.normal(0, space.outputs[o].sigma, int(mask.sum()))
                for o in found.trial.outputs
            }
            right = fit_problem(
                truth.problem(fmu, spec, space, found.trial, data),
                start=truth.values,
                global_search=False,
            )
            wrong = fit_problem(
                other.problem(fmu, spec, space, found.trial, data),
                start=other.values,
                global_search=False,
            )
            hits += chi2.sf(wrong.chi2 - right.chi2, 1) < 1e-3
        assert hits >= 18, (truth.name, hits)


def test_default_space_follows_the_study_data():
    t = np.round(np.arange(0, 8.0001, 0.2), 10)
    exp = experiment_from_arrays("d.csv", t, {"f": np.where(t > 1, 2.0, 0.0), "x": 0.1 * t})
    spec = spec_from_json(json.dumps(SPEC))
    space = default_space(Problem(builtin_fmu("msd"), [exp], spec))
    assert space.input == "f"
    assert space.families["step"]["amplitude"] == (-2.0, 2.0)
    assert space.duration == (8.0, 8.0) and space.longest_test == 8.0
    assert space.rates_hz == [pytest.approx(5.0)]
    assert space.outputs["x"].sigma == 0.005


def test_the_default_space_of_a_slowly_sampled_process_is_below_its_nyquist():
    """A record sampled every 4 s (a process): every frequency range is ordered and below the
    Nyquist frequency's half (the former 0.05 Hz floor exceeded the multisine's 0.025 Hz top)."""
    t = np.arange(0.0, 4096.0, 4.0)
    exp = experiment_from_arrays("p.csv", t, {"f": np.where(t > 100, 2.0, 0.0), "x": 1e-3 * t})
    space = default_space(Problem(builtin_fmu("msd"), [exp], spec_from_json(json.dumps(SPEC))))
    nyquist = 0.5 / 4.0
    for family in ("chirp", "multisine"):
        for name in ("f0", "f1", "f_min", "f_max"):
            if name in space.families[family]:
                low, high = space.families[family][name]
                assert 0 < low <= high <= nyquist / 2, (family, name)
