"""The diagnose stage over raw inputs: build the problem once, then diagnose it."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from fmuid.data import Experiment, Spec
from fmuid.discrepancy.engine import DiagnoseOptions, diagnose_problem
from fmuid.discrepancy.result import Diagnosis
from fmuid.estimation.problem import Problem
from fmuid.model.fmu import FmuModel
from fmuid.progress import ProgressCallback


def diagnose(
    fmu_path: str | Path | FmuModel,
    experiments: Sequence[Experiment],
    spec: Spec,
    progress: ProgressCallback | None = None,
    options: DiagnoseOptions = DiagnoseOptions(),
    problem: Problem | None = None,
    test_data: Sequence[Experiment] = (),
) -> Diagnosis:
    """Fit the spec's model, test its residuals and explain a mismatch by left-out physics.

    Parameters
    ----------
    fmu_path
        A parsed FMU, an FMU file (FMI 2.0 or 3.0), or the name of a built-in model (e.g.
        ``"msd"``).
    experiments
        Datasets sharing the parameters.
    spec
        The study; ``physics`` may declare the FMU's switchable physics.
    progress
        Receives ``Progress("diagnose", done, total, detail)`` events.
    options
        Levels and effort (default: false-alarm level 0.01, 95% intervals).
    problem
        The problem ``fmuid.estimation.study.make_problem`` built of these inputs (default:
        built here).
    test_data
        Held-out experiments: the base and each augmented model are simulated on them
        (``validation``: RMS simulation error per file and output, before and after).

    Returns
    -------
    Diagnosis
        ``.to_dict()`` gives the contract's JSON.

    """
    from fmuid.estimation.study import make_problem

    problem = problem or make_problem(fmu_path, experiments, spec)
    return diagnose_problem(problem, options=options, progress=progress, test_data=test_data)
