"""Diagnose a model mismatch: locate it, name the left-out physics, model it, show the gain.

1. Fit the base model and test its weighted residuals (:mod:`.residual_tests`) plus whether
   the experiments' separate fits disagree; ``mismatch`` is Holm's decision at the family-wise
   false-alarm level :data:`~.residual_tests.FALSE_ALARM`.
2. Fit every catalogue candidate (:mod:`.catalogue`) warm-started from the base fit, rank them
   by BIC and test each by a likelihood-ratio test (Bonferroni over the candidates).
3. Re-test the residuals of the best augmented model; if a mismatch remains, fit the other
   candidates on top of it once more. If the tests still fail, or no candidate is significant,
   the effect is ``unexplained`` and a generic ARX correction (:mod:`.correction`) measures
   how much of the misfit is structure.
4. Profile the added parameters for their interval and whether it excludes the off value.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

from fmuid.diagnose import residual_tests as rt
from fmuid.diagnose.catalogue import AddedParameter, AugmentedPredictor, Candidate, catalogue
from fmuid.diagnose.correction import arx_correction
from fmuid.diagnose.result import AddedEstimate, CandidateScore, Diagnosis
from fmuid.errors import FmuidError
from fmuid.fit.optimize import (
    FitOptions,
    fit_problem,
    jacobian,
    make_fit_result,
    refine,
    safe_residuals,
)
from fmuid.fit.predictor import FmuPredictor, merged_inputs
from fmuid.fit.problem import Problem
from fmuid.fit.result import Cost, FitResult
from fmuid.profile.engine import profile_problem
from fmuid.profile.walk import WalkOptions
from fmuid.progress import Progress, ProgressCallback

log = logging.getLogger(__name__)


POLISH = FitOptions(ftol=1e-9, xtol=1e-9, gtol=1e-9, max_nfev=100)
"""Trust-region settings that bring a candidate's fit to convergence."""


@dataclass(frozen=True)
class DiagnoseOptions:
    """Settings of a diagnosis.

    Attributes
    ----------
    alpha
        Family-wise false-alarm level of the mismatch decision and of naming an effect.
    ci_confidence
        Level of the pointwise profile-likelihood interval of the added parameters.
    tie_bic
        Candidates whose BIC is within this of the best are reported as indistinguishable.
    equivalent_chi2
        Candidates whose chi2 is within this of the best are the same model numerically (a
        lag on the input or on the outputs of a linear model); the first in catalogue order
        is named.
    max_nfev
        Cap on residual evaluations of each candidate's quick trust-region fit.
    polish, polish_bic
        At most ``polish`` candidates within ``polish_bic`` of the best BIC are then refined
        to convergence (:data:`POLISH`) before they are compared.
    scan_points
        Grid points of the warm-start scan over each added parameter's range.
    scan_refits
        The best scan points from which a short re-fit of every parameter is tried.
    workers
        Processes for the profile branches (1: in this process).
    walk
        Profile walk settings: the walk stops at the simultaneous threshold, past the
        pointwise crossing that gives the added parameters' intervals.

    """

    alpha: float = rt.FALSE_ALARM
    ci_confidence: float = 0.95
    tie_bic: float = 2.0
    equivalent_chi2: float = 0.5
    max_nfev: int = 15
    scan_points: int = 7
    scan_refits: int = 4
    workers: int = 1
    polish: int = 3
    polish_bic: float = 20.0
    walk: WalkOptions = WalkOptions(  # noqa: B008 (frozen value)
        rise_per_step=0.15,
        margin=0.0,
        max_points=12,
        refit=FitOptions(ftol=1e-7, xtol=1e-7, gtol=1e-7, max_nfev=20),
    )


def residual_series(problem: Problem, values: dict[str, float]) -> list[rt.Series]:
    """Weighted residuals of every experiment and output at ``values``, with the inputs."""
    predictions = problem.predict(values)
    out = []
    for i, exp in enumerate(problem.experiments):
        input_time, inputs = merged_inputs(exp, problem.inputs)
        for j, output in enumerate(problem.outputs):
            mask = problem.masks[i][j]
            if mask.sum() < 2:
                continue
            t = exp.time[mask]
            r = (problem.data[i][j] - predictions[i][output][mask]) / problem.sigma[i][output][mask]
            u = {name: np.interp(t, input_time, v) for name, v in inputs.items()}
            out.append(rt.Series(exp.name, output, t, r, u))
    return out


