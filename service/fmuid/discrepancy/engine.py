"""Diagnose a model mismatch in small steps: locate, scan, decide, refine, profile, explain.

1. **Locate** (:mod:`.locate`): fit the base model, test its weighted residuals and whether
   separate per-experiment fits disagree.
2. **Scan** (:mod:`.scan`): score every catalogue candidate (:mod:`.catalogue`) by its
   likelihood-ratio statistic against the base fit; the scan always runs, because a concealed
   effect leaves the residuals looking like noise. The base fit is re-checked from the best
   candidate's base parameters (a lower base optimum would otherwise pass for an effect).
3. **Decide** (:mod:`.decide`): one weighted Holm family at the false-alarm level fixed in
   advance (0.5 %) over the scan (min-P over the candidates, boundary-aware nulls), the
   agreement test and the residual tests. A candidate is named when it is significant after the
   scan's adjustment and the augmented model's residuals pass; candidates that explain the
   data equally well are listed (Vuong's test, or equal predictions).
4. **Add** (:mod:`.forward`): effects one after another while a round's best candidate is
   significant on top of the model so far; when none is, the mismatch is ``unexplained`` and
   a generic correction (:mod:`.correction`) describes it (also the misfit a named model
   leaves, when its residuals still fail).
5. **Profile**: the added parameters' intervals, and the original parameters' intervals and
   labels before and after the augmentation (:mod:`.absorb`); on a tie, the test like the
   data's that would settle it (:mod:`.settle`); the fine grid's coupling error; each model
   simulated on held-out data (:mod:`.validate`).
6. **Explain** (:mod:`.explain`), and where in the outputs' range the misfit sat
   (:mod:`.levels`).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

from fmuid.data import Experiment
from fmuid.discrepancy import decide, explain, locate
from fmuid.discrepancy import residual_tests as rt
from fmuid.discrepancy.absorb import absorbed
from fmuid.discrepancy.catalogue import study_catalogue
from fmuid.discrepancy.correction import arx_correction
from fmuid.discrepancy.coupling import coupling_error, step_scale
from fmuid.discrepancy.forward import effect_steps, forward
from fmuid.discrepancy.generic import describe, generic_rival, generic_test, local_model
from fmuid.discrepancy.levels import level_location
from fmuid.discrepancy.result import Diagnosis
from fmuid.discrepancy.run import Run, added_estimates, fit_of, scan_base, score, tie_intervals
from fmuid.discrepancy.scan import CandidateFit, augmented
from fmuid.discrepancy.schema import AbsorbedOut, CorrectionOut, TieOut
from fmuid.discrepancy.settle import settles, settling_or_reason
from fmuid.discrepancy.tasks import candidate_pool
from fmuid.discrepancy.validate import validation
from fmuid.engine.count import counting
from fmuid.estimation.optimize import (
    FitOptions,
    fit_problem,
    safe_residuals,
)
from fmuid.estimation.problem import Problem
from fmuid.estimation.result import FitResult
from fmuid.estimation.series import residual_series as fit_series
from fmuid.experiment_design.schema import DiscriminatingOut
from fmuid.profiling.checks import CheckOptions
from fmuid.profiling.engine import profile_problem
from fmuid.profiling.health import Health
from fmuid.profiling.walk import WalkOptions
from fmuid.progress import ProgressCallback

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class DiagnoseOptions:
    """Settings of a diagnosis.

    Attributes
    ----------
    alpha
        Family-wise false-alarm level of the mismatch decision and of naming an effect.
    ci_confidence
        Level of the pointwise profile-likelihood interval of the added parameters.
    screen_level
        Candidates whose linearised screen p-value is below this are fitted in full.
    min_fits
        At least this many of the strongest candidates are fitted in full.
    fit
        Trust-region settings of a candidate's full fit.
    agreement_nfev
        Cap on residual evaluations of each single-experiment fit of the agreement test.
    absorbed
        Re-profile the original parameters before and after the augmentation.
    discriminate
        On a tie, search the tests like the data's for one that would settle it.
    workers
        Processes for the profile branches (1: in this process).
    walk
        Profile walk settings: the walk stops at the simultaneous threshold, past the
        pointwise crossing that gives the intervals; a non-smooth objective gets larger
        difference steps, not the thorough profile of ``fmuid profile``
        (:attr:`~fmuid.profiling.walk.WalkOptions.thorough`); the checks of its ends re-fit
        from other valleys and diverse starts with at most 40 evaluations (150 in ``fmuid
        profile``) and re-walk a branch once (3): after a restart each end is re-fitted from
        every earlier optimum, and on a slow FMU with a clipped level each such re-fit cost
        minutes.

    """

    alpha: float = rt.FALSE_ALARM
    ci_confidence: float = 0.95
    screen_level: float = 0.05
    min_fits: int = 2
    fit: FitOptions = FitOptions(ftol=1e-9, xtol=1e-9, gtol=1e-9, max_nfev=60)
    agreement_nfev: int = 20
    absorbed: bool = True
    discriminate: bool = True
    workers: int = 1
    walk: WalkOptions = WalkOptions(  # noqa: B008 (frozen value)
        rise_per_step=0.15,
        margin=0.0,
        max_points=12,
        refit=FitOptions(ftol=1e-7, xtol=1e-7, gtol=1e-7, max_nfev=20),
        thorough=False,
        checks=CheckOptions(  # noqa: B008 (frozen value)
            max_rewalks=1, refit=FitOptions(ftol=1e-6, xtol=1e-6, gtol=1e-6, max_nfev=40)
        ),
    )


def _tests_after(problem: Problem, fit: FitResult, seed: int) -> list[rt.TestResult]:
    """Residual tests of an augmented fit and the generic error-model test on top of it."""
    tests = locate.residual_tests(problem, fit)
    z = fit.z_estimate()
    model = local_model(problem, z, fit.jacobian)
    generic, _ = generic_test(problem, safe_residuals(problem, z), model, seed)
    return [*tests, generic] if generic else tests


def _correction(
    problem: Problem, values: dict[str, float], generic: rt.TestResult | None, pole: Any
) -> dict[str, Any]:
    """Return the generic ARX correction of a fit's residuals and the input-driven model."""
    correction = arx_correction(locate.residual_series(problem, values))
    if generic is not None and pole is not None:
        correction["input_error_model"] = {
            "model": describe(pole),
            "pole_hz": pole.pole_hz,
            "chi2_drop": generic.statistic,
            "df": generic.df,
            "p_value": generic.p_value,
        }
    return correction


