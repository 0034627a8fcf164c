"""The backward half of forward selection: an effect the final model does without is dropped.

The data come from scipy's solution of m x'' + b x' + k x = f + 0.05 (an input offset only, not
from the FMU). An output bias fitted first stands in for the offset at steady state; once the
offset is added on top, the bias is not needed and is dropped, while the offset is kept. With
the offset alone, nothing is dropped.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from tests.discrepancy.msd_truth import SPEC, msd_record

from fmuid.discrepancy.catalogue import study_catalogue
from fmuid.discrepancy.effects import Effect
from fmuid.discrepancy.forward import Step, _backward
from fmuid.discrepancy.scan import CandidateFit, Scanner
from fmuid.estimation.optimize import FitOptions, fit_problem, jacobian
from fmuid.estimation.study import make_problem

OFFSET, ALPHA = 0.05, 0.01


def _added(scanner: Scanner, effect: Effect, stage: int) -> CandidateFit:
    return scanner.fit(scanner.screen(effect, stage), FitOptions())


@pytest.mark.slow
def test_a_stand_in_is_dropped_and_the_needed_effect_kept(msd_fmu: Path) -> None:
    problem = make_problem(msd_fmu, [msd_record("train.csv", 3, OFFSET, 0.0)], SPEC)
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
    offset = step.fit.problem.from_z(step.fit.z)[by_name["input_offset"].names[0]]
    assert offset == pytest.approx(OFFSET, rel=0.1)
    alone = _added(base, by_name["input_offset"], 1)
    assert _backward(base, [Step(alone, base.chi2, 0.0)], FitOptions(), ALPHA)[0].fit is alone
