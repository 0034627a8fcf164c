"""Profiles of a non-smooth chi2: a test FMU whose time constant carries a deterministic jitter
(piecewise constant over cells of tau, as a variable-step solver's output jumps), checked
against a brute-force profile (the gain re-optimised in closed form on a fine grid of tau)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from tests.model.quirks import build_quirk_fmu

import fmuid
from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.model.simulator import Simulator
from fmuid.profiling.ends import bracket
from fmuid.profiling.intervals import NOISE_PREFIX, profile_noise
from fmuid.profiling.points import WalkPoint
from fmuid.profiling.result import IDENTIFIABLE, PRACTICALLY_NON_IDENTIFIABLE

SIGMA = 0.02
TIME = np.round(np.linspace(0.0, 5.0, 51), 10)
JITTER = {"jitter": 0.003, "cell": 0.002}


@pytest.fixture(scope="module")
def jitter_fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build_quirk_fmu("jitter", tmp_path_factory.mktemp("jitter"))


def _data() -> np.ndarray:
    """A step response of K = 2, tau = 1 (closed form) with seeded noise."""
    rng = np.random.default_rng(1)
    return 2.0 * (1.0 - np.exp(-TIME)) + SIGMA * rng.normal(size=TIME.size)


def brute_force_profile(fmu: Path, taus: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Chi2 of the best gain at each tau: y is linear in K (zero start), so K is closed form."""
    sim = Simulator(fmu)
    try:
        out = []
        for tau in taus:
            g = sim.simulate(
                {"tau": float(tau), "K": 1.0, **JITTER},
                np.array([0.0, 5.0]),
                {"u": np.ones(2)},
                TIME,
                ["y"],
            )[:, 0]
            k = (g @ y) / (g @ g)
            out.append(float(np.sum(((y - k * g) / SIGMA) ** 2)))
    finally:
        sim.close()
    return np.array(out)


def outermost(taus: np.ndarray, chi2: np.ndarray, level: float, side: int, centre: float) -> float:
    """The farthest tau on one side whose profile is still at or under ``level``."""
    inside = (chi2 <= level) & (np.sign(taus - centre) == side)
    return float(taus[inside][np.argmax(np.abs(taus[inside] - centre))])


@pytest.mark.slow
def test_jagged_profile_reports_the_outermost_crossing_and_the_noise(jitter_fmu: Path) -> None:
    y = _data()
    data = experiment_from_arrays("step.csv", TIME, {"u": np.ones_like(TIME), "y": y})
    body = {
        "parameters": {
            "tau": {"start": 1.1, "lower": 0.5, "upper": 2.0},
            "K": {"start": 1.5, "lower": 0.5, "upper": 4.0},
        },
        "fixed": JITTER,
        "outputs": {"y": {"sigma": SIGMA}},
        "global_search": False,
    }
    result = fmuid.profile(jitter_fmu, [data], spec_from_json(json.dumps(body)), workers=1)
    tau = result.parameters["tau"]
    assert result.checks["health"]["smooth"] is False
    assert tau.status == PRACTICALLY_NON_IDENTIFIABLE
    assert tau.status_reason.startswith(NOISE_PREFIX)
    assert result.parameters["K"].status == IDENTIFIABLE  # K's profile re-fits tau in a cell
    lo, hi = tau.ci_simultaneous
    assert lo is not None and hi is not None
    half = max(tau.estimate - lo, hi - tau.estimate)
    taus = np.linspace(tau.estimate - 2.0 * half, tau.estimate + 2.0 * half, 801)
    chi2 = brute_force_profile(jitter_fmu, taus, y)
    noise = float(re.search(r"chi2 jumps by up to ([0-9.e+-]+)", tau.status_reason)[1])
    assert noise > 0.1 * result.thresholds["pointwise"]
    grid = taus[1] - taus[0]
    for kind in ("simultaneous", "pointwise"):
        threshold = result.thresholds[kind]
        level = result.fit.chi2 + threshold
        for end, side in zip(getattr(tau, f"ci_{kind}"), (-1, 1), strict=True):
            assert end is not None
            inside = np.sign(taus - tau.estimate) == side
            over = inside & (chi2 > level)
            first = taus[over][np.argmin(np.abs(taus[over] - tau.estimate))]
            reach = outermost(taus, chi2, level, side, tau.estimate)
            # never inside the first crossing; the outermost one within the shift the label
            # states (a jump of the noise floor at a parabola's slope there)
            assert side * (end - first) >= -2 * grid
            shift = noise / (2.0 * threshold) * abs(end - tau.estimate)
            assert abs(end - reach) <= shift + 2 * grid


def test_outermost_bracket_and_profile_noise_on_a_stepped_parabola() -> None:
    z = np.linspace(0.0, 2.0, 21)
    chi2 = 10.0 + z**2 - 0.6 * ((z > 1.05) & (z < 1.35))  # under a rise of 1 at 1.1 and 1.2
    side = [WalkPoint(np.array([x]), c) for x, c in zip(z, chi2, strict=True)]
    first, last = bracket(side, 0, 10.0, 1.0), bracket(side, 0, 10.0, 1.0, outermost=True)
    assert first is not None and last is not None
    assert float(first[1].z[0]) == pytest.approx(1.0)
    assert float(last[0].z[0]) == pytest.approx(1.2) and float(last[1].z[0]) == pytest.approx(1.3)
    assert profile_noise(z, 10.0 + z**2, 10.0) < 1e-12
    one = 10.0 + z**2 - 0.6 * np.isclose(z, 1.1)  # a single point off: exactly its jump
    assert profile_noise(z, one, 10.0) == pytest.approx(0.6, rel=1e-9)