def augmented(root: Problem, candidates: Sequence[Candidate], confidence: float) -> Problem:
    """Return the root problem with the candidates' parameters added and wrappers applied."""
    params = dict(root.parameter_specs)
    wrappers: dict[str, tuple[str, str | None]] = {}
    for c in candidates:
        for p in c.parameters:
            params[p.name] = p.spec
            if c.wrapper is not None:
                wrappers[p.name] = c.wrapper
    base = root.predictor
    predictor = AugmentedPredictor(base, wrappers) if wrappers and isinstance(
        base, FmuPredictor
    ) else base  # fmt: skip
    spec = root.spec.model_copy(update={"confidence": confidence})
    return Problem(
        root.fmu_path, root.experiments, spec, predictor=predictor, parameters=params,
        sigma=root.sigma, sigma_method=root.sigma_method,
    )  # fmt: skip


def _fit_candidate(
    problem: Problem,
    start: dict[str, float],
    added: Sequence[AddedParameter],
    opts: DiagnoseOptions,
) -> tuple[np.ndarray, float]:
    """Scan each added parameter over its range from ``start``, then refine everything."""
    values = {**start, **{p.name: p.spec.start for p in added}}
    z = problem.to_z(values)
    tried = [(float(np.sum(safe_residuals(problem, z) ** 2)), z)]
    for p in added:
        i = problem.names.index(p.name)
        span = problem.z_upper[i] - problem.z_lower[i]
        for zi in np.linspace(problem.z_lower[i], problem.z_upper[i], opts.scan_points):
            if abs(zi - z[i]) < 1e-9 * span:
                continue  # the start itself (a round-off neighbour of it can stall the fit)
            trial = tried[0][1].copy()
            trial[i] = zi
            tried.append((float(np.sum(safe_residuals(problem, trial) ** 2)), trial))
        tried.sort(key=lambda t: t[0])
    options = FitOptions(ftol=1e-8, xtol=1e-8, gtol=1e-8, max_nfev=opts.max_nfev)
    best: tuple[np.ndarray, float] | None = None
    # The base parameters have shifted to hide the effect, so the scan's ranking with them held
    # fixed favours "off"; a short re-fit of everything from each of the best starts decides.
    for _, trial in tried[: opts.scan_refits]:
        try:
            z, chi2, _ = refine(problem, trial, options=options)
        except FmuidError:
            continue
        if best is None or chi2 < best[1]:
            best = (z, chi2)
    if best is None:
        return tried[0][1], tried[0][0]
    return best


def _tests(problem: Problem, fit: FitResult, opts: DiagnoseOptions) -> list[rt.TestResult]:
    """Residual tests of a fit, the global chi2 test and the experiments' agreement."""
    series = residual_series(problem, fit.estimates)
    known = all(m in ("given", "column") for m in problem.sigma_method.values())
    tests = rt.series_tests(series, known)
    if known:
        tests.append(rt.global_goodness_of_fit(fit.chi2, fit.n_data, problem.n_free))
    disagree = _experiments_disagree(problem, fit, opts)
    if disagree is not None:
        tests.append(disagree)
    return tests


def _experiments_disagree(
    problem: Problem, fit: FitResult, opts: DiagnoseOptions
) -> rt.TestResult | None:
    """Likelihood-ratio test that every experiment shares the parameters.

    Each experiment is fitted alone, warm-started from the joint fit; the joint chi2 minus the
    sum of the separate ones is chi2 with (experiments - 1) x parameters df (conservative when
    a single experiment leaves parameters unidentifiable).
    """
    if len(problem.experiments) < 2:
        return None
    separate = 0.0
    z0 = fit.z_estimate()
    for i, exp in enumerate(problem.experiments):
        one = Problem(
            problem.fmu_path, [exp], problem.spec, predictor=problem.predictor,
            parameters=problem.parameter_specs, sigma=[problem.sigma[i]],
            sigma_method=problem.sigma_method,
        )  # fmt: skip
        _, chi2, _ = refine(one, z0, options=FitOptions(ftol=1e-8, max_nfev=opts.max_nfev))
        separate += chi2
        problem.simulations += one.simulations
    stat = max(fit.chi2 - separate, 0.0)
    df = (len(problem.experiments) - 1) * problem.n_free
    p = float(stats.chi2.sf(stat, df))
    return rt.TestResult("experiments_disagree", None, None, p, stat, df)


