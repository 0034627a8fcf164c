"""The job kinds as one table: per kind, what it takes, how it loads, runs and is drawn.

Every place that depends on a job's kind looks it up here with :func:`runner`: the submission
(:mod:`fmuid.intake.submission`: CSV files, or a design's experiment space), the loader of a
stored job's inputs (:mod:`fmuid.intake.inputs`), the job process (:mod:`fmuid.jobs.run`) and
the drawing process (:mod:`fmuid.jobs.draw`). The result is written the same way for every kind
(its ``to_dict()`` as JSON, which names its kind) and read back by
:func:`fmuid.results.result_from_dict`. The stages (``fmuid.fit``, ``profile``,
``diagnose``, ``design``) and the report are imported when a runner is called, so that a kind's
machinery is loaded in the processes that run it only.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

from fmuid.errors import FmuidError, SpecError
from fmuid.jobs.records import KINDS, Job, Kind

if TYPE_CHECKING:
    from fmuid.data import Experiment, Spec
    from fmuid.experiment_design import Space
    from fmuid.progress import ProgressCallback

__all__ = ["RUNNERS", "JobInputs", "RunContext", "Runner", "runner"]

DASK_TIMEOUT = "20s"
"""How long a job waits for the dask scheduler before it fails saying so."""


@dataclass(frozen=True)
class JobInputs:
    """What the engine needs to run a job (or to draw its report).

    Attributes
    ----------
    fmu
        The FMU file.
    spec
        The parsed spec.
    experiments
        The experiments of a fit, profile or diagnosis (empty for a design).
    test_data
        The held-out experiments (empty for a design).
    space
        The experiment space of a design (``None`` for the other kinds).

    """

    fmu: Path
    spec: Spec
    experiments: list[Experiment]
    test_data: list[Experiment]
    space: Space | None = None


@dataclass(frozen=True)
class RunContext:
    """What the job process hands every runner besides the inputs.

    Attributes
    ----------
    progress
        Called with the engine's progress events.
    dask_scheduler
        Address of a dask scheduler for the kinds that spread tasks (``None``: local workers).
    checkpoint
        Folder that keeps a design's finished evaluations across restarts of the job.

    """

    progress: ProgressCallback
    dask_scheduler: str | None = None
    checkpoint: Path | None = None

    @contextlib.contextmanager
    def executor(self) -> Iterator[Any]:
        """Yield a dask client connected to :attr:`dask_scheduler`, or ``None`` without one.

        Raises
        ------
        FmuidError
            If the scheduler cannot be reached (the message names its address).

        """
        if not self.dask_scheduler:
            yield None
            return
        from distributed import Client

        try:
            client = Client(self.dask_scheduler, timeout=DASK_TIMEOUT)
        except OSError as exc:
            raise FmuidError(
                f"cannot reach the dask scheduler at {self.dask_scheduler}: {exc}"
            ) from exc
        with client:
            yield client


@dataclass(frozen=True)
class Runner:
    """How one job kind is submitted, loaded, run and drawn.

    Attributes
    ----------
    kind
        The kind (a key of :data:`RUNNERS`).
    takes_space
        The submission brings an experiment space (``space``) instead of CSV files and held-out
        data; the space is stored in the job's own column (:attr:`fmuid.jobs.records.Job.space`).
    load
        ``load(inputs, job, data)``: ``inputs`` (FMU, spec and held-out data) with the kind's
        own part read: the experiments from the staged CSV files ``data``, or the space.
    run
        ``run(inputs, context)``: the engine's result object.
    draw
        ``draw(result, inputs, directory)``: the HTML report of the result in ``directory``.

    """

    kind: Kind
    takes_space: bool
    load: Callable[[JobInputs, Job, list[Path]], JobInputs]
    run: Callable[[JobInputs, RunContext], Any]
    draw: Callable[[Any, JobInputs, Path], None]


def _experiments(inputs: JobInputs, job: Job, data: list[Path]) -> JobInputs:
    from fmuid.data import load_experiment

    return replace(inputs, experiments=[load_experiment(path) for path in data])


def _space(inputs: JobInputs, job: Job, data: list[Path]) -> JobInputs:
    """Read a design's space from its column, or from its one dataset (stored before the column).

    :mod:`fmuid.experiment_design` is imported for a design job only.
    """
    from fmuid.experiment_design import load_space, space_from_json

    if job.space is not None:
        return replace(inputs, space=space_from_json(job.space, "space"))
    if data:
        return replace(inputs, space=load_space(data[0]))
    raise SpecError(f"job {job.id}: a design job without an experiment space")


def _fit(inputs: JobInputs, context: RunContext) -> Any:
    import fmuid

    return fmuid.fit(
        inputs.fmu,
        inputs.experiments,
        inputs.spec,
        progress=context.progress,
        test_data=inputs.test_data,
    )


def _on_cluster(stage: str) -> Callable[[JobInputs, RunContext], Any]:
    """Run ``fmuid.<stage>`` (profile, diagnose) on the service's dask scheduler if it has one."""

    def run(inputs: JobInputs, context: RunContext) -> Any:
        import fmuid

        with context.executor() as executor:
            return getattr(fmuid, stage)(
                inputs.fmu,
                inputs.experiments,
                inputs.spec,
                progress=context.progress,
                executor=executor,
                test_data=inputs.test_data,
            )

    return run


def _design(inputs: JobInputs, context: RunContext) -> Any:
    import fmuid

    assert inputs.space is not None  # loaded by _space
    with context.executor() as executor:
        return fmuid.design(
            inputs.fmu,
            inputs.spec,
            inputs.space,
            progress=context.progress,
            executor=executor,
            checkpoint=context.checkpoint,
        )


def _draw_study(result: Any, inputs: JobInputs, directory: Path) -> None:
    """Draw a fit, profile or diagnosis: its problem is built from the inputs once."""
    from fmuid.report import write_report

    write_report(
        result, directory, fmu=inputs.fmu, experiments=inputs.experiments, spec=inputs.spec
    )


def _draw_design(result: Any, inputs: JobInputs, directory: Path) -> None:
    """Draw a design: its result holds all the page shows."""
    from fmuid.report import write_report

    write_report(result, directory)


RUNNERS: Mapping[Kind, Runner] = MappingProxyType(
    {
        "fit": Runner("fit", False, _experiments, _fit, _draw_study),
        "profile": Runner("profile", False, _experiments, _on_cluster("profile"), _draw_study),
        "diagnose": Runner("diagnose", False, _experiments, _on_cluster("diagnose"), _draw_study),
        "design": Runner("design", True, _space, _design, _draw_design),
    }
)
"""The runner of every job kind (:data:`fmuid.jobs.records.KINDS`), by kind."""


def runner(kind: str) -> Runner:
    """Return the runner of the job kind ``kind``.

    Raises
    ------
    SpecError
        If ``kind`` is no job kind (the message names it and the kinds).

    """
    try:
        return RUNNERS[kind]  # type: ignore[index]
    except KeyError:
        raise SpecError(
            f"kind: unknown job kind {kind[:100]!r}; the kinds: {', '.join(KINDS)}"
        ) from None
