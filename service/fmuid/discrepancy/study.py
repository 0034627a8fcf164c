"""The diagnose stage over raw inputs: build the problem once, then diagnose it."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from fmuid import provenance
from fmuid.data import Experiment, Spec
from fmuid.data.checks import check_test_data
from fmuid.discrepancy.engine import DiagnoseOptions, diagnose_problem
from fmuid.discrepancy.result import Diagnosis
from fmuid.estimation.problem import Problem
from fmuid.estimation.result import FitResult
from fmuid.formats.start import Start, start_at
from fmuid.model.fmu import FmuModel
from fmuid.progress import ProgressCallback, default_progress


def diagnose(
    fmu: str | Path | FmuModel,
    experiments: Sequence[Experiment],
    spec: Spec,
    *,
    fit: FitResult | None = None,
    workers: int | None = None,
    executor: Any = None,
    progress: ProgressCallback | None = None,
    problem: Problem | None = None,
    test_data: Sequence[Experiment] = (),
    start: Start | None = None,
    options: DiagnoseOptions = DiagnoseOptions(),
) -> Diagnosis:
    """Fit the spec's model, test its residuals and explain a mismatch by left-out physics.

    The signature is :func:`fmuid.profile`'s, with ``start`` and ``options`` added.

    Parameters
    ----------
    fmu
        A parsed FMU, an FMU file (FMI 2.0 or 3.0), or the name of a built-in model (e.g.
        ``"msd"``).
    experiments
        Datasets sharing the parameters.
    spec
        The study; ``physics`` may declare the FMU's switchable physics.
    fit
        The study's best fit, when the caller has it (default: fitted here).
    workers
        Local worker processes of the candidate scan and the profiles (default:
        ``options.workers``).
    progress
        Receives ``Progress("diagnose", done, total, detail)`` events.
    options
        Levels and effort (default: false-alarm level 0.005, 95% intervals).
    problem
        The problem ``fmuid.estimation.study.make_problem`` built of these inputs (default:
        built here).
    test_data
        Held-out experiments: the base and each augmented model are simulated on them
        (``validation``: RMS simulation error per file and output, before and after).
    start
        Where the fit begins (:func:`fmuid.formats.start.start_at`): an earlier fit or
        profile result (the object, or its JSON file: its estimates, without the global
        search) or an ``.ssv`` file; as the CLI's ``--start``. Ignored with ``problem``.
    executor
        A ``dask.distributed.Client``: the candidate scan and the profiles run on its workers
        (the same results as one process).

    Returns
    -------
    Diagnosis
        ``.to_dict()`` gives the contract's JSON.

    """
    from fmuid.estimation.study import make_problem

    started = provenance.now()
    progress = default_progress(progress)
    spec = start_at(spec, start)
    problem = problem or make_problem(fmu, experiments, spec)
    if test_data:
        model = problem.model
        check_test_data(spec, model.parameters, model.inputs, model.outputs, test_data)
    if workers is not None:
        options = replace(options, workers=workers)
    result = diagnose_problem(
        problem,
        fit=fit,
        options=options,
        progress=progress,
        test_data=test_data,
        executor=executor,
    )
    held = [e.name for e in test_data]
    recorded = provenance.record(
        result,
        fmu_sha256=problem.model.sha256,
        spec=spec,
        experiments=[*experiments, *test_data],
        options={"stage": "diagnose", **_options(options), "test_data": held},
        started=started,
    )
    return replace(recorded, problem=problem)


def _options(options: DiagnoseOptions) -> dict[str, object]:
    """Return the options as JSON values (nested settings as their text)."""
    plain = (int, float, bool)
    return {k: v if isinstance(v, plain) else repr(v) for k, v in vars(options).items()}