def _location(problem: Problem, fit: FitResult, evidence: Sequence[rt.TestResult]) -> tuple[
    dict[str, object], list[rt.Window]
]:
    """Return the outputs, experiments, time windows and band the evidence points to."""
    pairs = {(t.experiment, t.output) for t in evidence if t.output is not None}
    series = residual_series(problem, fit.estimates)
    if not pairs:
        pairs = {(s.experiment, s.output) for s in series}
    chosen = [s for s in series if (s.experiment, s.output) in pairs]
    found = [w for s in chosen for w in rt.windows(s)]
    bands = [b for s in chosen if (b := rt.spectrum_band(s)) is not None]
    spans = sorted([w.start, w.end] for w in found)
    merged: list[list[float]] = []
    for span in spans:
        if merged and span[0] <= merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], span[1])
        else:
            merged.append(list(span))
    band = max(bands, key=lambda b: b[2]) if bands else None
    location = {
        "outputs": sorted({o for _, o in pairs}),
        "experiments": [e.name for e in problem.experiments if e.name in {x for x, _ in pairs}],
        "time_windows": merged,
        "frequency_hz": [band[0], band[1]] if band else None,
    }
    return location, found


def _added_estimate(
    problem: Problem, fit: FitResult, p: AddedParameter, ci: tuple[float | None, float | None],
    confidence: float,
) -> AddedEstimate:
    """Estimate, interval and the off-value check of one added parameter."""
    lo, hi = ci
    if p.off_side == "low":
        excludes = lo is not None
    elif p.off_side == "high":
        excludes = hi is not None
    else:
        low = lo if lo is not None else p.spec.lower
        high = hi if hi is not None else p.spec.upper
        excludes = not low <= p.off <= high
    return AddedEstimate(fit.estimates[p.name], ci, confidence, p.unit, p.off, bool(excludes))