def refit(problem: Problem, fit: FitResult) -> FitResult:
    """Refine a fit of the study on the problem the diagnosis simulates (its fine input grid)."""
    return fit_problem(problem, start=fit.estimates, global_search=False)


def diagnose_problem(
    problem: Problem,
    *,
    fit: FitResult | None = None,
    options: DiagnoseOptions = DiagnoseOptions(),
    progress: ProgressCallback | None = None,
    test_data: Sequence[Experiment] = (),
    executor: Any = None,
) -> Diagnosis:
    """Diagnose the model mismatch of an estimation problem (see the module docstring).

    Parameters
    ----------
    problem
        The base study (its predictor must be the plain FMU predictor).
    fit
        Its best fit; by default fitted here (``spec.global_search``, ``spec.seed``).
    options
        Levels and effort.
    progress
        Receives ``Progress("diagnose", done, total, detail)`` after every stage.
    test_data
        Held-out experiments: the base and every augmented model are simulated on them from
        their fitted parameters (``validation`` in the result).
    executor
        A ``dask.distributed.Client``: the candidate scan and the profiles run as tasks on its
        workers instead of ``options.workers`` local processes.

    Returns
    -------
    Diagnosis

    """
    common = augmented(problem, [])
    if common.predictor is not problem.predictor:
        problem, fit = common, None if fit is None else refit(common, fit)
    with candidate_pool(problem, options.workers, executor) as engine, counting() as count:
        run = Run(problem, options, progress, count, engine.map, engine)
        return _diagnose(run, fit, test_data)


