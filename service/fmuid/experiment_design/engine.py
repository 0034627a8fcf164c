"""``fmuid design``: screen the experiment space by Fisher information, verify by profiles."""

from __future__ import annotations

import functools
import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fmuid import provenance
from fmuid.data import Spec
from fmuid.estimation.result import Cost
from fmuid.experiment_design.checkpoint import Checkpoint, Codec, evaluate_resumably
from fmuid.experiment_design.fisher import (
    Sensitivity,
    criterion,
    identifiable_basis,
    null_space,
    predicted_intervals,
    robust_points,
    sensitivity,
    structural_names,
    trial_problem,
)
from fmuid.experiment_design.result import DesignResult, RankedDesign
from fmuid.experiment_design.signals import Trial, sample_trials
from fmuid.experiment_design.space import Space, check_design
from fmuid.experiment_design.verify import Draw, DrawTask, combine
from fmuid.model.builtin import resolve_fmu
from fmuid.model.fmu import FmuModel, model_of_file
from fmuid.profiling.engine import thresholds
from fmuid.progress import Progress, ProgressCallback, default_progress

log = logging.getLogger(__name__)

KEEP = 10
"""Designs listed in the result."""


@dataclass(frozen=True)
class Screen:
    """The Fisher screen of the space: every trial's sensitivities at every prior point."""

    model: FmuModel
    spec: Spec
    space: Space
    points: list[dict[str, float]]
    basis: np.ndarray
    structural: set[str]
    combinations: list[dict[str, Any]]
    threshold: float

    def score(self, sens: Sequence[Sensitivity], trial: Trial, outputs: Sequence[str]) -> float:
        """Worst-case half-width over the prior points, per unit of test time."""
        worst = max(
            criterion(s.fisher(outputs), self.basis, self.space.criterion, self.threshold)
            for s in sens
        )
        return worst * math.sqrt(trial.duration / self.space.longest_test)

    def sensitivities(self, trial: Trial) -> list[Sensitivity]:
        """Sensitivities of a trial (all candidate sensors) at every prior point."""
        problem = trial_problem(self.model, self.spec, self.space, trial)
        return [sensitivity(problem, p) for p in self.points]

    def predicted(self, sens: Sensitivity, trial: Trial, outputs: Sequence[str]) -> dict:
        """Predicted intervals at the nominal (the first point)."""
        problem = trial_problem(self.model, self.spec, self.space, trial)
        return predicted_intervals(
            sens.fisher(outputs),
            self.basis,
            problem,
            self.points[0],
            self.threshold,
            self.structural,
        )


