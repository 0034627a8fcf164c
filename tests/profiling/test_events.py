"""An FMU with events (Reference-FMU BouncingBall, e and g free): the exact interval, flagged.

The bounce times move on the FMU's fixed step grid, so chi2 jumps as e and g change. The
reference profile here is brute force: for each e, chi2 minimised over g on a dense grid and
polished by bounded Brent searches in the best cells; its outermost crossings are bisected.
"""

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

import fmuid
from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.estimation import optimize
from fmuid.estimation.optimize import fit_problem, make_fit_result
from fmuid.estimation.result import Cost
from fmuid.model.simulator import Simulator
from fmuid.profiling import engine
from fmuid.profiling.engine import profile_problem
from fmuid.profiling.intervals import NOISE_PREFIX
from fmuid.profiling.walk import WalkOptions
from fmuid.stages import make_problem

FMU = Path(__file__).parents[3] / "shared" / "reference-fmus" / "fmi2" / "BouncingBall.fmu"

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(not FMU.exists(), reason=f"{FMU} is absent (Reference-FMUs not shared)"),
]

SIGMA = 0.05


def bouncing_ball_case():
    t = np.round(np.arange(0.0, 3.0 + 1e-9, 0.05), 10)
    y = Simulator(FMU).simulate({"e": 0.7, "g": -9.81}, t[:1], {}, t, ["h"])[:, 0]
    noisy = y + np.random.default_rng(1).normal(0.0, SIGMA, t.size)
    spec = spec_from_json(
        json.dumps(
            {
                "parameters": {
                    "e": {"start": 0.75, "lower": 0.5, "upper": 1.0},
                    "g": {"start": -9.0, "lower": -12.0, "upper": -8.0},
                },
                "inputs": [],
                "outputs": {"h": {"sigma": SIGMA}},
                "global_search": False,
            }
        )
    )
    return experiment_from_arrays("bounce.csv", t, {"h": noisy}), spec


def profile_e(problem, e):
    """min over g of chi2 at e: a dense grid, then bounded Brent in the three best cells."""
    grid = np.linspace(-12.0, -8.0, 81)

    def chi2(g):
        return problem.chi2(problem.to_z({"e": e, "g": g}))

    values = np.array([chi2(g) for g in grid])
    best = float(values.min())
    for k in np.argsort(values)[:3]:
        a, b = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
        res = minimize_scalar(chi2, bounds=(a, b), method="bounded", options={"xatol": 1e-6})
        best = min(best, float(res.fun))
    return best


def crossing(problem, e_hat, chi2_hat, threshold, direction, half):
    """Outermost crossing within twice ``half`` of e_hat (steps of a twentieth of ``half``),
    then bisection: chi2 jumps, so the profile may cross back under past its first crossing."""
    steps = e_hat + direction * half * np.arange(0, 41) / 20
    under = [k for k, e in enumerate(steps) if profile_e(problem, e) - chi2_hat < threshold]
    inner, outer = steps[under[-1]], steps[min(under[-1] + 1, steps.size - 1)]
    while abs(outer - inner) > 1e-4 * half:
        mid = 0.5 * (inner + outer)
        if profile_e(problem, mid) - chi2_hat < threshold:
            inner = mid
        else:
            outer = mid
    return 0.5 * (inner + outer)


def test_bouncing_ball_exact_interval_and_non_smoothness_reported():
    experiment, spec = bouncing_ball_case()
    result = fmuid.profile(FMU, [experiment], spec, workers=2)
    health = result.checks["health"]
    assert not health["smooth"]
    assert sum(health["jumps"].values()) > 0
    p = result.parameters["e"]
    assert p.quality.jumps > 0
    assert p.status_reason.startswith(NOISE_PREFIX)  # the jumps could move its ends
    problem = make_problem(FMU, [experiment], spec)
    e_hat = p.estimate
    chi2_hat = profile_e(problem, e_hat)
    assert result.chi2 <= chi2_hat + 1e-6 * chi2_hat
    thr = result.thresholds["simultaneous"]
    lo, hi = p.ci_simultaneous
    assert lo is not None and hi is not None
    for end, direction in ((lo, -1), (hi, 1)):
        half = abs(end - e_hat)
        exact = crossing(problem, e_hat, chi2_hat, thr, direction, half)
        assert abs(end - exact) <= 0.05 * abs(exact - e_hat), (direction, end, exact)
    assert lo < 0.7 < hi


