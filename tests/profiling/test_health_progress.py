"""The health check says how many runs it makes and how long they take, and can be shortened;
what it calls smooth; it reads back from what it writes, and its probes run as tasks give
the check made in one process."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
import pytest
from tests.model.quirks import build_quirk_fmu

import fmuid
from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.engine.run import open_engine
from fmuid.estimation.problem import Problem
from fmuid.estimation.result import FitResult
from fmuid.profiling.health import PROBE_STEP, SMOOTH_STEP, Health, check_health
from fmuid.progress import Progress
from fmuid.stages import make_problem


def _jitter_study(tmp_path: Path) -> tuple[Problem, FitResult]:
    """A first-order lag FMU whose outputs jitter, fitted to a clean step response."""
    fmu = build_quirk_fmu("jitter", tmp_path)
    t = np.round(np.linspace(0.0, 5.0, 26), 10)
    data = experiment_from_arrays(
        "step.csv", t, {"u": np.ones_like(t), "y": 2.0 * (1.0 - np.exp(-t))}
    )
    body = {
        "parameters": {
            "tau": {"start": 1.1, "lower": 0.5, "upper": 2.0},
            "K": {"start": 1.5, "lower": 0.5, "upper": 4.0},
        },
        "outputs": {"y": {"sigma": 0.02}},
        "global_search": False,
    }
    spec = spec_from_json(json.dumps(body))
    return make_problem(fmu, [data], spec), fmuid.fit(fmu, [data], spec)


def test_progress_and_estimate_of_a_shortened_check(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    problem, fit = _jitter_study(tmp_path)
    events: list[Progress] = []
    with caplog.at_level(logging.INFO, logger="fmuid.profiling.health"):
        health = check_health(problem, fit.z_estimate(), fit.jacobian, events.append, 3)
    total = 2 + 2 * (4 + 2 * 3)
    assert [e.done for e in events] == list(range(1, total + 1))
    assert {e.total for e in events} == {total} and {e.stage for e in events} == {"health"}
    assert events[-1].detail.endswith(" 0 s left")
    assert any(f"health check: {total} runs of the 1 experiment(s)" in m for m in caplog.messages)
    assert health.smooth and set(health.jumps) == {"tau", "K"}
    assert Health.of(health.to_dict()) == health  # as a later profile of the same point reuses it


def test_noise_at_round_off_raises_the_step_but_leaves_the_objective_smooth():
    """An error-controlled solver's noise far under any threshold needs a longer difference
    step, not the thorough profile; noise that needs a step over ``SMOOTH_STEP`` or a jump
    does."""
    assert Health(deterministic=True, reset_matches_fresh=True, diff_step=30 * PROBE_STEP).smooth
    noisy = Health(deterministic=True, reset_matches_fresh=True, diff_step=2 * SMOOTH_STEP)
    assert not noisy.smooth
    assert not Health(deterministic=True, reset_matches_fresh=None, jumps={"k": 1}).smooth
    assert not Health(deterministic=False, reset_matches_fresh=None).smooth


@pytest.mark.slow
def test_probes_run_as_tasks_give_the_check_made_here(tmp_path: Path) -> None:
    problem, fit = _jitter_study(tmp_path)
    here = check_health(problem, fit.z_estimate(), fit.jacobian)
    events: list[Progress] = []
    with open_engine(problem.model, workers=2) as engine:
        mapped = check_health(problem, fit.z_estimate(), fit.jacobian, events.append, 4, engine.map)
    assert mapped == here and here.noise_floor["tau"] > 0
    total = 2 + 2 * (4 + 2 * 4)  # the two runs at the estimate here, then every probe as tasks
    assert [(e.done, e.total) for e in events] == [(1, total), (2, total), (total, total)]