def design(
    fmu: str | Path,
    spec: Spec,
    space: Space,
    *,
    verify_designs: int | None = None,
    workers: int | None = 1,
    executor: Any = None,
    progress: ProgressCallback | None = None,
    checkpoint: Path | None = None,
) -> DesignResult:
    """Propose the experiment that identifies every free parameter most narrowly per test time.

    Parameters
    ----------
    fmu
        An FMU file or the name of a built-in model.
    spec
        Free parameters (bounds; ``start`` is the nominal guess and the truth of the simulated
        verification data), fixed FMU parameters, confidence.
    space
        The feasible experiments (:func:`fmuid.experiment_design.load_space`).
    verify_designs
        Best designs verified by profiles (default ``space.verify_designs``).
    workers, executor
        Local worker processes (``None``: the CPU count) or a dask client. One task is one
        trial of the screen (its sensitivities at every prior point: ``2 n (points + 1)``
        simulations, far more than a task's overhead) or one verified design on one noise draw
        (a fit and every profile). The numbers do not depend on where the tasks run.
    progress
        Receives ``Progress("design", done, total, detail)`` after every finished evaluation.
    checkpoint
        A folder that keeps every finished evaluation
        (:mod:`fmuid.experiment_design.checkpoint`): run again with the same inputs, the study
        evaluates only what is not there.

    Returns
    -------
    DesignResult

    Raises
    ------
    SpecError
        When the space does not fit the FMU or the spec.

    """
    t0 = time.perf_counter()
    started = provenance.now()
    progress = default_progress(progress)
    model = model_of_file(resolve_fmu(fmu))
    check_design(space, spec, model)
    n_verify = space.verify_designs if verify_designs is None else verify_designs
    store = Checkpoint.for_study(checkpoint, model, spec, space, n_verify) if checkpoint else None
    rng = np.random.default_rng(space.seed)
    trials = sample_trials(space, rng)
    threshold = thresholds(spec.confidence, len(spec.parameters))["simultaneous"]
    template = trial_problem(model, spec, space, trials[0])
    points = robust_points(spec, space, template, rng)
    base = Screen(model, spec, space, points, np.eye(len(spec.parameters)), set(), [], threshold)
    run = functools.partial(
        evaluate_resumably,
        checkpoint=store,
        model=model,
        interface=spec.interface,
        workers=workers,
        executor=executor,
    )
    sens_all = run(
        base.sensitivities,
        trials,
        [f"screen-{k}" for k in range(len(trials))],
        SENSITIVITIES,
        on_done=_reporter(progress, "Fisher screen"),
    )
    sims0 = len(trials) * len(points) * (2 * len(spec.parameters))
    check = null_space([s[0] for s in sens_all], template, points[0])
    combos = check["non_identifiable_combinations"]
    screen = Screen(
        model,
        spec,
        space,
        points,
        identifiable_basis(combos, template.names),
        structural_names(combos),
        combos,
        threshold,
    )
    scored = [
        (screen.score(sens, trial, outputs), k, outputs)
        for k, (trial, sens) in enumerate(zip(trials, sens_all, strict=True))
        for outputs in space.sensor_sets()
    ]
    scored.sort(key=lambda s: s[0])
    ranked = []
    for score, k, outputs in scored[:KEEP]:
        trial = trials[k].with_(outputs=tuple(outputs))
        ranked.append(RankedDesign(trial, score, screen.predicted(sens_all[k][0], trial, outputs)))
    t_screen = time.perf_counter() - t0
    pairs = [(i, draw) for i in range(min(n_verify, len(ranked))) for draw in range(space.draws)]
    tasks = [
        DrawTask(model, spec, space, ranked[i].trial, space.seed + 1000 * (i + 1), draw)
        for i, draw in pairs
    ]
    draws = run(
        DrawTask.run,
        tasks,
        [f"verify-{i}-{draw}" for i, draw in pairs],
        DRAW,
        on_done=_reporter(progress, "profiles of the best designs"),
    )
    verified = []
    for i, d in enumerate(ranked[:n_verify]):
        v = combine(list(spec.parameters), draws[i * space.draws : (i + 1) * space.draws])
        sims0 += v.simulations
        verified.append(RankedDesign(d.trial, d.score, d.predicted, v))
    verified.sort(key=lambda d: _verified_key(d, space))
    designs = (*verified, *ranked[n_verify:])
    best = designs[0]
    best_sens = sens_all[trials.index(best.trial.with_(outputs=tuple(space.outputs)))]
    tradeoffs = _tradeoffs(screen, best, best_sens)
    seconds = time.perf_counter() - t0
    result = DesignResult(
        fmu_sha256=model.sha256,
        model_name=model.model_name,
        input_name=space.input,
        criterion=space.criterion,
        designs=designs,
        not_identifiable_by_any=combos,
        tradeoffs=tradeoffs,
        screened=len(scored),
        cost=Cost(sims0, seconds),
        stage_seconds={"screen_seconds": t_screen, "verify_seconds": seconds - t_screen},
    )
    options = {
        "stage": "design",
        "space": space.model_dump(mode="json"),
        "verify_designs": n_verify,
        "workers": workers,
        "executor": None if executor is None else type(executor).__name__,
    }
    return provenance.record(
        result,
        fmu_sha256=model.sha256,
        spec=spec,
        options=options,
        started=started,
        seed=space.seed,
    )


def _reporter(progress: ProgressCallback | None, detail: str) -> Callable[[int, int], None]:
    def report(done: int, total: int) -> None:
        if progress:
            progress(Progress("design", done, total, detail))

    return report


SENSITIVITIES: Codec[list[Sensitivity]] = Codec(
    lambda sens: {
        "jacobians": np.stack([s.jacobian for s in sens]),
        "outputs": np.array(sens[0].outputs),
        "rows": np.array(sens[0].rows),
    },
    lambda a: [
        Sensitivity(j, tuple(str(o) for o in a["outputs"]), int(a["rows"])) for j in a["jacobians"]
    ],
)
"""Checkpoint form of a screen evaluation: a trial's sensitivities at every prior point."""
DRAW: Codec[Draw] = Codec(Draw.to_arrays, Draw.from_arrays)
"""Checkpoint form of a verification evaluation."""


def _verified_key(d: RankedDesign, space: Space) -> tuple[float, float]:
    v = d.verified
    assert v is not None
    short = sum(v.draws - c for c in v.identifiable.values())
    return short, v.geometric_mean_width() * math.sqrt(d.trial.duration / space.longest_test)


def _tradeoffs(screen: Screen, best: RankedDesign, sens: list[Sensitivity]) -> dict[str, dict]:
    """Score and predicted widths of the best design with a sensor dropped or added, rate halved."""
    trial, outputs = best.trial, list(best.trial.outputs)

    def entry(t: Trial, s: list[Sensitivity], outs: Sequence[str]) -> dict[str, Any]:
        pred = screen.predicted(s[0], t, outs)
        score = screen.score(s, t, outs)
        return {
            "score": score if math.isfinite(score) else None,
            "score_ratio": score / best.score if math.isfinite(score) and best.score > 0 else None,
            "width": {
                n: (p["width_z"] if math.isfinite(p.get("width_z", math.inf)) else None)
                for n, p in pred.items()
            },
            "status": {n: p["status"] for n, p in pred.items()},
        }

    out = {}
    if len(outputs) > 1:
        for o in outputs:
            rest = [x for x in outputs if x != o]
            out[f"drop {o}"] = entry(trial, sens, rest)
    for o in screen.space.outputs:
        if o not in outputs:
            out[f"add {o}"] = entry(trial, sens, [*outputs, o])
    half = trial.with_(rate_hz=trial.rate_hz / 2, outputs=tuple(screen.space.outputs))
    out[f"rate {half.rate_hz:g} Hz"] = entry(half, screen.sensitivities(half), outputs)
    return out