def test_a_profile_that_is_not_thorough_polishes_no_re_fit(monkeypatch):
    """The diagnosis's setting: the jumps raise the difference step, and no re-fit of a walk
    is polished by Powell's method (a minute per re-fit of a slow FMU), only the optimum once
    before the walks; the interval still holds e."""
    experiment, spec = bouncing_ball_case()
    problem = make_problem(FMU, [experiment], spec)
    fit = fit_problem(problem)
    polished = []
    minimize = optimize.minimize

    def counted_polish(*args, **kwargs):
        polished.append(kwargs.get("method"))
        return minimize(*args, **kwargs)

    monkeypatch.setattr(optimize, "minimize", counted_polish)
    options = WalkOptions(thorough=False)
    result = profile_problem(problem, fit, workers=1, options=options)
    assert not result.checks["health"]["smooth"]
    assert len(polished) == 1
    lo, hi = result.parameters["e"].ci_simultaneous
    assert lo is not None and hi is not None and lo < 0.7 < hi


def test_a_fit_short_of_the_minimum_is_polished_once_before_the_walks():
    """A fit short of the minimum of a non-smooth objective is refined once, polished, before
    any walk: the profiles start from the lower optimum instead of each finding it and
    restarting every profile (the diagnosis's setting, whose re-fits are not polished)."""
    experiment, spec = bouncing_ball_case()
    problem = make_problem(FMU, [experiment], spec)
    fit = fit_problem(problem)
    sd = fit.fisher_sd_z()
    z = fit.z_estimate() + np.array([sd["e"], -sd["g"]])
    short = make_fit_result(problem, z, problem.chi2(z), fit.jacobian, "short", False, Cost(0, 0))
    assert short.chi2 > fit.chi2 + 1.0
    options = WalkOptions(thorough=False)
    result = profile_problem(problem, short, only=["e", "g"], workers=1, options=options)
    assert not result.checks["health"]["smooth"]
    assert result.fit.chi2 < fit.chi2 + 0.1
    assert not result.better_optimum_found


def _short_of_the_minimum(monkeypatch, jump):
    """BouncingBall's problem and a fit left about 1 short of its minimum (its refinement before
    the walks skipped), the health check's jumps of chi2 set to ``jump``."""
    experiment, spec = bouncing_ball_case()
    problem = make_problem(FMU, [experiment], spec)
    fit = fit_problem(problem)
    z = fit.z_estimate() + np.array([0.5 * fit.fisher_sd_z()["e"], 0.0])
    short = make_fit_result(problem, z, problem.chi2(z), fit.jacobian, "short", False, Cost(0, 0))
    assert 0.1 < short.chi2 - fit.chi2 < 4.0
    check = engine.check_health

    def jumpy(*args, **kwargs):
        health = check(*args, **kwargs)
        return replace(health, chi2_noise={name: jump for name in health.chi2_noise})

    monkeypatch.setattr(engine, "check_health", jumpy)
    monkeypatch.setattr(engine, "descend", lambda problem, fit, settle: fit)
    return problem, short


@pytest.mark.parametrize(("jump", "restarts"), [(5.0, False), (1e-3, True)])
def test_a_lower_point_within_the_jumps_of_chi2_restarts_nothing(monkeypatch, jump, restarts):
    """On a non-smooth objective a walk's chi2 below the optimum by less than the jumps the
    health check measured is not a better optimum (no restart of every profile); by more, it
    is. The optimum is left short by about 1 (its refinement before the walks is skipped)."""
    problem, short = _short_of_the_minimum(monkeypatch, jump)
    options = WalkOptions(thorough=False)
    result = profile_problem(problem, short, only=["e"], workers=1, options=options)
    assert result.better_optimum_found is restarts


def test_a_restart_is_the_same_in_this_process_and_in_two_workers(monkeypatch):
    """A pass that finds a point below the optimum stops at the first branch, in order, that
    found one; the restart, and so every profile, is the same whatever the workers' timing."""
    problem, short = _short_of_the_minimum(monkeypatch, 1e-3)
    passes: dict[int, list[list[bool]]] = {}

    def recorded(workers):
        def walk_all(*args, **kwargs):
            branches = walk(*args, **kwargs)
            if kwargs.get("again") is None:  # not the cross-check's branches settled again
                passes.setdefault(workers, []).append([b.better is not None for b in branches])
            return branches

        return walk_all

    walk = engine.walk_all
    options = WalkOptions(thorough=False)
    results = []
    for workers in (1, 2):
        monkeypatch.setattr(engine, "walk_all", recorded(workers))
        results.append(
            profile_problem(problem, short, only=["e", "g"], workers=workers, options=options)
        )
    here, pooled = results
    assert here.better_optimum_found and pooled.better_optimum_found
    assert passes[1] == passes[2]
    first = passes[1][0]
    assert first[-1] and not any(first[:-1])  # stopped at the first branch with a lower point
    assert len(first) < 4  # the branches after it were not walked
    assert passes[1][-1] == [False] * 4  # the last pass walked every branch
    assert pooled.fit.chi2 == here.fit.chi2
    assert pooled.checks["cross"] == here.checks["cross"]
    for name, p in here.parameters.items():
        assert pooled.parameters[name].ci_simultaneous == p.ci_simultaneous
