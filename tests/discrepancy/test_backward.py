"""The backward half of forward selection: an effect the final model does without is dropped.

The data come from scipy's solution of m x'' + b x' + k x = f + 0.05 (an input offset only, not
from the FMU). An output bias fitted first stands in for the offset at steady state; once the
offset is added on top, the bias is not needed and is dropped, while the offset is kept. With
the offset alone, nothing is dropped.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.discrepancy.catalogue import study_catalogue
from fmuid.discrepancy.forward import Step, _backward
from fmuid.discrepancy.scan import CandidateFit, Scanner
from fmuid.estimation.optimize import FitOptions, fit_problem, jacobian
from fmuid.estimation.study import make_problem

M, K, B, OFFSET, SIGMA, ALPHA = 1.1, 4.4, 1.6, 0.05, 0.005, 0.01


def _record():  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 30.0, 0.05)
    freqs, phases = rng.uniform(0.1, 1.5, 8), rng.uniform(0.0, 2 * np.pi, 8)
    u = 0.6 * sum(np.sin(2 * np.pi * f * t + p) for f, p in zip(freqs, phases))

    def rhs(tt: float, s: np.ndarray) -> list[float]:
        x, v = s
        return [v, (np.interp(tt, t, u) + OFFSET - B * v - K * x) / M]

    sol = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-10, atol=1e-12, max_step=0.01)
    return experiment_from_arrays(
        "train.csv", t, {"f": u, "x": sol.y[0] + rng.normal(0, SIGMA, t.size)}
    )


def _added(scanner: Scanner, effect, stage: int) -> CandidateFit:  # type: ignore[no-untyped-def]
    return scanner.fit(scanner.screen(effect, stage), FitOptions())


@pytest.mark.slow
def test_a_stand_in_is_dropped_and_the_needed_effect_kept(msd_fmu: Path) -> None:
    spec = spec_from_json(
        '{"parameters": {"m": {"start": 1, "lower": 0.1, "upper": 10},'
        ' "k": {"start": 4, "lower": 0.1, "upper": 20}, "b": {"start": 1, "lower": 0.1,'
        ' "upper": 10}}, "inputs": ["f"], "outputs": {"x": {"sigma": 0.005}}, "seed": 0,'
        ' "global_search": false}'
    )
    problem = make_problem(msd_fmu, [_record()], spec)
    fit = fit_problem(problem, global_search=False)
    by_name = {c.effect: c for c in study_catalogue(problem, fit.estimates)}
    z = problem.to_z(fit.estimates)
    base = Scanner(problem, z, jacobian(problem, z))
    bias = _added(base, by_name["output_bias"], 1)
    on_bias = Scanner(bias.problem, bias.z, jacobian(bias.problem, bias.z))
    both = _added(on_bias, by_name["input_offset"], 2)
    assert bias.chi2 < base.chi2 - 10  # the bias stood in for the offset
    steps = [Step(bias, base.chi2, 0.0), Step(both, bias.chi2, 0.0)]

    kept = _backward(base, steps, FitOptions(), ALPHA)

    assert [s.effect.effect for s in kept] == ["input_offset"]
    (step,) = kept
    assert step.chi2_before == base.chi2
    assert step.fit.chi2 <= both.chi2 + 3.0  # the offset alone fits as well as both
    assert step.fit.problem.from_z(step.fit.z)[by_name["input_offset"].names[0]] == pytest.approx(
        OFFSET, rel=0.1
    )
    alone = _added(base, by_name["input_offset"], 1)
    assert _backward(base, [Step(alone, base.chi2, 0.0)], FitOptions(), ALPHA)[0].fit is alone
