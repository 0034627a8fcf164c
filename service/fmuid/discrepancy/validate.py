"""Held-out validation of each augmented model, and the feedback coupling's own error.

The base model and the model after each added effect are simulated on the test experiments
from their fitted parameters; the error is the benchmarks' metric, the root mean square of the
simulation error in the output's unit, over the rows after the settle-in window.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from fmuid.data import Experiment
from fmuid.discrepancy.augment import AugmentedPredictor
from fmuid.estimation.problem import Problem


def settle_seconds(problem: Problem) -> float:
    """Return the spec's settle-in window [s] (0 when the spec has none)."""
    return float(getattr(problem.spec, "settle", 0.0) or 0.0)


def rms_errors(
    problem: Problem, values: Mapping[str, float], experiments: Sequence[Experiment]
) -> dict[tuple[str, str], tuple[int, float]]:
    """RMS simulation error per test experiment and fitted output: ``{(exp, out): (n, rms)}``.

    Outputs a test file does not record are left out.
    """
    settle = settle_seconds(problem)
    out: dict[tuple[str, str], tuple[int, float]] = {}
    for exp in experiments:
        names = [o for o in problem.outputs if o in exp.columns]
        if not names:
            continue
        y = problem.predictor.predict(dict(values), exp, names)
        problem.simulations += 1
        kept = exp.time >= exp.time[0] + settle
        for j, o in enumerate(names):
            mask = exp.output_mask(o) & kept
            error = y[mask, j] - exp.columns[o][mask]
            out[(exp.name, o)] = (int(mask.sum()), float(np.sqrt(np.mean(error**2))))
    return out


def validation(
    models: Sequence[tuple[Problem, Mapping[str, float]]], experiments: Sequence[Experiment]
) -> list[dict[str, Any]]:
    """Contract entries of the base model (first) and each augmented model after it.

    Each entry: experiment, output, n, ``rms_base``, ``rms_by_step`` (after each added effect)
    and ``rms_final`` (the last model's; the base's when nothing was added).
    """
    if not experiments:
        return []
    runs = [rms_errors(problem, values, experiments) for problem, values in models]
    entries = []
    for (exp, output), (n, base) in runs[0].items():
        steps = [run[(exp, output)][1] for run in runs[1:]]
        entries.append({
            "experiment": exp, "output": output, "n": n, "rms_base": base,
            "rms_final": steps[-1] if steps else base, "rms_by_step": steps,
        })  # fmt: skip
    return entries


def coupling_error(problem: Problem, values: Mapping[str, float]) -> float | None:
    """Largest change, in sigmas, of the fit's predictions when the fine step is halved.

    None when the model has no effect that acts on a fine grid (nothing to check).
    """
    predictor = problem.predictor
    if not isinstance(predictor, AugmentedPredictor):
        return None
    if not any(e.side in ("feedback", "input") or e.effect == "output_lag"
               for e in predictor.effects):  # fmt: skip
        return None
    half = AugmentedPredictor(predictor.base, predictor.effects, predictor.step_scale / 2)
    worst = 0.0
    for i, exp in enumerate(problem.experiments):
        a = predictor.predict(dict(values), exp, problem.outputs)
        b = half.predict(dict(values), exp, problem.outputs)
        problem.simulations += 2
        for j, o in enumerate(problem.outputs):
            mask = problem.masks[i][j]
            if mask.any():
                sigma = problem.sigma[i][o][mask]
                worst = max(worst, float(np.max(np.abs(a[mask, j] - b[mask, j]) / sigma)))
    return worst
