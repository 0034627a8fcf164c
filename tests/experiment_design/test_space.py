"""The experiment space file: validation names the field at fault; the signals are as stated."""

import json

import numpy as np
import pytest

from design_cases import MSD_SPACE, space_of
from fmuid.errors import SpecError
from fmuid.experiment_design.signals import Trial, input_signal, output_times, sample_trials
from fmuid.experiment_design.space import check_space, load_space


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"families": {"sawtooth": {}}}, "families: unknown family 'sawtooth'"),
        ({"families": {"step": {"amplitude": 1}}}, "missing: time"),
        ({"families": {"step": {"amplitude": [2, 1], "time": 1}}}, "step.amplitude lower 2.0"),
        ({"duration": [4, 9]}, "at most longest_test"),
        ({"base_outputs": ["y"]}, "base_outputs: ['y'] are not among outputs"),
        ({"outputs": {"x": {"sigma": -1}}}, "outputs.x.sigma"),
        ({"rates_hz": []}, "rates_hz"),
        ({"colour": "red"}, "colour"),
    ],
)
def test_bad_space_names_the_field(changes, message):
    with pytest.raises(SpecError, match=message.replace("[", r"\[").replace("]", r"\]")):
        space_of(**changes)


def test_space_against_fmu_names_unknown_variables(tmp_path):
    space = space_of(input="u", fixed={"speed": [1, 2]})
    with pytest.raises(SpecError) as err:
        check_space(space, ["f"], ["x", "v"], {"m": 1, "k": 1, "b": 1}, ["m", "k", "b"])
    assert "input: 'u' is not an FMU input" in str(err.value)
    assert "fixed: 'speed' is not an FMU parameter" in str(err.value)
    path = tmp_path / "E.json"
    path.write_text(json.dumps(MSD_SPACE)[:-2])
    with pytest.raises(SpecError, match="E.json: invalid JSON at line 1"):
        load_space(path)


def test_signals_follow_their_definitions():
    ramp = Trial("ramp", {"amplitude": 0.17452, "start": 1.0, "rise": 0.5}, 10.0, 5.0, ("x",))
    t, u = input_signal(ramp)
    assert np.interp([0.5, 1.25, 1.5, 9.0], t, u) == pytest.approx([0, 0.08726, 0.17452, 0.17452])
    chirp = Trial("chirp", {"f0": 0.1, "f1": 0.5, "amplitude": 0.17453}, 10.0, 5.0, ("x",))
    t, u = input_signal(chirp)
    # the thesis's chirp: 0.17453 sin(2 pi (0.1 t + 0.02 t^2))
    assert u == pytest.approx(0.17453 * np.sin(2 * np.pi * (0.1 * t + 0.02 * t**2)), abs=1e-12)
    multi = Trial("multisine", {"f_min": 0.1, "f_max": 1, "amplitude": 2, "tones": 4}, 8, 5, ("x",))
    assert np.max(np.abs(input_signal(multi)[1])) == pytest.approx(2.0)
    # every family starts from rest: a test begins in straight driving (or at equilibrium)
    dlc = Trial("double_lane_change", {"duration": 2.0, "amplitude": 0.1}, 10.0, 5.0, ("x",))
    step = Trial("step", {"amplitude": 1.0, "time": 2.0}, 10.0, 5.0, ("x",))
    for trial in (ramp, chirp, multi, dlc, step):
        assert input_signal(trial)[1][0] == 0.0, trial.family
    assert output_times(ramp)[[0, 1, -1]] == pytest.approx([0.0, 0.2, 10.0])


def test_sampling_is_seeded_and_inside_the_bounds():
    space = space_of()
    a = sample_trials(space, np.random.default_rng(1))
    b = sample_trials(space, np.random.default_rng(1))
    assert [t.settings for t in a] == [t.settings for t in b]
    assert len(a) == 2 * 4 * 2
    for t in a:
        for name, value in t.settings.items():
            lo, hi = space.families[t.family][name]
            assert lo <= value <= hi
        assert 4.0 <= t.duration <= 8.0


def test_longest_test_defaults_to_the_longest_duration(tmp_path):
    given = {k: v for k, v in MSD_SPACE.items() if k != "longest_test"}
    path = tmp_path / "E.json"
    path.write_text(json.dumps({**given, "duration": [3, 7.5]}))
    assert load_space(path).longest_test == 7.5
    path.write_text(json.dumps({**given, "duration": 6}))
    assert load_space(path).longest_test == 6.0