def diagnose_problem(
    problem: Problem,
    *,
    fit: FitResult | None = None,
    options: DiagnoseOptions = DiagnoseOptions(),
    progress: ProgressCallback | None = None,
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

    Returns
    -------
    Diagnosis

    """
    t0 = time.perf_counter()
    sims0 = problem.simulations
    opts = options
    if fit is None:
        fit = fit_problem(problem, global_search=problem.spec.global_search, seed=problem.spec.seed)
    n = fit.n_data
    bic_before = fit.chi2 + problem.n_free * np.log(n)
    tests_before = _tests(problem, fit, opts)
    evidence = rt.holm(tests_before, opts.alpha)
    location, found = _location(problem, fit, evidence)
    before = dict(fit.estimates)
    common = {
        "false_alarm": opts.alpha, "tests_before": tuple(tests_before), "location": location,
        "windows": tuple(found), "evidence": tuple(evidence), "chi2_before": fit.chi2,
        "n_data": n, "bic_before": bic_before, "parameters_before": before,
        "fmu": {"sha256": fit.fmu_sha256, "model_name": fit.model_name},
    }  # fmt: skip
    if not evidence:
        return Diagnosis(
            mismatch=False, tests_after=tuple(tests_before), effect=None,
            description="No mismatch: the residuals pass every test at a family-wise "
            f"false-alarm level of {opts.alpha:g}.",
            candidates=(), added_parameters={}, chi2_after=fit.chi2, lrt_p_value=None,
            bic_after=bic_before, parameters_after=before,
            cost=Cost(problem.simulations - sims0, time.perf_counter() - t0), **common,
        )  # fmt: skip
    scale = {
        o: max(float(np.max(np.abs(np.concatenate([d[j] for d in problem.data])))), 1e-12)
        for j, o in enumerate(problem.outputs)
    }
    cands = catalogue(
        problem.model.model_name, list(problem.model.parameters), problem.spec, problem.inputs,
        problem.outputs, scale,
    )  # fmt: skip
    total = 2 * len(cands) + 2
    done = [0]
    made: list[Problem] = []

    def spent() -> int:
        return problem.simulations - sims0 + sum(p.simulations for p in made)

    def report(detail: str) -> None:
        done[0] += 1
        if progress:
            progress(Progress("diagnose", done[0], total, detail))

    def round_of(
        stage: int, applied: list[Candidate], start: dict[str, float], chi2_prev: float,
        pool: Sequence[Candidate],
    ) -> list[tuple[CandidateScore, Candidate, Problem, np.ndarray]]:
        def scored_fit(
            c: Candidate, aug: Problem, z: np.ndarray, chi2: float
        ) -> tuple[CandidateScore, Candidate, Problem, np.ndarray]:
            values = aug.from_z(z)
            drop = max(chi2_prev - chi2, 0.0)
            score = CandidateScore(
                c.effect, {k: values[k] for k in c.names}, chi2,
                float(stats.chi2.sf(drop, len(c.names))), chi2 + aug.n_free * np.log(n), stage,
            )  # fmt: skip
            return score, c, aug, z

        scored = []
        for c in pool:
            aug = augmented(problem, [*applied, c], opts.ci_confidence)
            made.append(aug)
            z, chi2 = _fit_candidate(aug, start, c.parameters, opts)
            scored.append(scored_fit(c, aug, z, chi2))
            report(f"round {stage}: {c.label} chi2 {chi2:.4g}")
        scored.sort(key=lambda s: s[0].bic)
        # the quick fits rank the candidates; the leading ones are refined to convergence
        lead = [s for s in scored if s[0].bic - scored[0][0].bic < opts.polish_bic]
        for s in lead[: opts.polish]:
            z, chi2, _ = refine(s[2], s[3], options=POLISH)
            scored[scored.index(s)] = scored_fit(s[1], s[2], z, min(chi2, s[0].chi2))
        scored.sort(key=lambda s: s[0].bic)
        same = [s for s in scored if s[0].chi2 - scored[0][0].chi2 < opts.equivalent_chi2]
        first = min(same, key=lambda s: pool.index(s[1]))
        return [first, *(s for s in scored if s is not first)]

    first = round_of(1, [], before, fit.chi2, cands)
    level = opts.alpha / max(len(first), 1)
    scores = [s for s, *_ in first]
    best_score, best, aug, z = first[0]
    applied = [best]
    final_fit = make_fit_result(aug, z, best_score.chi2, jacobian(aug, z), "", False, t0, 0)
    tests_after = _tests(aug, final_fit, opts)
    second: str | None = None
    if rt.holm(tests_after, opts.alpha) and best_score.p_value < level:
        pool = [c for c in cands if c is not best]
        again = round_of(2, applied, final_fit.estimates, best_score.chi2, pool)
        scores += [s for s, *_ in again]
        s2, c2, aug2, z2 = again[0]
        if s2.p_value < opts.alpha / max(len(pool), 1):
            fit2 = make_fit_result(aug2, z2, s2.chi2, jacobian(aug2, z2), "", False, t0, 0)
            tests2 = _tests(aug2, fit2, opts)
            applied, aug, final_fit, tests_after, second = [best, c2], aug2, fit2, tests2, c2.effect
            # backward step: is the first effect still needed once the second is in?
            alone = next(s for s in first if s[1] is c2)
            z_alone, chi2_alone, _ = refine(alone[2], alone[3], options=POLISH)
            chi2_alone = min(chi2_alone, alone[0].chi2)
            redundant = stats.chi2.sf(max(chi2_alone - s2.chi2, 0.0), len(best.names)) >= level
            if redundant:
                fit1 = make_fit_result(alone[2], z_alone, chi2_alone, jacobian(alone[2], z_alone),
                                       "", False, t0, 0)  # fmt: skip
                tests1 = _tests(alone[2], fit1, opts)
                if not rt.holm(tests1, opts.alpha):
                    drop = max(fit.chi2 - chi2_alone, 0.0)
                    best_score = CandidateScore(
                        c2.effect, {k: fit1.estimates[k] for k in c2.names}, chi2_alone,
                        float(stats.chi2.sf(drop, len(c2.names))),
                        chi2_alone + alone[2].n_free * np.log(n), 1,
                    )  # fmt: skip
                    scores = [best_score, *(s for s in scores if s is not alone[0])]
                    best, applied, aug, final_fit = c2, [c2], alone[2], fit1
                    tests_after, second = tests1, None
    report("tests of the augmented model")
    explained = best_score.p_value < level and not rt.holm(tests_after, opts.alpha)
    ties = tuple(
        s.effect for s in scores[1:]
        if s.stage == 1 and s.bic - best_score.bic < opts.tie_bic and s.p_value < level
    )  # fmt: skip
    if not explained:
        correction = arx_correction(residual_series(problem, fit.estimates))
        report("generic correction")
        worst = min(tests_after, key=lambda t: t.p_value)
        return Diagnosis(
            mismatch=True, tests_after=tuple(tests_after), effect="unexplained",
            description=_unexplained_text(best_score, worst, correction, location),
            candidates=tuple(scores), added_parameters={}, chi2_after=fit.chi2,
            lrt_p_value=best_score.p_value, bic_after=bic_before, parameters_after=before,
            generic_correction=correction, cost=Cost(spent(), time.perf_counter() - t0),
            **common,
        )  # fmt: skip
    added = [p for c in applied for p in c.parameters]
    prof = profile_problem(
        aug, final_fit, only=[p.name for p in added], workers=opts.workers, options=opts.walk
    )
    remote = prof.cost.simulations - final_fit.cost.simulations if opts.workers != 1 else 0
    final_fit = prof.fit
    estimates = {
        p.name: _added_estimate(
            aug, final_fit, p, prof.parameters[p.name].ci_pointwise, opts.ci_confidence
        )
        for p in added
    }
    report("profiles of the added parameters")
    lrt = float(stats.chi2.sf(max(fit.chi2 - final_fit.chi2, 0.0), len(added)))
    return Diagnosis(
        mismatch=True, tests_after=tuple(tests_after), effect=best.effect,
        description=_explained_text(applied, estimates, fit.chi2, final_fit.chi2, lrt, ties),
        candidates=tuple(scores), added_parameters=estimates, chi2_after=final_fit.chi2,
        lrt_p_value=lrt, bic_after=final_fit.chi2 + aug.n_free * np.log(n),
        parameters_after=dict(final_fit.estimates), second_effect=second, indistinguishable=ties,
        cost=Cost(spent() + max(remote, 0), time.perf_counter() - t0),
        **common,
    )  # fmt: skip


def _fmt_ci(e: AddedEstimate) -> str:
    ends = ["-inf" if e.ci[0] is None else f"{e.ci[0]:.3g}", "inf" if e.ci[1] is None else
            f"{e.ci[1]:.3g}"]  # fmt: skip
    verdict = "excludes" if e.excludes_off else "does not exclude"
    return f"{e.confidence:.0%} CI [{ends[0]}, {ends[1]}] {verdict} the off value {e.off:g}"


def _explained_text(
    applied: Sequence[Candidate], estimates: dict[str, AddedEstimate], chi2_before: float,
    chi2_after: float, lrt: float, ties: Sequence[str],
) -> str:
    """Human summary of a named effect."""
    parts = []
    for c in applied:
        e = estimates[c.parameters[0].name]
        text = c.description.format(value=f"{e.estimate:.3g}")
        parts.append(f"{c.effect}: {text} ({c.parameters[0].name} {_fmt_ci(e)})")
    out = "; then ".join(parts) + (
        f". Chi2 {chi2_before:.4g} -> {chi2_after:.4g} (likelihood-ratio p = {lrt:.2g}); the "
        "augmented model's residuals pass every test."
    )
    if ties:
        out += (
            f" {', '.join(ties)} explains the data equally well (BIC within 2): the "
            "experiments cannot tell them apart."
        )
    return out[0].upper() + out[1:]


def _unexplained_text(
    best: CandidateScore, worst: rt.TestResult, correction: dict[str, object],
    location: dict[str, object],
) -> str:
    """Human summary of a mismatch that no candidate removes."""
    outputs = location.get("outputs")
    where = ", ".join(map(str, outputs)) if isinstance(outputs, list) else "the outputs"
    return (
        f"A mismatch is certain in {where} but no catalogue entry removes it: the best "
        f"candidate, {best.effect} (likelihood-ratio p = {best.p_value:.2g}), still leaves "
        f"{worst.test} at p = {worst.p_value:.2g}. A generic {correction['model']} reduces chi2 "
        f"from {correction['chi2_before']:.4g} to {correction['chi2_after']:.4g} "
        f"(noise alone would leave about {correction['noise_chi2']:.4g}; "
        f"{float(correction['structure_fraction']):.0%} of the misfit is structure)."  # type: ignore[arg-type]
    )