def _diagnose(run: Run, fit: FitResult | None, test_data: Sequence[Experiment]) -> Diagnosis:
    """Diagnose the run's problem (:func:`diagnose_problem`'s steps)."""
    problem, opts = run.problem, run.opts
    if fit is None:
        spec = problem.spec
        fit = fit_problem(
            problem, global_search=spec.global_search, seed=spec.seed, mapper=run.mapper
        )
    cands = study_catalogue(problem, fit.estimates)
    run.total = 3 * len(cands) + 5
    run.lap("base fit")
    # 1-2. locate and scan
    fit, scanner, fits, adjusted = scan_base(run, fit, cands)
    run.lap("scan")
    tests_before = locate.residual_tests(problem, fit)
    agreement = locate.experiments_disagree(problem, fit, opts.agreement_nfev)
    model = local_model(problem, scanner.z, scanner.jac)
    generic, pole = generic_test(problem, scanner.r0, model, problem.spec.seed)
    run.report("residual tests, the experiments' agreement and the generic error model")
    k_best = int(np.argmin(adjusted))
    scan_test = rt.TestResult(
        "catalogue_scan", None, None, adjusted[k_best], fits[k_best].statistic, None
    )
    family = [*tests_before, *(t for t in (agreement, generic) if t), scan_test]
    # 3. decide
    evidence = decide.weighted_holm(decide.family_weights(family), opts.alpha)
    where, found = locate.location(problem, fit, [t for t in evidence if t.output])
    base_series = fit_series(problem, fit.estimates)
    where["levels"] = level_location(base_series, opts.alpha)
    bic_before = fit.chi2 + problem.n_free * float(np.log(fit.n_data))
    base_model = [(problem, dict(fit.estimates))]
    common: dict[str, Any] = {
        "false_alarm": opts.alpha,
        "tests_before": tuple(family),
        "location": where,
        "windows": tuple(found),
        "evidence": tuple(evidence),
        "chi2_before": fit.chi2,
        "n_data": fit.n_data,
        "bic_before": bic_before,
        "parameters_before": dict(fit.estimates),
        "fmu": {"sha256": fit.fmu_sha256, "model_name": fit.model_name},
        "scan_p_value": scan_test.p_value,
        "units": dict(fit.units),
    }
    run.lap("tests")
    if not evidence:
        checked = validation(base_model, test_data)
        cost, stages = run.finish("validation")
        return Diagnosis(
            mismatch=False,
            tests_after=tuple(tests_before),
            effect=None,
            description=explain.no_mismatch(opts.alpha, scan_test.p_value),
            candidates=tuple(score(f, a) for f, a in zip(fits, adjusted)),
            added_parameters={},
            chi2_after=fit.chi2,
            lrt_p_value=None,
            bic_after=bic_before,
            parameters_after=dict(fit.estimates),
            validation=tuple(checked),
            cost=cost,
            stages=stages,
            **common,
        )
    # 4. add effects while a round's best candidate is significant
    seed_after = problem.spec.seed + 1

    def misfit_left(f: CandidateFit) -> bool:
        fitted = fit_of(f.problem, f.z, f.chi2)
        return bool(rt.holm(_tests_after(f.problem, fitted, seed_after), opts.alpha))

    steps, scored = forward(
        scanner, (fits, adjusted), cands, run.scan_round, opts.alpha, opts.fit, misfit_left
    )
    scores = [score(f, a) for f, a in scored]
    if not steps:
        run.lap("forward selection")
        correction = _correction(problem, fit.estimates, generic, pole)
        run.report("generic correction")
        checked = validation(base_model, test_data)
        cost, stages = run.finish("validation")
        worst = min(tests_before, key=lambda t: t.p_value) if tests_before else None
        return Diagnosis(
            mismatch=True,
            tests_after=tuple(tests_before),
            effect="unexplained",
            description=explain.unexplained(scores[0], worst, correction, where),
            candidates=tuple(scores),
            added_parameters={},
            chi2_after=fit.chi2,
            lrt_p_value=scores[0].p_value,
            bic_after=bic_before,
            parameters_after=dict(fit.estimates),
            generic_correction=CorrectionOut.model_validate(correction),
            validation=tuple(checked),
            cost=cost,
            stages=stages,
            **common,
        )
    best = steps[0].fit
    applied = [s.effect for s in steps]
    aug, z = steps[-1].fit.problem, steps[-1].fit.z
    final_fit = fit_of(aug, z, steps[-1].fit.chi2)
    tests_after = _tests_after(aug, final_fit, seed_after)
    run.report("tests of the augmented model")
    run.lap("forward selection")
    # 5. profile the added parameters, then the original ones before and after
    added = [p for c in applied for p in c.parameters]
    prof = profile_problem(
        aug,
        final_fit,
        only=[p.name for p in added],
        workers=opts.workers,
        options=opts.walk,
        confidence=opts.ci_confidence,
        executor=run.executor,
    )
    same = np.array_equal(prof.fit.z_estimate(), final_fit.z_estimate())
    final_fit, health = prof.fit, Health.of(prof.checks["health"]) if same else None
    estimates = added_estimates(prof, added, opts.ci_confidence)
    run.report("profiles of the added parameters")
    run.lap("profiles")
    absorbed_by: dict[str, object] = {}
    if opts.absorbed:
        at_study = augmented(problem, applied, step_scale(aug))
        absorbed_by = absorbed(
            problem, fit, at_study, final_fit, opts.workers, opts.walk, run.executor, health
        )
        run.report("profiles of the original parameters before and after")
        run.lap("absorbed")
    common["location"] = {
        **locate.effect_location(
            locate.residual_series(problem, fit.estimates),
            locate.residual_series(aug, final_fit.estimates),
        ),
        "levels": where["levels"],
    }
    rivals = [f for f, a in zip(fits, adjusted) if a <= opts.alpha]
    ties = decide.ties(best, rivals) if len(applied) == 1 else []
    tied = [{**t.to_dict(), "intervals": tie_intervals(run, t.fit)} for t in ties]
    tests, no_test = (
        settling_or_reason(problem, best, ties, run.mapper) if opts.discriminate else ([], "")
    )
    for entry, test in zip(tied, tests):
        entry["expected_separation"] = round(test.expected_chi2, 4)
    rival = None
    if len(applied) == 1 and pole is not None:
        rival = generic_rival(best, scanner.r0, pole, model, problem.n_free)
    proposal = max(filter(settles, tests), key=lambda d: d.expected_chi2, default=None)
    if tests:
        run.report("tests that would settle the ties")
    run.lap("ties")
    coupling = coupling_error(aug, final_fit.estimates)
    models = [*base_model, *((s.fit.problem, s.fit.problem.from_z(s.fit.z)) for s in steps[:-1])]
    checked = validation([*models, (aug, dict(final_fit.estimates))], test_data)
    run.report("coupling check and held-out validation")
    lrt = float(stats.chi2.sf(max(fit.chi2 - final_fit.chi2, 0.0), len(added)))
    concealed = not rt.holm(tests_before, opts.alpha)
    residuals_pass = not rt.holm(tests_after, opts.alpha)
    reported = effect_steps(steps, estimates, coupling)
    leftover = None if residuals_pass else _correction(aug, final_fit.estimates, None, None)
    cost, stages = run.finish("validation")
    return Diagnosis(
        mismatch=True,
        tests_after=tuple(tests_after),
        effect=best.candidate.effect,
        description=explain.explained(
            reported,
            fit.chi2,
            final_fit.chi2,
            lrt,
            ties,
            concealed,
            rival,
            residuals_pass,
        )
        + explain.misfit_scale(final_fit.chi2, fit.n_data - aug.n_free, residuals_pass)
        + explain.settle(tests)
        + no_test
        + explain.held_out(checked)
        + explain.levels(where["levels"]),
        candidates=tuple(scores),
        added_parameters=estimates,
        chi2_after=final_fit.chi2,
        lrt_p_value=lrt,
        bic_after=final_fit.chi2 + aug.n_free * np.log(fit.n_data),
        parameters_after=dict(final_fit.estimates),
        second_effect=applied[1].effect if len(applied) > 1 else None,
        indistinguishable=tuple(map(TieOut.model_validate, (*tied, *([rival] if rival else [])))),
        absorbed={n: AbsorbedOut.model_validate(a) for n, a in absorbed_by.items()},
        discriminating_experiment=DiscriminatingOut.of(proposal) if proposal else None,
        generic_correction=None if leftover is None else CorrectionOut.model_validate(leftover),
        effects=reported,
        validation=tuple(checked),
        cost=cost,
        stages=stages,
        **common,
    )
