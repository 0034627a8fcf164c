"""The health check says how many runs it makes and how long they take, and can be shortened;
what it calls smooth; it reads back from what it writes."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
import pytest
from tests.model.quirks import build_quirk_fmu

import fmuid
from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.profiling.health import PROBE_STEP, SMOOTH_STEP, Health, check_health
from fmuid.progress import Progress
from fmuid.stages import make_problem


def test_progress_and_estimate_of_a_shortened_check(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
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
    fit = fmuid.fit(fmu, [data], spec)
    problem = make_problem(fmu, [data], spec)
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
